"""Bad input, one table per subcommand: exit 2, exactly one stderr line naming the file or option, no --out.

Every case is a mistake a new user makes: a negative
seed, a wrong-typed truth file, a target without a surface, a damaged
calibration or design folder, an absurd physical value, a mesh too fine to
solve. Each is refused before any heavy work, so the table runs in seconds;
the folders it damages are made once per module (a small synthetic
calibration, a coarse vault1 design).
"""

import json
import shutil

import pytest

from airmat.cli import main

NAN = float("nan")


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    """A synthetic set, its calibration and a coarse design, from the command line (a few seconds)."""
    root = tmp_path_factory.mktemp("good")
    assert main(["synth", str(root / "set"), "--points", "10000", "--l-over-L", "0.4,0.6,0.8,0.9", "-q"]) == 0
    assert main(["calibrate", str(root / "set" / "manifest.csv"), "--out", str(root / "cal"),
                 "--walkers", "16", "--max-steps", "200", "-q"]) in (0, 3)
    assert main(["design", "--preset", "vault1", "--spacing-mm", "40", "--out", str(root / "design"), "-q"]) == 0
    (root / "line.obj").write_text("".join(f"v {80 * i} {70 * i} 0\n" for i in range(10))
                                   + "".join(f"f {i} {i + 1} {i + 2}\n" for i in range(1, 9)))
    (root / "flat_faces.obj").write_text(   # points spread over the plane, every face a straight row
        "".join(f"v {160 * i} {140 * j} 0\n" for j in range(6) for i in range(6))
        + "".join(f"f {6 * j + i + 1} {6 * j + i + 2} {6 * j + i + 3}\n" for j in range(6) for i in range(4)))
    (root / "cut.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                  "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                  "end_header\n0 0 0\n800 0 0\n0 700 0\n3 0 1\n")   # a copy that stopped
    sheet = "".join(f"v {400 * i} {350 * j} {-100 * (i == 1)}\n" for j in range(3) for i in range(3))
    quads = [(3 * j + i + 1, 3 * j + i + 2, 3 * j + i + 5, 3 * j + i + 4) for j in range(2) for i in range(2)]
    faces = "".join(f"f {a} {b} {c}\nf {a} {c} {d}\n" for a, b, c, d in quads)
    lifted = "".join(f"v {400 * i} {350 * j} {70 - 100 * (i == 1)}\n" for j in range(3) for i in range(3))
    faces2 = "".join(f"f {a + 9} {b + 9} {c + 9}\nf {a + 9} {c + 9} {d + 9}\n" for a, b, c, d in quads)
    (root / "two_sheets.obj").write_text(sheet + faces + lifted + faces2)   # both faces of a thickened vault
    scan = (root / "set" / "specimen_00.ply").read_bytes()
    (root / "cut_scan.ply").write_bytes(scan[:len(scan) // 2])
    assert b"format binary_little_endian" in scan[:200]
    (root / "swapped.ply").write_bytes(scan.replace(b"format binary_little_endian", b"format binary_big_endian", 1))
    return root


def _json_edit(path, edit):
    doc = json.loads(path.read_text())
    edit(doc)
    path.write_text(json.dumps(doc))


def _copy(good, tmp_path, name):
    dst = tmp_path / name
    shutil.copytree(good / name, dst)
    return dst


def _set(doc, keys, value):
    node = doc
    for k in keys[:-1]:
        node = node[k]
    node[keys[-1]] = value


def bad_cal(edit):
    """A calibration folder damaged by ``edit(folder)``."""
    def make(good, tmp_path):
        folder = _copy(good, tmp_path, "cal")
        edit(folder)
        return str(folder)
    return make


def cal_json(keys, value):
    return bad_cal(lambda f: _json_edit(f / "calibration.json", lambda d: _set(d, keys, value)))


def bad_design(edit):
    """A design folder damaged by ``edit(folder)``."""
    def make(good, tmp_path):
        folder = _copy(good, tmp_path, "design")
        edit(folder)
        return str(folder)
    return make


def dash0(key, value):
    return bad_design(lambda f: _json_edit(f / "design.json", lambda d: d["dashes"][0].__setitem__(key, value)))


def truth(text):
    def make(good, tmp_path):
        p = tmp_path / "truth.json"
        p.write_text(text)
        return str(p)
    return make


def target(name):
    return lambda good, tmp_path: str(good / name)


MANIFEST = lambda good, tmp_path: str(good / "set" / "manifest.csv")  # noqa: E731
DESIGN = lambda good, tmp_path: str(good / "design")  # noqa: E731
SCAN = lambda good, tmp_path: str(good / "set" / "specimen_00.ply")  # noqa: E731

# (command, argv with OUT for the output folder and callables for inputs, text the one stderr line holds)
CASES = {
    "fit-seed": ("fit", [SCAN, "--seed", "-1"], "--seed: must be in [0, 2**32), got -1"),
    "fit-noise": ("fit", [SCAN, "--noise-mm", "0"], "--noise-mm must be > 0"),
    "fit-cut": ("fit", [target("cut_scan.ply")], "cut_scan.ply: truncated PLY: the header declares"),
    "fit-byte-order": ("fit", [target("swapped.ply")], "swapped.ply: the vertices do not read as coordinates in "
                       "the header's byte order (binary_big_endian: the first is"),
    "synth-seed": ("synth", ["OUT", "--seed", "-1"], "--seed: must be in [0, 2**32)"),
    "synth-seed-text": ("synth", ["OUT", "--seed", "one"], "expected an integer"),
    "synth-d": ("synth", ["--out", "OUT", "--thickness-mm", "1e6"], "--thickness-mm: 1e+06 mm is outside [10, 500] mm"),
    "synth-L": ("synth", ["OUT", "--L-mm", "0"], "--L-mm: 0 mm is outside [50, 2000] mm"),
    "synth-ratio": ("synth", ["OUT", "--l-over-L", "0.5,2"], "every ratio l/L must lie in (0, 1)"),
    "synth-delta": ("synth", ["OUT", "--delta-mm", "-1"], "--delta-mm: -1 mm is outside [0, L/2)"),
    "synth-scatter": ("synth", ["OUT", "--scatter", "5"], "--scatter: 5 is outside [0, 1]"),
    "synth-points": ("synth", ["OUT", "--points", "10"], "--points: 10 points is outside [10000, 1e+07] points"),
    "calibrate-seed": ("calibrate", [MANIFEST, "--out", "OUT", "--seed", "-1"], "--seed: must be in"),
    "calibrate-truth-str": ("calibrate", [MANIFEST, "--out", "OUT", "--truth", truth('{"delta_mm": "18", "d_mm": 70}')],
                            "truth.json: field 'delta_mm' must be a finite number, got '18'"),
    "calibrate-truth-list": ("calibrate", [MANIFEST, "--out", "OUT", "--truth", truth('{"delta_mm": 18, "d_mm": [70]}')],
                             "truth.json: field 'd_mm' must be a finite number, got [70]"),
    "calibrate-truth-nan": ("calibrate", [MANIFEST, "--out", "OUT", "--truth",
                                          truth('{"delta_mm": 18, "d_mm": 70, "sigma_per_m": NaN}')],
                            "field 'sigma_per_m' must be a finite number, got nan"),
    "calibrate-truth-array": ("calibrate", [MANIFEST, "--out", "OUT", "--truth", truth("[18, 70]")],
                              "truth file must be a JSON object"),
    "design-seed": ("design", ["--preset", "vault1", "--out", "OUT", "--seed", "-1"], "--seed: must be in"),
    "design-spacing": ("design", ["--preset", "vault1", "--out", "OUT", "--resolution-mm", "1"],
                       "--resolution-mm 1: mesh spacing 1 mm gives 615771 vertices"),
    "design-thickness": ("design", ["--preset", "vault1", "--out", "OUT", "--thickness-mm", "1e6"],
                         "--thickness-mm: 1e+06 mm is outside [10, 500] mm"),
    "design-collinear": ("design", [target("line.obj"), "--mattress", "830x740", "--out", "OUT"],
                         "line.obj: the target has no surface: 8 of 8 faces are degenerate"),
    "design-cut": ("design", [target("cut.ply"), "--mattress", "830x740", "--out", "OUT"],
                   "cut.ply: truncated PLY: last 'face' row has 3 values, expected 4"),
    "design-two-sheets": ("design", [target("two_sheets.obj"), "--mattress", "830x740", "--out", "OUT"],
                          "two_sheets.obj: the target is 2 separate sheets (50 %, 50 % of its area; the nearest "
                          "to the largest is 70 mm from it)"),
    "design-mattress-metres": ("design", [target("line.obj"), "--mattress", "0.83x0.74", "--out", "OUT"],
                               "--mattress: 0.83 x 0.74 mm is outside [50, 20000] mm per side; sizes are in mm: "
                               "for a 0.83 x 0.74 m mattress give 830x740"),
    "design-degenerate": ("design", [target("flat_faces.obj"), "--mattress", "830x740", "--out", "OUT"],
                          "flat_faces.obj: the target has no surface: 24 of 24 faces"),
    "design-cal-L-text": ("design", ["--preset", "vault1", "--out", "OUT", "--calibration",
                                     cal_json(["curve", "L_mm"], "abc")],
                          "calibration.json: field 'curve.L_mm' must be a positive number (mm), got 'abc'"),
    "design-cal-L-list": ("design", ["--preset", "vault1", "--out", "OUT", "--calibration",
                                     cal_json(["curve", "L_mm"], [300])],
                          "calibration.json: field 'curve.L_mm' must be a positive number (mm), got [300]"),
    "design-cal-nan": ("design", ["--preset", "vault1", "--out", "OUT", "--calibration",
                                  cal_json(["parameters", "d_mm", "median"], NAN)],
                       "calibration.json: field 'parameters.d_mm.median' must be a finite number, got nan"),
    "design-npz-empty": ("design", ["--preset", "vault1", "--out", "OUT", "--calibration",
                                    bad_cal(lambda f: (f / "posterior.npz").write_bytes(b""))],
                         "posterior.npz: not readable as .npz: empty file"),
    "design-npz-truncated": ("design", ["--preset", "vault1", "--out", "OUT", "--calibration",
                                        bad_cal(lambda f: (f / "posterior.npz").write_bytes(
                                            (f / "posterior.npz").read_bytes()[:1000]))],
                             "posterior.npz: not readable as .npz"),
    "inflate-seed": ("inflate", [DESIGN, "--out", "OUT", "--seed", "-1"], "--seed: must be in"),
    "inflate-pressure": ("inflate", [DESIGN, "--out", "OUT", "--pressure-pa", "1e12"],
                         "--pressure-pa: 1e+12 Pa is outside (0, 100000] Pa"),
    "inflate-a-text": ("inflate", [dash0("a_mm", "abc"), "--out", "OUT"], "design.json: dash k1-"),
    "inflate-polyline-empty": ("inflate", [dash0("polyline_mm", []), "--out", "OUT"],
                               "polyline_mm must be a non-empty list of [u, v] points"),
    "inflate-polyline-nan": ("inflate", [dash0("polyline_mm", [[10.0, 10.0], [NAN, 20.0], [30.0, 30.0]]),
                                         "--out", "OUT"], "polyline_mm has a non-finite coordinate"),
    "inflate-outside": ("inflate", [dash0("a_mm", [5000.0, 10.0]), "--out", "OUT"],
                        "design.json: string k1-"),
    "inflate-surface-cut": ("inflate", [bad_design(lambda f: (f / "approx_surface.ply").write_bytes(
        (f / "approx_surface.ply").read_bytes()[:-100])), "--out", "OUT"],
        "approx_surface.ply: truncated PLY: the header declares"),
    "inflate-samples": ("inflate", [bad_design(lambda f: (f / "calibration_samples.npz").write_bytes(b"PK\x03")),
                                    "--out", "OUT"], "calibration_samples.npz: not readable"),
    "design-unknown-option": ("design", ["--preset", "vault1", "--out", "OUT", "--target-file"],
                              "airmat design: unrecognized arguments: --target-file"),
    "inflate-unknown-option": ("inflate", [DESIGN, "--out", "OUT", "--bogus"], "unrecognized arguments: --bogus"),
    "refine-no-strings": ("refine", [bad_design(lambda f: _json_edit(f / "design.json",
                                                                     lambda d: d.__setitem__("dashes", []))),
                                     "--out", "OUT"], "design.json: the design has no strings: nothing to refine"),
    # a file given for its folder, a folder for a file (the hint names what to give)
    "fit-folder": ("fit", [lambda good, tmp_path: str(good / "set")],
                   "set: is a folder: give one scan file ('airmat calibrate' reads a folder's scans through"),
    "calibrate-folder": ("calibrate", [lambda good, tmp_path: str(good / "set"), "--out", "OUT"],
                         "set: is a folder: give the manifest CSV ("),
    "design-target-folder": ("design", [lambda good, tmp_path: str(good / "set"), "--mattress", "830x740",
                                        "--out", "OUT"], "set: is a folder: give the target's mesh file (.obj"),
    "design-calibration-json": ("design", ["--preset", "vault1", "--out", "OUT", "--calibration",
                                           lambda good, tmp_path: str(good / "cal" / "calibration.json")],
                                "calibration.json: is a file: give the folder that holds calibration.json ("),
    "inflate-design-json": ("inflate", [lambda good, tmp_path: str(good / "design" / "design.json"), "--out", "OUT"],
                            "design.json: is a file: give the folder that holds design.json ("),
    "refine-design-json": ("refine", [lambda good, tmp_path: str(good / "design" / "design.json"), "--out", "OUT"],
                           "design.json: is a file: give the folder that holds design.json ("),
    "validate-seed": ("validate", ["--out", "OUT", "--seed", "-1"], "--seed: must be in"),
    "validate-ratio": ("validate", ["--out", "OUT", "--l-over-L", "2"], "ratios must lie in (0, 1)"),
    "gallery-seed": ("gallery", ["--out", "OUT", "--seed", "-1"], "--seed: must be in"),
    "gallery-presets-empty": ("gallery", ["--out", "OUT", "--presets", ""], "--presets: unknown preset(s) (none"),
    "gallery-resolution": ("gallery", ["--out", "OUT", "--resolution-mm", "0"], "--resolution-mm: 0 mm is outside (0, 75]"),
    "gallery-resolution-coarse": ("gallery", ["--out", "OUT", "--resolution-mm", "100"], "outside (0, 75] mm"),
    "gallery-resolution-nan": ("gallery", ["--out", "OUT", "--resolution-mm", "nan"], "outside (0, 75] mm"),
    "gallery-resolution-fine": ("gallery", ["--out", "OUT", "--presets", "saddle,roof", "--resolution-mm", "1"],
                                "--resolution-mm: 1 mm is too fine for the"),
    "gallery-calibration": ("gallery", ["--out", "OUT", "--calibration", cal_json(["parameters", "delta_mm",
                                                                                   "median"], "x")],
                            "field 'parameters.delta_mm.median' must be a finite number"),
    "demo-seed": ("demo", ["--out", "OUT", "--seed", "-1"], "--seed: must be in"),
    "demo-resolution": ("demo", ["--out", "OUT", "--resolution-mm", "0"], "--resolution-mm: 0 mm is outside (0, 75]"),
    "demo-resolution-inf": ("demo", ["--out", "OUT", "--resolution-mm", "inf"], "outside (0, 75] mm"),
    "demo-resolution-fine": ("demo", ["--out", "OUT", "--resolution-mm", "0.5"], "0.5 mm is too fine for the 830 x"),
    "demo-points": ("demo", ["--out", "OUT", "--points", "10"], "--points: 10 points is outside [10000, 1e+07]"),
    "demo-points-huge": ("demo", ["--out", "OUT", "--points", "100000000"], "--points: 1e+08 points is outside"),
    "demo-jobs": ("demo", ["--out", "OUT", "--jobs", "0"], "--jobs must be at least 1"),
    "demo-preset": ("demo", ["--out", "OUT", "--preset", "nope"], "--preset: unknown preset 'nope'"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input(case, good, tmp_path, capsys):
    command, argv, text = CASES[case]
    out = tmp_path / "out"
    args = [command] + [str(out) if a == "OUT" else a(good, tmp_path) if callable(a) else a for a in argv]
    try:
        code = main(args + ["-q"])
    except SystemExit as exc:   # argparse's refusals (a --seed that is not in range) exit from the parser
        code = exc.code
    cap = capsys.readouterr()
    lines = cap.err.splitlines()
    assert code == 2, cap.err
    assert len(lines) == 1 and lines[0].startswith(f"airmat {command}: "), lines
    assert text in lines[0]
    assert not out.exists()
