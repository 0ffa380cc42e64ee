"""airmat.design.export.rhino_stable: the same model gives the same .3dm bytes, whenever and wherever it is written."""

import base64
import os
import struct
import subprocess
import sys
import time
import zlib
from datetime import datetime
from pathlib import Path

import pytest

from airmat.errors import InputError
from airmat.design.export.rhino import rhino_model, write_3dm
from airmat.design.export.rhino_stable import Malformed3dm, fixed_time, normalize_3dm, stable_3dm_bytes
from test_export import _cylinder_surface, _document

rhino3dm = pytest.importorskip("rhino3dm")

REVISION, FILE_NAME, PROPERTIES = 0x20008021, 0x20008027, 0x10000014
ROOT = Path(__file__).resolve().parents[2]


def _model():
    doc, _ = _document()
    xyz, uv, faces = _cylinder_surface()
    return rhino_model(doc, xyz, uv, faces)


def _chunks(data, start, end, values=False):
    pos = start
    while pos < end:
        typecode, value = struct.unpack_from("<Iq", data, pos)
        size = 0 if typecode & 0x80000000 else value
        payload = data[pos + 12:pos + 12 + size]
        yield (typecode, value, payload) if values else (typecode, payload)
        pos += 12 + size


def _properties(data):
    (table,) = [p for t, p in _chunks(data, 32, len(data)) if t == PROPERTIES]
    return dict(_chunks(table, 0, len(table)))


def _raw(model):
    options = rhino3dm.File3dmWriteOptions()
    options.Version = 8
    return base64.b64decode(model.Encode(options))


def _next_second():
    time.sleep(1.02 - time.time() % 1.0)


def _content(model):
    layers = [(layer.FullPath, layer.Visible, str(layer.Id)) for layer in model.Layers]
    objects = [(o.Attributes.Name, o.Attributes.LayerIndex, str(o.Attributes.Id), sorted(o.Attributes.GetUserStrings()),
                type(o.Geometry).__name__, o.Geometry.GetBoundingBox().Min.X, o.Geometry.GetBoundingBox().Max.Z)
               for o in model.Objects]
    return str(model.Settings.ModelUnitSystem), model.Settings.ModelAbsoluteTolerance, layers, objects


def test_two_writes_at_different_times_and_paths_give_the_same_bytes(tmp_path, monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    raw_a = _raw(_model())
    write_3dm(tmp_path / "a" / "design.3dm", *_args())
    _next_second()
    raw_b = _raw(_model())
    write_3dm(tmp_path / "a much longer folder name" / "x" / "inflated.3dm", *_args())
    assert raw_a != raw_b                       # OpenNURBS did stamp the two writes differently
    assert _properties(raw_a)[REVISION] != _properties(raw_b)[REVISION]
    a = (tmp_path / "a" / "design.3dm").read_bytes()
    b = (tmp_path / "a much longer folder name" / "x" / "inflated.3dm").read_bytes()
    assert a == b
    assert FILE_NAME not in _properties(a) and str(tmp_path).encode("utf-16-le") not in a


def _args():
    doc, _ = _document()
    return (doc, *_cylinder_surface())


def test_the_stable_file_reads_back_with_the_same_model_and_fixed_times(tmp_path, monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    model = _model()
    path = tmp_path / "design.3dm"
    model.Write(str(tmp_path / "plain.3dm"), 8)
    path.write_bytes(stable_3dm_bytes(model))
    back, plain = rhino3dm.File3dm.Read(str(path)), rhino3dm.File3dm.Read(str(tmp_path / "plain.3dm"))
    assert len(back.Objects) == len(model.Objects) > 10 and len(back.Layers) == len(model.Layers)
    assert _content(back) == _content(plain)
    assert back.Created == back.LastEdited == datetime(2000, 1, 1)
    assert back.Revision == plain.Revision == 1
    assert back.CreatedBy == back.LastEditedBy == ""
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")        # 2023-11-14 22:13:20 UTC
    path.write_bytes(stable_3dm_bytes(model))
    assert rhino3dm.File3dm.Read(str(path)).Created == datetime(2023, 11, 14, 22, 13, 20)


def test_crcs_are_opennurbs_ones():
    raw = _raw(_model())
    record = _properties(raw)[REVISION]
    # the CRC OpenNURBS wrote is zlib's CRC-32 of the record's bytes: the one normalize_3dm recomputes
    assert struct.unpack("<I", record[-4:])[0] == zlib.crc32(record[:-4])
    fixed = _properties(normalize_3dm(raw, epoch=0))[REVISION]
    assert fixed != record and struct.unpack("<I", fixed[-4:])[0] == zlib.crc32(fixed[:-4])
    assert struct.unpack_from("<8i", fixed, 5) == fixed_time(0) == (0, 0, 0, 1, 0, 70, 4, 0)  # a Thursday


def test_fixed_time_matches_the_c_struct_tm(monkeypatch):
    # 2024-02-29 13:45:07 UTC, a Thursday, day 59 of the year (0-based)
    assert fixed_time(1709214307) == (7, 45, 13, 29, 1, 124, 4, 59)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1709214307")
    assert fixed_time() == (7, 45, 13, 29, 1, 124, 4, 59)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "yesterday")
    with pytest.raises(InputError, match="SOURCE_DATE_EPOCH"):
        fixed_time()


def test_saved_as_path_dropped_and_lengths_recomputed(tmp_path):
    model = _model()
    short, long = tmp_path / "s.3dm", tmp_path / ("long" * 20) / "design.3dm"
    long.parent.mkdir()
    model.Write(str(short), 8)
    _next_second()
    model.Write(str(long), 8)
    a, b = short.read_bytes(), long.read_bytes()
    assert len(a) != len(b) and FILE_NAME in _properties(a)
    na, nb = normalize_3dm(a), normalize_3dm(b)
    assert na == nb and FILE_NAME not in _properties(na)
    assert struct.unpack("<Q", na[-8:])[0] == len(na)             # the end mark holds the file's length
    (tmp_path / "n.3dm").write_bytes(na)
    assert _content(rhino3dm.File3dm.Read(str(tmp_path / "n.3dm"))) == _content(rhino3dm.File3dm.Read(str(short)))


def _with_user_names(raw, name):
    """``raw`` with a revision history that names a user (as on Windows or macOS), CRC and lengths fixed."""
    start = raw.index(struct.pack("<I", PROPERTIES))
    end = start + 12 + struct.unpack_from("<q", raw, start + 4)[0]
    text = struct.pack("<i", len(name) + 1) + (name + "\0").encode("utf-16-le")
    records = []
    for typecode, value, payload in _chunks(raw, start + 12, end, values=True):
        if typecode == REVISION:
            body = payload[:1] + text + payload[5:37] + text + payload[41:-4]
            payload = body + struct.pack("<I", zlib.crc32(body))
            value = len(payload)
        records.append(struct.pack("<Iq", typecode, value) + payload)
    table = b"".join(records)
    out = raw[:start] + struct.pack("<Iq", PROPERTIES, len(table)) + table + raw[end:-8]
    return out + struct.pack("<Q", len(out) + 8)


def test_user_names_are_blanked(tmp_path):
    raw = _raw(_model())
    named = _with_user_names(raw, "alice")
    (tmp_path / "named.3dm").write_bytes(named)
    assert rhino3dm.File3dm.Read(str(tmp_path / "named.3dm")).CreatedBy == "alice"   # the forged file is valid
    assert normalize_3dm(named) == normalize_3dm(raw)


def test_other_processes_and_hash_seeds_give_the_same_bytes(tmp_path, monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    here = stable_3dm_bytes(_model())
    script = ("import sys; from pathlib import Path; from test_rhino_stable import _model; "
              "from airmat.design.export.rhino_stable import stable_3dm_bytes; "
              "Path(sys.argv[1]).write_bytes(stable_3dm_bytes(_model()))")
    env = {**os.environ, "PYTHONHASHSEED": "12345",
           "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "tests" / "design")])}
    env.pop("SOURCE_DATE_EPOCH", None)
    subprocess.run([sys.executable, "-c", script, str(tmp_path / "other.3dm")], check=True, cwd=tmp_path, env=env)
    assert (tmp_path / "other.3dm").read_bytes() == here


@pytest.mark.parametrize("damage", ["not a 3dm", "truncated", "bad crc", "version 4"])
def test_malformed_bytes_are_refused(damage):
    raw = _raw(_model())
    if damage == "not a 3dm":
        data = b"PK\x03\x04" + raw[4:]
    elif damage == "truncated":
        data = raw[:len(raw) // 2]
    elif damage == "bad crc":
        i = raw.index(struct.pack("<I", REVISION)) + 12 + 10           # a byte of the creation time
        data = raw[:i] + bytes([raw[i] ^ 1]) + raw[i + 1:]
    else:
        data = raw[:24] + b"       4".rjust(8) + raw[32:]
    with pytest.raises(Malformed3dm):
        normalize_3dm(data)
