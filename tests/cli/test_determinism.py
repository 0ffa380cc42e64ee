"""Same inputs and seed, same bytes: a synth -> calibrate -> design -> inflate chain run twice.

Every file of every output folder must be identical, except the one
``timings_s`` field at the top of each JSON document (wall-clock seconds);
the .3dm files too (their time stamps are fixed by airmat.design.export.rhino_stable).
Both chains use the same relative paths (each from its own working folder),
since the documents record where their inputs were.
"""

import json

import pytest

from airmat.cli import main

CHAIN = [
    ["synth", "set", "--points", "10000", "--l-over-L", "0.4,0.6,0.8,0.9", "--seed", "7"],
    ["calibrate", "set/manifest.csv", "--out", "cal", "--walkers", "16", "--max-steps", "200", "--seed", "7"],
    ["design", "--preset", "vault1", "--spacing-mm", "40", "--calibration", "cal", "--out", "design", "--seed", "7"],
    ["inflate", "design", "--out", "inflate", "--resolution-mm", "60", "--jobs", "1", "--seed", "7"],
]


def _run_chain(folder, monkeypatch):
    folder.mkdir()
    monkeypatch.chdir(folder)
    codes = [main(argv + ["-q"]) for argv in CHAIN]
    assert codes[0] == 0 and codes[2] == 0 and codes[3] == 0
    assert codes[1] in (0, 3)               # 200 steps: the MCMC may be reported as not converged
    return {p.relative_to(folder): p for p in sorted(folder.rglob("*")) if p.is_file()}


def _without_timings(path):
    doc = json.loads(path.read_text())
    timings = doc.pop("timings_s", None)
    return doc, timings


@pytest.mark.slow  # two chains, about 30 s
def test_same_seed_same_bytes(tmp_path, monkeypatch, capsys):
    a = _run_chain(tmp_path / "a", monkeypatch)
    b = _run_chain(tmp_path / "b", monkeypatch)
    capsys.readouterr()
    assert sorted(a) == sorted(b)
    names = {p.name for p in a}
    assert {"calibration.json", "posterior.npz", "design.json", "pattern.dxf", "design.3dm", "inflate.json",
            "inflated.ply", "inflated.3dm", "deviation.png", "corner.png"} <= names
    timed = set()
    for rel in a:
        if rel.suffix == ".json":
            (doc_a, t_a), (doc_b, t_b) = _without_timings(a[rel]), _without_timings(b[rel])
            assert doc_a == doc_b, rel
            if t_a is not None:
                timed.add(rel.name)
                assert set(t_a) == set(t_b)
        else:
            assert a[rel].read_bytes() == b[rel].read_bytes(), rel
    assert {"calibration.json", "inflate.json"} <= timed
    for rel, path in a.items():             # no key outside timings_s names a wall-clock quantity
        if rel.suffix == ".json":
            bad = [k for k in _keys(json.loads(path.read_text())) if "second" in k or k.endswith("_s")]
            assert bad == [], (rel, bad)


def _keys(node):
    if isinstance(node, dict):
        for k, v in node.items():
            if k != "timings_s":
                yield k
                yield from _keys(v)
    elif isinstance(node, list):
        for v in node:
            yield from _keys(v)
