"""Every JSON output against its schema in ``airmat/schemas/`` (package data), on the outputs of small real runs.

Also: every schema is a valid JSON Schema (2020-12), every file carries
``schema_version``/``airmat_version`` and holds no bare NaN, and the schemas do
refuse a document that breaks them (they are not vacuous).
"""

import contextlib
import importlib.resources
import io
import json
from pathlib import Path

import pytest

jsonschema = pytest.importorskip("jsonschema")

from airmat.cli import main  # noqa: E402
from airmat.json_doc import SCHEMA_VERSION  # noqa: E402

SCHEMAS = Path(str(importlib.resources.files("airmat") / "schemas"))
OUTPUTS = ("calibration", "design", "inflate", "validate", "gallery", "retie", "fit", "plan", "correct")


def _validator(name):
    schema = json.loads((SCHEMAS / f"{name}.schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def _load(path):
    text = Path(path).read_text()
    return json.loads(text, parse_constant=lambda c: pytest.fail(f"{path}: bare {c}"))


def _quiet(argv):
    with contextlib.redirect_stdout(io.StringIO()) as out:
        code = main(argv + ["-q"])
    return code, out.getvalue()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A synthetic set, its calibration, two coarse designs, an inflation, a re-tie list and two fits."""
    r = tmp_path_factory.mktemp("runs")
    assert _quiet(["synth", str(r / "set"), "--points", "10000", "--l-over-L", "0.4,0.6,0.8,0.9"])[0] == 0
    assert _quiet(["calibrate", str(r / "set" / "manifest.csv"), "--out", str(r / "cal"),
                   "--walkers", "16", "--max-steps", "200"])[0] in (0, 3)
    for name, extra in (("a", ["--calibration", str(r / "cal")]), ("b", ["--mu2-mm", "120"])):
        assert _quiet(["design", "--preset", "vault1", "--spacing-mm", "40", *extra, "--out", str(r / name)])[0] == 0
    assert _quiet(["inflate", str(r / "a"), "--out", str(r / "inf"), "--resolution-mm", "60", "--jobs", "1",
                   "--no-envelope"])[0] == 0
    assert _quiet(["retie", str(r / "a"), str(r / "b"), "--out", str(r / "retie")])[0] == 0
    code, out = _quiet(["fit", str(r / "set" / "specimen_00.ply"), "--json"])
    assert code == 0
    (r / "fit.json").write_text(out)
    code, out = _quiet(["fit", str(r / "set" / "missing.ply"), "--json"])
    assert code == 2
    (r / "fit_refused.json").write_text(out)
    return {"calibration": [r / "cal" / "calibration.json"], "design": [r / "a" / "design.json", r / "b" / "design.json"],
            "inflate": [r / "inf" / "inflate.json"], "retie": [r / "retie" / "retie.json"],
            "fit": [r / "fit.json", r / "fit_refused.json"]}


def test_one_schema_per_output_and_each_is_valid():
    assert sorted(p.name for p in SCHEMAS.glob("*.schema.json")) == sorted(f"{n}.schema.json" for n in OUTPUTS)
    for name in OUTPUTS:
        _validator(name)


@pytest.mark.parametrize("name", ["calibration", "design", "inflate", "retie", "fit"])
def test_real_outputs_match_their_schema(runs, name):
    for path in runs[name]:
        doc = _load(path)
        assert list(doc)[:2] == ["schema_version", "airmat_version"], path
        assert doc["schema_version"] == SCHEMA_VERSION
        errors = [f"{list(e.path)}: {e.message}" for e in _validator(name).iter_errors(doc)]
        assert errors == [], path


def test_a_refused_fit_prints_its_error_as_json(runs):
    doc = _load(runs["fit"][1])
    assert doc["error"]["exit_code"] == 2 and doc["error"]["type"] == "InputError"
    assert doc["error"]["path"].endswith("missing.ply") and doc["converged"] is False


def test_without_json_a_refused_fit_prints_nothing_on_stdout(runs, capsys):
    assert main(["fit", str(runs["fit"][1].parent / "set" / "missing.ply")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("name,edit", [
    ("design", lambda d: d.pop("schema_version")),
    ("design", lambda d: d["dashes"][0].update(side="left")),
    ("inflate", lambda d: d["deviation"].update(rms_mm="13")),
    ("calibration", lambda d: d["parameters"].pop("d_mm")),
    ("retie", lambda d: d["steps"][0].update(action="cut")),
    ("retie", lambda d: d["counts"].update(retie=3)),            # not one of the five categories
    ("retie", lambda d: d.pop("cut_tolerance_mm")),
    ("fit", lambda d: d.update(axis=[0, 1])),
])
def test_the_schemas_refuse_a_broken_document(runs, name, edit):
    doc = _load(runs[name][0])
    assert _validator(name).is_valid(doc)
    edit(doc)
    assert not _validator(name).is_valid(doc)


def test_a_flat_fit_gives_null_radius_with_a_reason(tmp_path, capsys):
    from airmat.synthetic.ply_write import write_ply
    from airmat.synthetic.specimen_scan import specimen_scan

    path = tmp_path / "flat.ply"
    write_ply(path, specimen_scan(0.0, n_points=20_000, seed=9).points * 1e3)
    assert main(["fit", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["radius_mm"] is None and "flat" in doc["null_reasons"]["/radius_mm"]
    assert _validator("fit").is_valid(doc)


@pytest.mark.slow  # a validation point and a gallery preset: about 20 s
def test_validate_and_gallery_match_their_schemas(tmp_path):
    assert _quiet(["validate", "--out", str(tmp_path / "val"), "--l-over-L", "0.5", "--resolution-mm", "60",
                   "--jobs", "1"])[0] == 0
    assert _quiet(["gallery", "--presets", "saddle", "--resolution-mm", "60", "--out", str(tmp_path / "gal"),
                   "--jobs", "1"])[0] == 0
    for name, path in (("validate", tmp_path / "val" / "validate.json"), ("gallery", tmp_path / "gal" / "gallery.json")):
        doc = _load(path)
        assert doc["schema_version"] == SCHEMA_VERSION
        assert [e.message for e in _validator(name).iter_errors(doc)] == [], path
    gallery = _load(tmp_path / "gal" / "gallery.json")
    assert gallery["saddle"]["converged"] is True
    broken = {**gallery, "saddle": {**gallery["saddle"], "deviation": {"rms_mm": None}}}
    assert not _validator("gallery").is_valid(broken)
