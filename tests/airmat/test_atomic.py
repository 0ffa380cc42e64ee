"""Atomic outputs: a failed run leaves nothing behind; a reader sees the whole old result or the whole new one."""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import airmat.atomic as atomic
from airmat.atomic import atomic_write_text, check_out_dir, staged_dir, sweep_stale
from airmat.errors import InputError


def test_staged_dir_publishes_on_success(tmp_path):
    out = tmp_path / "out"
    with staged_dir(out) as tmp:
        (tmp / "a.json").write_text("{}")
        (tmp / "sub").mkdir()
        (tmp / "sub" / "b.csv").write_text("x\n")
        assert not out.exists()  # nothing visible before success
    assert (out / "a.json").read_text() == "{}"
    assert (out / "sub" / "b.csv").read_text() == "x\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out"]  # staging folder removed


def test_staged_dir_failure_keeps_previous_output(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.json").write_text("good")
    with pytest.raises(RuntimeError):
        with staged_dir(out) as tmp:
            (tmp / "a.json").write_text("half")
            (tmp / "new.png").write_bytes(b"\x89PNG")
            raise RuntimeError("boom")
    assert (out / "a.json").read_text() == "good"
    assert sorted(p.name for p in out.iterdir()) == ["a.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_failure_on_fresh_output_creates_nothing(tmp_path):
    out = tmp_path / "fresh"
    with pytest.raises(ValueError):
        with staged_dir(out) as tmp:
            (tmp / "x").write_text("1")
            raise ValueError
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_text_replaces_whole_file(tmp_path):
    p = tmp_path / "f.txt"
    atomic_write_text(p, "one")
    atomic_write_text(p, "two")
    assert p.read_text() == "two"
    assert [q.name for q in tmp_path.iterdir()] == ["f.txt"]


def test_outputs_are_ordinary_readable_files(tmp_path):
    import stat
    p = tmp_path / "f.txt"
    atomic_write_text(p, "x")
    with staged_dir(tmp_path / "out") as tmp:
        (tmp / "g.txt").write_text("y")
    for f in (p, tmp_path / "out" / "g.txt"):
        assert os.stat(f).st_mode & stat.S_IROTH


# ---------------------------------------------------------------- whole-folder swap

def _tree(folder):
    return {str(p.relative_to(folder)): p.read_text() for p in sorted(Path(folder).rglob("*")) if p.is_file()}


def _old(out):
    out.mkdir()
    (out / "a.json").write_text("old a")
    (out / "only_old.txt").write_text("old")
    (out / "sub").mkdir()
    (out / "sub" / "b.csv").write_text("old b")


def _write_new(tmp):
    (tmp / "a.json").write_text("new a")
    (tmp / "sub").mkdir()
    (tmp / "sub" / "b.csv").write_text("new b")


NEW = {"a.json": "new a", "sub/b.csv": "new b"}
OLD = {"a.json": "old a", "only_old.txt": "old", "sub/b.csv": "old b"}


@pytest.mark.parametrize("exchange", ["renameat2", "unsupported", "none"])
def test_success_replaces_the_old_folder_as_a_whole(tmp_path, monkeypatch, exchange):
    if exchange == "unsupported":  # a file system without RENAME_EXCHANGE: the rename-aside fallback
        def refuse(a, b):
            raise atomic.ExchangeUnsupported(22, "Invalid argument", a, None, b)
        monkeypatch.setattr(atomic, "_exchange", refuse)
    elif exchange == "none":
        monkeypatch.setattr(atomic, "_exchange", None)
    else:
        assert atomic._exchange is not None, "renameat2 should be found on Linux with glibc >= 2.28"
    out = tmp_path / "out"
    _old(out)
    os.chmod(out, 0o750)
    with staged_dir(out) as tmp:
        _write_new(tmp)
        assert _tree(out) == OLD  # nothing visible before success
    assert _tree(out) == NEW  # only_old.txt is gone: the folder is the run's
    assert (os.stat(out).st_mode & 0o777) == 0o750  # the folder keeps its permissions
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


@pytest.mark.parametrize("wrapper", [True, False], ids=["glibc-wrapper", "raw-syscall"])
def test_exchange_swaps_two_folders(tmp_path, wrapper):
    exchange = atomic._find_exchange(wrapper=wrapper)
    if exchange is None:
        pytest.skip("no renameat2 system call known on this machine")
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "x").write_text("a")
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "y").write_text("b")
    exchange(str(tmp_path / "a"), str(tmp_path / "b"))
    assert _tree(tmp_path) == {"a/y": "b", "b/x": "a"}
    with pytest.raises(FileNotFoundError):
        exchange(str(tmp_path / "a"), str(tmp_path / "missing"))


def test_a_symlinked_out_keeps_its_link_and_gets_the_new_result(tmp_path):
    real = tmp_path / "real"
    _old(real)
    (tmp_path / "link").symlink_to(real)
    with staged_dir(tmp_path / "link") as tmp:
        _write_new(tmp)
    assert (tmp_path / "link").is_symlink()
    assert _tree(real) == NEW
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real"]


def test_failed_swap_leaves_the_old_folder_untouched(tmp_path, monkeypatch):
    def broken(a, b):
        raise OSError(5, "Input/output error", a, None, b)
    monkeypatch.setattr(atomic, "_exchange", broken)
    out = tmp_path / "out"
    _old(out)
    with pytest.raises(OSError, match="Input/output"):
        with staged_dir(out) as tmp:
            _write_new(tmp)
    assert _tree(out) == OLD
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_publish_refuses_an_out_that_became_a_file(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(InputError, match="not a folder"):
        with staged_dir(out) as tmp:
            _write_new(tmp)
            out.write_text("someone else's file")
    assert out.read_text() == "someone else's file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# ---------------------------------------------------------------- Ctrl-C during the swap

def testsignals_deferred_delivers_after_the_block():
    seen = []
    with pytest.raises(KeyboardInterrupt):
        with atomic.signals_deferred():
            os.kill(os.getpid(), signal.SIGINT)
            seen.append("still running")
    assert seen == ["still running"]


@pytest.mark.parametrize("exchange", ["renameat2", "none"])
def test_ctrl_c_inside_the_swap_leaves_old_or_new(tmp_path, monkeypatch, exchange):
    """SIGINT right after the first rename of the swap: without deferral the
    fallback would leave ``out`` missing (old aside, new not in yet)."""
    if exchange == "none":
        monkeypatch.setattr(atomic, "_exchange", None)
    real_rename, real_exchange = os.rename, atomic._exchange

    def rename_then_sigint(a, b):
        real_rename(a, b)
        os.kill(os.getpid(), signal.SIGINT)
    monkeypatch.setattr(os, "rename", rename_then_sigint)
    if real_exchange is not None:
        monkeypatch.setattr(atomic, "_exchange", lambda a, b: (real_exchange(a, b),
                                                               os.kill(os.getpid(), signal.SIGINT)))
    out = tmp_path / "out"
    _old(out)
    with pytest.raises(KeyboardInterrupt):
        with staged_dir(out) as tmp:
            _write_new(tmp)
    assert _tree(out) == NEW
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def _sigint_after(monkeypatch, name):
    """Make ``tempfile.<name>`` deliver SIGINT to this process the instant it has made its file or folder."""
    real = getattr(atomic.tempfile, name)

    def then_sigint(*args, **kwargs):
        made = real(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGINT)
        return made
    monkeypatch.setattr(atomic.tempfile, name, then_sigint)


def test_ctrl_c_right_after_the_staging_folder_is_made_leaves_nothing(tmp_path, monkeypatch):
    """SIGINT the instant ``mkdtemp`` returns, before the folder's removal was
    registered: without deferral the folder stayed behind (CI saw it once when
    the kill test interrupted a run as soon as its staging folder appeared)."""
    _sigint_after(monkeypatch, "mkdtemp")
    out = tmp_path / "out"
    _old(out)
    body = []
    with pytest.raises(KeyboardInterrupt):
        with staged_dir(out):
            body.append("ran")
    assert body == []  # the interrupt came before the run's body
    assert _tree(out) == OLD
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert not atomic._HELD


def test_ctrl_c_right_after_an_atomic_writes_temporary_file_is_made_leaves_nothing(tmp_path, monkeypatch):
    _sigint_after(monkeypatch, "mkstemp")
    target = tmp_path / "a.json"
    target.write_text("old")
    with pytest.raises(KeyboardInterrupt):
        atomic_write_text(target, "new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"] and target.read_text() == "old"


# ---------------------------------------------------------------- stale staging folders

_HOLD = """
import fcntl, os, sys, time
fd = os.open(sys.argv[1], os.O_RDONLY | os.O_DIRECTORY)
fcntl.flock(fd, fcntl.LOCK_EX)
print("locked", flush=True)
time.sleep(60)
"""


def test_stale_staging_of_a_dead_run_is_removed_a_live_one_kept(tmp_path):
    out = tmp_path / "out"
    dead = tmp_path / ".out.staging-dead1234"
    live = tmp_path / ".out.staging-live1234"
    other = tmp_path / ".other.staging-dead1234"  # another output's: not ours to judge
    for folder in (dead, live, other):
        folder.mkdir()
        (folder / "partial.ply").write_bytes(b"ply\n")
    owner = subprocess.Popen([sys.executable, "-c", _HOLD, str(live)], stdout=subprocess.PIPE, text=True)
    try:
        assert owner.stdout.readline().strip() == "locked"
        with staged_dir(out) as tmp:
            _write_new(tmp)
        assert not dead.exists()
        assert (live / "partial.ply").exists()  # its run is alive
        assert other.exists()
    finally:
        owner.kill()
        owner.wait()
        owner.stdout.close()
    assert sweep_stale(out) == [live]  # the owner is gone now
    assert sorted(p.name for p in tmp_path.iterdir()) == [".other.staging-dead1234", "out"]
    assert _tree(out) == NEW


def test_sweep_keeps_the_staging_folder_of_a_running_stage(tmp_path):
    out = tmp_path / "out"
    with staged_dir(out) as tmp:
        (tmp / "a.json").write_text("x")
        assert sweep_stale(out) == []
        assert tmp.exists()
    assert _tree(out) == {"a.json": "x"}


# ---------------------------------------------------------------- concurrent runs

def test_concurrent_runs_on_one_out_end_with_one_whole_result(tmp_path, monkeypatch):
    swap = atomic._swap_uninterrupted

    def slowed(*args, **kwargs):  # widen the publish so they overlap
        time.sleep(0.02)
        swap(*args, **kwargs)
        time.sleep(0.02)
    monkeypatch.setattr(atomic, "_swap_uninterrupted", slowed)
    out = tmp_path / "fresh" / "out"  # missing: the first publish is a plain rename
    barrier = threading.Barrier(4)
    errors = []

    def run(i):
        try:
            with staged_dir(out) as tmp:
                for k in range(20):
                    (tmp / f"f{k:02d}.txt").write_text(str(i))
                barrier.wait()
        except BaseException as err:  # reported below
            errors.append(err)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    tree = _tree(out)
    assert len(tree) == 20 and len(set(tree.values())) == 1  # one run's files, all of them
    assert sorted(p.name for p in out.parent.iterdir()) == ["out"]


# ---------------------------------------------------------------- check_out_dir

def test_check_out_dir_accepts_missing_and_existing_folders(tmp_path):
    assert check_out_dir(tmp_path / "a" / "b" / "c") == (tmp_path / "a" / "b" / "c").resolve()
    (tmp_path / "d").mkdir()
    assert check_out_dir(tmp_path / "d") == (tmp_path / "d").resolve()
    assert not (tmp_path / "a").exists()  # checking creates nothing


def test_check_out_dir_refuses_a_file(tmp_path):
    f = tmp_path / "f.txt"
    f.write_text("keep")
    with pytest.raises(InputError, match="not a folder") as info:
        check_out_dir(f)
    assert info.value.path == str(f)
    with pytest.raises(InputError, match="is a file") as info:
        check_out_dir(f / "sub" / "out")
    assert info.value.path == str(f / "sub" / "out")
    assert f.read_text() == "keep"


def test_check_out_dir_refuses_folders_a_swap_would_destroy(tmp_path, monkeypatch):
    (tmp_path / "work" / "inputs").mkdir(parents=True)
    (tmp_path / "work" / "inputs" / "manifest.csv").write_text("x")
    monkeypatch.chdir(tmp_path / "work")
    for out in (".", "..", str(tmp_path)):
        with pytest.raises(InputError, match="working folder"):
            check_out_dir(out)
    (tmp_path / "home").mkdir()
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    with pytest.raises(InputError, match="home folder or the root"):
        check_out_dir(tmp_path / "home")
    with pytest.raises(InputError, match="mount point"):
        check_out_dir("/proc")
    with pytest.raises(InputError, match="holds the input"):
        check_out_dir("inputs", inputs=["inputs/manifest.csv"])
    with pytest.raises(InputError, match="holds the input"):
        check_out_dir("inputs", inputs=[None, "inputs"])
    assert check_out_dir("elsewhere", inputs=[None, "inputs/manifest.csv"]).name == "elsewhere"


_CHECK = """
import sys
from airmat.atomic import check_out_dir
from airmat.errors import InputError
try:
    check_out_dir(sys.argv[1])
except InputError as err:
    print(err.one_line())
"""


def test_check_out_dir_refuses_an_unwritable_parent(tmp_path):
    (tmp_path / "ro").mkdir()
    os.chmod(tmp_path / "ro", 0o555)
    target = tmp_path / "ro" / "new" / "out"
    try:
        if os.geteuid() != 0:
            with pytest.raises(InputError, match="no write permission") as info:
                check_out_dir(target)
            assert info.value.path == str(target)
            return
        # root writes anywhere: ask from a process without the capabilities that allow it
        import shutil
        if shutil.which("setpriv") is None:
            pytest.skip("running as root without setpriv to drop CAP_DAC_OVERRIDE")
        root = Path(atomic.__file__).resolve().parents[1]
        res = subprocess.run(["setpriv", "--bounding-set", "-dac_override,-dac_read_search", sys.executable,
                              "-c", _CHECK, str(target)], capture_output=True, text=True,
                             env={**os.environ, "PYTHONPATH": str(root)}, timeout=60)
        if res.returncode != 0:
            pytest.skip(f"setpriv cannot drop capabilities here: {res.stderr.strip()}")
        assert res.stdout.strip() == f"{target}: cannot write the output: no write permission in {tmp_path / 'ro'}"
    finally:
        os.chmod(tmp_path / "ro", 0o755)


def test_a_run_staged_inside_another_runs_staging_folder_does_not_wait_for_itself(tmp_path):
    """demo stages its whole tree and synth stages its own folder inside it: no deadlock, one tree."""
    import threading

    done = []

    def nested():
        with staged_dir(tmp_path / "demo") as outer:
            with staged_dir(outer / "synth") as inner:
                (inner / "a.txt").write_text("scan")
            (outer / "b.txt").write_text("report")
        done.append(True)

    t = threading.Thread(target=nested, daemon=True)
    t.start()
    t.join(timeout=20)
    assert done, "nested staged_dir did not finish: it waits for its own lock"
    assert (tmp_path / "demo" / "synth" / "a.txt").read_text() == "scan"
    assert (tmp_path / "demo" / "b.txt").read_text() == "report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo"]


def test_listed_names_the_folder_first_given_then_sorted_subfolders_marked(tmp_path):
    from airmat.listing import listed

    for name in ("b.png", "a.csv", "main.json", "z.txt"):
        (tmp_path / name).write_text("x")
    (tmp_path / "sub").mkdir()
    assert listed(tmp_path, ("main.json", "missing.ply", "z.txt")) == "main.json, z.txt, a.csv, b.png, sub/"
    assert listed(tmp_path) == "a.csv, b.png, main.json, sub/, z.txt"
