"""The calibration manifest: which scan shows which string length.

A CSV file with a header and one row per scanned specimen::

    scan,l_mm,L_mm,surface_offset_mm
    specimen_00.ply,90.0,300.0,0
    specimen_01.ply,107.7,300.0,0

- ``scan``: the scan file, relative to the manifest's folder (or absolute);
- ``l_mm``: string length (mm), ``0 < l <= L``;
- ``L_mm``: geodesic distance of the string ends on the mattress (mm), > 0;
- ``surface_offset_mm`` (optional, default 0): when the scanned face is not
  the reference face, the curvature is ``kappa = 1 / (R + offset)``;
- ``units`` (optional): the unit of that scan's coordinates, one of
  ``m cm mm in ft us-ft``; an empty cell keeps the default (``--scan-units``,
  else what the file states, else mm), so a calibration can mix a PTS in
  metres with PLYs in millimetres.

Blank lines and lines starting with ``#`` are ignored. Values are converted
to metres here; the library works in SI.

What a spreadsheet writes is read as meant: a UTF-8 byte-order mark, CRLF
line ends and quoted cells; a header without commas but with semicolons
(Excel where the decimal separator is a comma) or tabs sets the delimiter,
and with semicolons ``107,7`` is 107.7; a scan name written on Windows
(``scans\\specimen_00.ply``) is found with ``/`` separators when it is not
found as written.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path, PureWindowsPath

import numpy as np

from airmat.errors import InputError
from airmat.units import MM, SCAN_UNITS

__all__ = ["Manifest", "read_manifest", "write_manifest_text", "REQUIRED_COLUMNS", "N_PARAMETERS"]

REQUIRED_COLUMNS = ("scan", "l_mm", "L_mm")
OPTIONAL_COLUMNS = ("surface_offset_mm", "units")
#: parameters of the calibration (Delta, d, sigma): at least this many specimens
N_PARAMETERS = 3


@dataclass(frozen=True)
class Manifest:
    """A checked calibration manifest (SI units).

    Attributes
    ----------
    path : str
        The manifest file.
    scans : tuple of str
        Scan file names as written in the manifest.
    scan_paths : tuple of str
        The scan files, resolved against the manifest's folder.
    l, L, surface_offset : ndarray of shape (S,)
        String length, string-end distance and surface offset (m).
    units : tuple of (str or None)
        Each scan's coordinate unit from the ``units`` column (a key of
        :data:`airmat.units.SCAN_UNITS`), None where not given.
    """

    path: str
    scans: tuple
    scan_paths: tuple
    l: np.ndarray
    L: np.ndarray
    surface_offset: np.ndarray
    units: tuple = ()

    def unit(self, i: int) -> str | None:
        """Scan ``i``'s unit from the manifest, or None."""
        return self.units[i] if i < len(self.units) else None

    def __len__(self) -> int:
        return len(self.scans)


def _rows(path: Path):
    """Header and (line number, row) pairs of a CSV file, comments and blanks skipped."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError("manifest not found", path=path) from None
    except IsADirectoryError:
        hint = f" ({path / 'manifest.csv'})" if (path / "manifest.csv").is_file() else ""
        raise InputError(f"is a folder: give the manifest CSV{hint}, with the columns scan,l_mm,L_mm",
                         path=path) from None
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"cannot read the manifest: {err}", path=path) from None
    lines = [(i, ln) for i, ln in enumerate(text.splitlines(), start=1)
             if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError("empty manifest: expected a header "
                         f"{','.join(REQUIRED_COLUMNS)}", path=path)
    delimiter = _delimiter(lines[0][1])
    parsed = list(csv.reader([ln for _, ln in lines], delimiter=delimiter))
    header = [h.strip() for h in parsed[0]]
    return header, [(lines[k][0], [c.strip() for c in row]) for k, row in enumerate(parsed) if k], delimiter


def _delimiter(header: str) -> str:
    """The header's delimiter: a comma, else a semicolon or a tab when the header holds one."""
    if "," in header:
        return ","
    return next((d for d in (";", "\t") if d in header), ",")


def _number(value: str, column: str, line: int, path: Path, *, decimal_comma: bool = False) -> float:
    if decimal_comma and value.count(",") == 1 and "." not in value:
        value = value.replace(",", ".")
    try:
        x = float(value)
    except ValueError:
        raise InputError(f"line {line}: {column} = {value!r} is not a number", path=path,
                         line=line, column=column) from None
    if not math.isfinite(x):
        raise InputError(f"line {line}: {column} = {value!r} is not finite", path=path,
                         line=line, column=column)
    return x


def _check_row(line, scan, l_mm, L_mm, path):
    if L_mm <= 0:
        raise InputError(f"line {line}: L_mm = {L_mm:g} must be > 0", path=path, line=line)
    if not 0 < l_mm <= L_mm:
        raise InputError(f"line {line}: l_mm = {l_mm:g} must satisfy 0 < l <= L = {L_mm:g}",
                         path=path, line=line)
    if not scan:
        raise InputError(f"line {line}: empty scan name", path=path, line=line)


def read_manifest(path, *, check_files: bool = True) -> Manifest:
    """Read and check a calibration manifest.

    Parameters
    ----------
    path : str or PathLike
        The CSV file (columns ``scan,l_mm,L_mm[,surface_offset_mm][,units]``, lengths in mm).
    check_files : bool
        Check that every scan file exists.

    Returns
    -------
    Manifest
        Lengths in metres.

    Raises
    ------
    airmat.errors.InputError
        With ``path`` the manifest: missing file, missing columns (named),
        non-numeric or non-finite values (line number), an unknown unit, ``l <= 0``, ``l > L``,
        ``L <= 0``, a scan listed twice, a missing scan file, or fewer
        specimens than the calibration's parameters.
    """
    path = Path(path)
    header, rows, delimiter = _rows(path)
    comma = delimiter == ";"
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise InputError(f"missing column(s) {', '.join(missing)}: the header must contain "
                         f"{','.join(REQUIRED_COLUMNS)} (found {','.join(header)})",
                         path=path, missing=missing)
    col = {name: header.index(name) for name in REQUIRED_COLUMNS + OPTIONAL_COLUMNS if name in header}
    scans, paths, values, units, seen = [], [], [], [], {}
    for line, row in rows:
        if len(row) < len(header):
            raise InputError(f"line {line}: {len(row)} values for {len(header)} columns",
                             path=path, line=line)
        scan = row[col["scan"]]
        l_mm = _number(row[col["l_mm"]], "l_mm", line, path, decimal_comma=comma)
        L_mm = _number(row[col["L_mm"]], "L_mm", line, path, decimal_comma=comma)
        off = row[col["surface_offset_mm"]] if "surface_offset_mm" in col else ""
        off_mm = _number(off, "surface_offset_mm", line, path, decimal_comma=comma) if off else 0.0
        _check_row(line, scan, l_mm, L_mm, path)
        unit = row[col["units"]] if "units" in col else ""
        if unit and unit not in SCAN_UNITS:
            raise InputError(f"line {line}: units = {unit!r} is not a scan unit; use one of "
                             f"{', '.join(SCAN_UNITS)} (or leave it empty)", path=path, line=line)
        try:
            resolved = (path.parent / scan).resolve()
            if "\\" in scan and not resolved.exists():   # written on Windows: try its separators as /
                posix = (path.parent / PureWindowsPath(scan).as_posix()).resolve()
                resolved = posix if posix.exists() else resolved
        except (OSError, RuntimeError) as err:  # RuntimeError: a symlink loop (Python < 3.13)
            raise InputError(f"line {line}: scan {scan!r} cannot be resolved: {err}", path=path,
                             line=line) from None
        if resolved in seen:
            raise InputError(f"line {line}: scan {scan!r} is listed twice (also on line "
                             f"{seen[resolved]})", path=path, line=line)
        seen[resolved] = line
        if check_files and not resolved.is_file():
            raise InputError(f"line {line}: scan file {scan!r} not found (looked for {resolved})",
                             path=path, line=line)
        scans.append(scan)
        paths.append(str(resolved))
        values.append((l_mm, L_mm, off_mm))
        units.append(unit or None)
    if len(scans) < N_PARAMETERS:
        raise InputError(f"{len(scans)} specimen(s) cannot determine the {N_PARAMETERS} parameters "
                         f"(Delta, d, sigma): list at least {N_PARAMETERS} scans", path=path)
    v = np.array(values, dtype=float) * MM
    return Manifest(path=str(path), scans=tuple(scans), scan_paths=tuple(paths),
                    l=v[:, 0], L=v[:, 1], surface_offset=v[:, 2], units=tuple(units))


def write_manifest_text(scans, l_mm, L_mm, surface_offset_mm=None) -> str:
    """The CSV text of a manifest (used by the synthetic calibration sets)."""
    lines = ["scan,l_mm,L_mm" + (",surface_offset_mm" if surface_offset_mm is not None else "")]
    offs = surface_offset_mm if surface_offset_mm is not None else [None] * len(scans)
    for s, l, L, o in zip(scans, l_mm, L_mm, offs):
        lines.append(f"{s},{l:.6g},{L:.6g}" + (f",{o:.6g}" if o is not None else ""))
    return "\n".join(lines) + "\n"
