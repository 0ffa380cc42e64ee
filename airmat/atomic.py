"""Atomic outputs: a reader of an output folder sees the whole old result or the whole new one.

A run writes into a hidden staging folder ``.NAME.staging-XXXXXXXX`` next to
its output folder ``NAME``; only when the whole run succeeded does
:func:`staged_dir` publish it, by exchanging the two directories in one
system call (Linux ``renameat2(RENAME_EXCHANGE)``, macOS
``renamex_np(RENAME_SWAP)``). The old contents, now under the staging name,
are then removed. Whatever instant the process is killed at, ``NAME`` is
complete: the old result, the new one, or (first run) absent.

The output folder is the run's own: publishing replaces it as a whole, so
files in it that the new run does not write are gone afterwards (they are
never mixed with the new ones). :func:`check_out_dir` refuses the folders
where that would destroy something else (the working directory or one
above it, the home folder, the run's own inputs).

Housekeeping and concurrency:

* A run holds an ``flock`` on its staging folder while it lives; the kernel
  drops it when the process dies, even by SIGKILL. The next run on the same
  output removes the staging folders nobody holds (left by killed runs) and
  never one of a live concurrent run.
* Creating a staging folder, sweeping stale ones and publishing happen under
  an ``flock`` on the folder that holds the output (for milliseconds; the
  computations of concurrent runs still overlap). Two runs on one output
  therefore end with one complete result, the one that published last.
* SIGINT and SIGTERM are deferred across the swap itself, so Ctrl-C cannot
  land between its steps, and across the creation of the staging folder, so
  it cannot land before the folder's removal is registered; the interrupt is
  raised right after.

Where no exchange is available (another OS, a file system without it), the
fallback renames the old folder aside and the new one in, under the same
lock and with signals deferred: no mix is possible, but for the microseconds
between the two renames a reader (or a SIGKILL) finds the output absent, and
the old result is then left in a stale staging folder that the next run
removes. A ``current`` symlink swap would close that window, but it would
turn every output folder into a symlink (``rm -r``, ``cp``, archivers treat
it differently), for the benefit of systems the project does not target.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import glob
import logging
import os
import platform
import shutil
import signal
import stat
import sys
import tempfile
import threading
from pathlib import Path
from typing import Callable, Iterable, Iterator

from airmat.errors import InputError

try:  # POSIX only; without it runs are not locked against each other
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

__all__ = ["staged_dir", "check_out_dir", "sweep_stale", "atomic_write_bytes", "atomic_write_text", "signals_deferred"]

log = logging.getLogger(__name__)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# ---------------------------------------------------------------- the exchange

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2  # linux/fs.h
_RENAME_SWAP = 2  # macOS sys/stdio.h
_SYS_RENAMEAT2 = {"x86_64": 316, "aarch64": 276}  # for glibc < 2.28, which lacks the wrapper
_UNSUPPORTED = {errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP}


class ExchangeUnsupported(OSError):
    """The OS or the file system cannot exchange two directories atomically."""


def _find_exchange(*, wrapper: bool = True) -> Callable[[str, str], None] | None:
    """The atomic ``exchange(a, b)`` of this OS through libc, or None.

    ``wrapper=False`` skips glibc's ``renameat2`` wrapper and makes the raw
    system call, as on glibc < 2.28 (a test checks both ways).
    """
    try:
        libc = ctypes.CDLL(None, use_errno=True)
    except OSError:  # pragma: no cover
        return None
    if sys.platform.startswith("linux"):
        if wrapper and hasattr(libc, "renameat2"):
            fn = libc.renameat2
            fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]

            def call(a, b):
                return fn(_AT_FDCWD, a, _AT_FDCWD, b, _RENAME_EXCHANGE)
        elif platform.machine() in _SYS_RENAMEAT2:  # old glibc
            nr = _SYS_RENAMEAT2[platform.machine()]
            fn = libc.syscall
            fn.argtypes = [ctypes.c_long, ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                           ctypes.c_uint]

            def call(a, b):
                return fn(nr, _AT_FDCWD, a, _AT_FDCWD, b, _RENAME_EXCHANGE)
        else:  # pragma: no cover
            return None
    elif sys.platform == "darwin" and hasattr(libc, "renamex_np"):  # pragma: no cover
        fn = libc.renamex_np
        fn.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint]

        def call(a, b):
            return fn(a, b, _RENAME_SWAP)
    else:  # pragma: no cover
        return None

    def exchange(a: str, b: str) -> None:
        if call(os.fsencode(a), os.fsencode(b)) != 0:
            err = ctypes.get_errno()
            cls = ExchangeUnsupported if err in _UNSUPPORTED else OSError
            raise cls(err, os.strerror(err), a, None, b)

    return exchange


#: ``exchange(a, b)`` swaps two paths atomically; None where the OS has no such call
_exchange = _find_exchange()


# ------------------------------------------------------------------- locks

#: staging folders this process holds the lock of: a run staged inside one of them (``demo``
#: stages its whole tree, ``synth`` inside it stages its own folder) is private to this process,
#: so it takes no lock there (flock would wait for our own lock: a deadlock)
_HELD: set = set()


@contextlib.contextmanager
def _locked(path: Path, *, blocking: bool = True) -> Iterator[bool]:
    """Hold an exclusive ``flock`` on the directory ``path``; yields whether it was obtained."""
    if fcntl is None or (blocking and Path(path) in _HELD):  # a probe of our own folder still locks
        yield True
        return
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError as err:
        # a lock we wait for (the parent's): run unlocked rather than fail; a probe
        # (is this staging folder free?): say no, so nothing we cannot inspect is removed
        log.debug("cannot open %s to lock it: %s", path, err)
        yield blocking
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
        except BlockingIOError:
            yield False
            return
        except OSError as err:  # pragma: no cover - file systems without flock
            log.debug("cannot lock %s: %s", path, err)
        yield True
    finally:
        os.close(fd)


def _staging_prefix(out: Path) -> str:
    return f".{out.name}.staging-"


def sweep_stale(out: str | os.PathLike) -> list[Path]:
    """Remove the staging folders of ``out`` that no live run holds.

    Parameters
    ----------
    out : path
        An output folder (need not exist).

    Returns
    -------
    list of Path
        The folders removed. A staging folder whose owner is alive (it holds
        the folder's ``flock``) is kept. Call it under the parent's lock, as
        :func:`staged_dir` does, so a folder being created is never taken for
        a stale one.
    """
    out = Path(os.path.realpath(out))
    removed = []
    try:
        candidates = sorted(out.parent.glob(glob.escape(_staging_prefix(out)) + "*"))
    except OSError:  # pragma: no cover
        return removed
    for path in candidates:
        if path.is_symlink() or not path.is_dir():
            continue
        with _locked(path, blocking=False) as free:
            if free:
                shutil.rmtree(path, ignore_errors=True)
                removed.append(path)
    if removed:
        log.debug("removed %d staging folder(s) left by interrupted runs next to %s", len(removed), out)
    return removed


# ------------------------------------------------------------ signals

@contextlib.contextmanager
def signals_deferred(signums: Iterable[int] = (signal.SIGINT, signal.SIGTERM)) -> Iterator[None]:
    """Hold SIGINT/SIGTERM for the duration of the block, then deliver the first one that came.

    Only the main thread can install handlers; elsewhere the block runs as is
    (Python delivers signals to the main thread only anyway).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {}
    for signum in signums:
        if signal.getsignal(signum) is not None:  # None: a handler Python did not install; leave it
            previous[signum] = signal.signal(signum, lambda n, frame: caught.append(n))
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if caught:
            signal.raise_signal(caught[0])


# ------------------------------------------------------------ checks

def _protected(out: Path) -> str | None:
    """Why replacing the folder ``out`` as a whole would destroy more than a result, or None."""
    cwd = Path(os.path.realpath(os.getcwd()))
    if out == cwd or out in cwd.parents:
        return "is the working folder or contains it"
    if out == Path(os.path.realpath(Path.home())) or out.parent == out:
        return "is the home folder or the root"
    return None


def check_out_dir(out: str | os.PathLike, *, inputs: Iterable[str | os.PathLike | None] = ()) -> Path:
    """Check, before any computation, that ``out`` can become this run's output folder.

    Parameters
    ----------
    out : path
        The output folder (``--out``). It may be missing; the folders above it
        are created when the run publishes.
    inputs : iterable of path or None, optional
        The run's input files and folders (None entries are skipped). The
        output replaces ``out`` as a whole, so ``out`` may neither be one of
        them nor contain one.

    Returns
    -------
    Path
        ``out`` with symlinks resolved: the folder that will be replaced.

    Raises
    ------
    InputError
        With ``path=out``: ``out`` is an existing file; a folder above it is
        a file or cannot be written to; ``out`` is a mount point, or is or
        holds the working folder, the home folder, the root, or an input.
    """
    real = Path(os.path.realpath(out))
    if os.path.lexists(out) and not real.is_dir():
        raise InputError("exists and is not a folder; give a folder for the output", path=out)
    if os.path.ismount(real):
        raise InputError("is a mount point; the output replaces its folder as a whole, give a folder "
                         "inside it", path=out)
    why = _protected(real)
    if why:
        raise InputError(f"{why}; the output replaces its folder as a whole, give a folder of its own",
                         path=out)
    for item in inputs:
        if item is None:
            continue
        src = Path(os.path.realpath(item))
        if src == real or real in src.parents:
            raise InputError(f"holds the input {item}; the output replaces its folder as a whole, "
                             "give another folder", path=out)
    above = real.parent
    while not above.exists():
        above = above.parent
    if not above.is_dir():
        raise InputError(f"cannot create the folder: {above} is a file", path=out)
    if not os.access(above, os.W_OK | os.X_OK, effective_ids=os.access in os.supports_effective_ids):
        raise InputError(f"cannot write the output: no write permission in {above}", path=out)
    return real


# ------------------------------------------------------------ publishing

def _prepare(tmp: Path, out: Path) -> None:
    """Give the staged tree ordinary permissions (and the old folder's own, when there is one)."""
    umask = _umask()
    for root, _, files in os.walk(tmp):
        for name in files:
            os.chmod(os.path.join(root, name), 0o666 & ~umask)
    try:
        mode = stat.S_IMODE(os.stat(out).st_mode)
    except FileNotFoundError:
        mode = 0o777 & ~umask  # mkdtemp made it 0700
    os.chmod(tmp, mode)


def _swap(tmp: Path, out: Path, *, replace: bool) -> None:
    """Put ``tmp`` at ``out`` in one step; the old ``out`` (``replace``: there is one) ends up at ``tmp``."""
    if not replace:
        os.rename(tmp, out)
        return
    if _exchange is not None:
        try:
            _exchange(str(tmp), str(out))
            return
        except ExchangeUnsupported as err:
            log.debug("no atomic exchange here (%s); renaming aside", err)
    aside = tmp.with_name(tmp.name + ".old")  # still a staging name: swept if we die in between
    os.rename(out, aside)
    try:
        os.rename(tmp, out)
    except BaseException:
        os.rename(aside, out)
        raise
    os.rename(aside, tmp)


def _swap_uninterrupted(tmp: Path, out: Path, *, replace: bool) -> None:
    """:func:`_swap` with SIGINT/SIGTERM deferred: Ctrl-C cannot land between its steps."""
    with signals_deferred():
        _swap(tmp, out, replace=replace)


def _publish(tmp: Path, out: Path, parent: Path) -> None:
    _prepare(tmp, out)
    with _locked(parent):  # between looking at out and swapping, no other run may publish
        replace = os.path.lexists(out)
        if replace and not out.is_dir():  # made a file while we computed
            raise InputError("exists and is not a folder; give a folder for the output", path=out)
        _swap_uninterrupted(tmp, out, replace=replace)


@contextlib.contextmanager
def staged_dir(out: str | os.PathLike) -> Iterator[Path]:
    """Stage every output of a run and publish them as ``out`` in one step on success.

    Parameters
    ----------
    out : path
        The output folder; it and the folders above it are created when
        missing. On success it is replaced as a whole: files in it that this
        run does not write are removed.

    Yields
    ------
    Path
        A private staging folder next to ``out``; write the run's files there
        under their final names (sub-folders allowed). On normal exit it
        becomes ``out`` atomically (see the module notes); on an exception it
        is removed and ``out`` is left exactly as it was.

    Raises
    ------
    InputError
        ``out`` cannot be an output folder (see :func:`check_out_dir`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as d:
    ...     with staged_dir(pathlib.Path(d) / "run") as tmp:
    ...         _ = (tmp / "a.txt").write_text("new")
    ...     sorted(p.name for p in pathlib.Path(d).iterdir())
    ['run']
    """
    out = check_out_dir(out)
    parent = out.parent
    parent.mkdir(parents=True, exist_ok=True)
    with contextlib.ExitStack() as stack:
        with _locked(parent):
            sweep_stale(out)
            # a Ctrl-C between creating the folder and registering its removal would leave it
            # behind: the two happen with SIGINT/SIGTERM deferred, the interrupt comes right after
            with signals_deferred():
                tmp = Path(tempfile.mkdtemp(prefix=_staging_prefix(out), dir=parent))
                # held until the run ends: tells other runs' sweeps that this folder is alive
                stack.enter_context(_locked(tmp))
                # removed while still locked: the failed run's files, or the old result
                stack.callback(shutil.rmtree, tmp, ignore_errors=True)
                _HELD.add(tmp)
                stack.callback(_HELD.discard, tmp)
        yield tmp
        _publish(tmp, out, parent)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and an atomic rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = tmp = None
    try:
        with signals_deferred():   # a Ctrl-C right after mkstemp comes once tmp is known, so it is removed
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        with os.fdopen(fd, "wb") as fh:
            fd = None   # the file object closes it
            fh.write(data)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; outputs are ordinary files
        os.replace(tmp, path)
    except BaseException:
        if fd is not None:
            with contextlib.suppress(OSError):
                os.close(fd)
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
        raise


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))

