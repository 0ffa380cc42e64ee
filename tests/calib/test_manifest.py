"""Calibration manifest: parsing, units, and every bad input naming the file."""

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.calib.manifest import read_manifest, write_manifest_text


def make(tmp_path, text, scans=("a.ply", "b.ply", "c.ply", "d.ply")):
    for s in scans:
        (tmp_path / s).write_bytes(b"ply\n")
    path = tmp_path / "manifest.csv"
    path.write_text(text)
    return path


GOOD = "scan,l_mm,L_mm\na.ply,90,300\nb.ply,150,300\nc.ply,300,300\n"


def test_reads_lengths_in_metres_and_resolves_scans(tmp_path):
    m = read_manifest(make(tmp_path, GOOD))
    assert m.scans == ("a.ply", "b.ply", "c.ply") and len(m) == 3
    np.testing.assert_allclose(m.l, [0.09, 0.15, 0.30])
    np.testing.assert_allclose(m.L, 0.3)
    np.testing.assert_array_equal(m.surface_offset, 0.0)
    assert m.scan_paths[1] == str((tmp_path / "b.ply").resolve())


def test_optional_offset_comments_blank_lines_and_column_order(tmp_path):
    text = ("# a comment\nL_mm, scan ,surface_offset_mm,l_mm\n\n300,a.ply,70,90\n"
            "250,sub/b.ply,,100\n300,c.ply,-5.5,120\n")
    (tmp_path / "sub").mkdir()
    m = read_manifest(make(tmp_path, text, scans=("a.ply", "sub/b.ply", "c.ply")))
    np.testing.assert_allclose(m.surface_offset, [0.07, 0.0, -0.0055])
    np.testing.assert_allclose(m.L, [0.3, 0.25, 0.3])
    np.testing.assert_allclose(m.l, [0.09, 0.1, 0.12])


def test_written_manifest_reads_back(tmp_path):
    text = write_manifest_text(["a.ply", "b.ply", "c.ply"], [90.0, 107.7, 285.0], [300.0] * 3,
                               [0.0, 1.5, 0.0])
    m = read_manifest(make(tmp_path, text))
    np.testing.assert_allclose(m.l * 1e3, [90.0, 107.7, 285.0])
    np.testing.assert_allclose(m.surface_offset * 1e3, [0.0, 1.5, 0.0])


BAD = [
    ("scan,l_mm\na.ply,90\nb.ply,100\nc.ply,110\n", r"missing column\(s\) L_mm"),
    ("file,length\na.ply,90\n", r"missing column\(s\) scan, l_mm, L_mm"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,ninety,300\nc.ply,100,300\n", r"line 3: l_mm = 'ninety'"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,100,nan\nc.ply,100,300\n", r"line 3: L_mm .* not finite"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,0,300\nc.ply,100,300\n", r"line 3: l_mm = 0 must"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,-5,300\nc.ply,100,300\n", r"line 3: l_mm = -5 must"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,310,300\nc.ply,100,300\n", r"line 3: l_mm = 310 .* l <= L"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,100,0\nc.ply,100,300\n", r"line 3: L_mm = 0 must be > 0"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,100,-300\nc.ply,100,300\n", r"line 3: L_mm = -300"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,100,300\n./a.ply,120,300\n", r"line 4: .* listed twice .*line 2"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,100,300\nmissing.ply,120,300\n", r"line 4: scan file 'missing.ply' not found"),
    ("scan,l_mm,L_mm\na.ply,90,300\nb.ply,100,300\n", r"2 specimen\(s\) cannot determine the 3 parameters"),
    ("scan,l_mm,L_mm\na.ply,90\n", r"line 2: 2 values for 3 columns"),
    ("scan,l_mm,L_mm,surface_offset_mm\na.ply,90,300,x\n", r"line 2: surface_offset_mm = 'x'"),
    ("", r"empty manifest"),
]


@pytest.mark.parametrize("text, match", BAD)
def test_bad_manifest_raises_input_error_naming_it(tmp_path, text, match):
    path = make(tmp_path, text)
    with pytest.raises(InputError, match=match) as info:
        read_manifest(path)
    assert info.value.path == str(path)
    assert str(path) in info.value.one_line() and "\n" not in info.value.one_line()


def test_missing_manifest(tmp_path):
    with pytest.raises(InputError, match="manifest not found") as info:
        read_manifest(tmp_path / "nope.csv")
    assert info.value.path == str(tmp_path / "nope.csv")


def test_missing_scan_allowed_when_not_checking(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text(GOOD)
    assert len(read_manifest(path, check_files=False)) == 3
    with pytest.raises(InputError, match="not found"):
        read_manifest(path)


@pytest.mark.parametrize("text", [
    "\ufeffscan,l_mm,L_mm\r\na.ply,90,300\r\nb.ply,107.7,300\r\nc.ply,300,300\r\n",   # Excel's UTF-8 CSV, CRLF
    '"scan","l_mm","L_mm"\n"a.ply","90","300"\n"b.ply","107.7","300"\n"c.ply","300","300"\n',
    "scan;l_mm;L_mm\na.ply;90;300\nb.ply;107,7;300\nc.ply;300;300\n",   # a decimal-comma locale's Excel
    "scan\tl_mm\tL_mm\na.ply\t90\t300\nb.ply\t107.7\t300\nc.ply\t300\t300\n",
])
def test_what_a_spreadsheet_writes_reads_as_meant(tmp_path, text):
    m = read_manifest(make(tmp_path, text))
    assert m.scans == ("a.ply", "b.ply", "c.ply")
    np.testing.assert_allclose(m.l * 1e3, [90, 107.7, 300])


def test_a_thousands_separator_is_not_guessed(tmp_path):
    text = "scan;l_mm;L_mm\na.ply;90;1.200,5\nb.ply;100;300\nc.ply;110;300\n"
    with pytest.raises(InputError, match=r"line 2: L_mm = '1.200,5' is not a number"):
        read_manifest(make(tmp_path, text))


def test_a_scan_path_written_on_windows_is_found(tmp_path):
    (tmp_path / "scans").mkdir()
    text = "scan,l_mm,L_mm\nscans\\a.ply,90,300\nscans\\b.ply,100,300\nscans/c.ply,110,300\n"
    m = read_manifest(make(tmp_path, text, scans=("scans/a.ply", "scans/b.ply", "scans/c.ply")))
    assert m.scans[0] == "scans\\a.ply"
    assert m.scan_paths[0] == str((tmp_path / "scans" / "a.ply").resolve())
    with pytest.raises(InputError, match=r"line 2: scan file 'scans\\\\x.ply' not found"):
        read_manifest(make(tmp_path, text.replace("scans\\a.ply", "scans\\x.ply"),
                           scans=("scans/a.ply", "scans/b.ply", "scans/c.ply")))
