"""`airmat export DESIGN_DIR [--paper A4|A3] [--dxf] [--csv] [--3dm] [--out DIR]`: a design folder's workshop files, made again."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from airmat.errors import InputError

#: the files made when no file option is given: what the workshop uses (print, cut, tie; CAD and Rhino)
DEFAULT_PAPERS = ("A4",)

EPILOG = """\
files (from any design folder: 'airmat design', 'airmat refine', 'airmat design --refine'):
  --paper A4|A3  pattern_A4.pdf / pattern_A3.pdf: the 1:1 drawing tiled over pages of that size, with
                 crop marks, page numbers and a 20 mm overlap (repeat for both)
  --dxf          pattern.dxf: the drawing for CAD, a plotter or a cutter
  --csv          cutting_list.csv: each string's id, face and length to cut
  --3dm          design.3dm: Ŝ and the strings for Rhino (skipped with a warning without rhino3dm)
With none of them: pattern_A4.pdf, pattern.dxf, cutting_list.csv and design.3dm.

The files are made from design.json (design.3dm also from approx_surface.ply), the lengths the
folder holds, refined ones included; pattern.dxf and cutting_list.csv come out byte for byte as the
command that wrote the folder made them.

Without --out the files are replaced in DESIGN_DIR itself and nothing else there is touched: all of
them are made first, then each one replaces its old version in one step, so a run that fails or is
interrupted leaves the old files (a run killed outright may leave a hidden .export-* folder). With
--out DIR: a new folder holding only these files (DIR is replaced as a whole, as by every command)."""


def add_parser(sub, parents):
    import argparse

    p = sub.add_parser("export", parents=parents,
                       help="make a design folder's workshop files again: the tiled 1:1 PDF, DXF, cutting list, "
                            "Rhino file (a refined design's too)",
                       description=__doc__.splitlines()[0].split(": ", 1)[1], epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("design", metavar="DESIGN_DIR", help="output folder of 'airmat design' or 'airmat refine'")
    p.add_argument("--paper", action="append", choices=("A4", "A3"), default=None,
                   help="write pattern_A4.pdf / pattern_A3.pdf (repeat for both)")
    p.add_argument("--dxf", action="store_true", help="write pattern.dxf")
    p.add_argument("--csv", action="store_true", help="write cutting_list.csv")
    p.add_argument("--3dm", dest="rhino", action="store_true", help="write design.3dm (Rhino)")
    p.add_argument("--out", metavar="DIR", default=None,
                   help="output folder holding only the files written (default: replace them in DESIGN_DIR)")
    p.set_defaults(func=run)


def requested(args) -> tuple:
    """The papers and the other formats asked for: ``(papers, dxf, csv, rhino)``; none asked: the default set."""
    papers = tuple(dict.fromkeys(args.paper or ()))
    if not (papers or args.dxf or args.csv or args.rhino):
        return DEFAULT_PAPERS, True, True, True
    return papers, args.dxf, args.csv, args.rhino


def write_files(result, folder, *, papers=(), dxf=False, csv=False, rhino=False) -> list[str]:
    """Write the requested workshop files of ``result`` into ``folder``; the names written, in order."""
    from airmat.design.design_io import document
    from airmat.design.export import write_3dm, write_cutting_list, write_dxf, write_pdf

    folder = Path(folder)
    doc = document(result)
    names = []
    for paper in papers:
        write_pdf(folder / f"pattern_{paper}.pdf", doc, paper)
        names.append(f"pattern_{paper}.pdf")
    if dxf:
        write_dxf(folder / "pattern.dxf", doc)
        names.append("pattern.dxf")
    if csv:
        write_cutting_list(folder / "cutting_list.csv", doc)
        names.append("cutting_list.csv")
    a = result.approx
    if rhino and write_3dm(folder / "design.3dm", doc, a.xyz, a.uv, a.faces):
        names.append("design.3dm")
    return names


def _in_place(result, folder: Path, **files) -> list[str]:
    """Make the files in a hidden folder inside ``folder``, then move each over its old version."""
    from airmat.atomic import signals_deferred
    from airmat.cli import sigint

    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError("cannot write the files here: no write permission", path=folder)
    stage = Path(tempfile.mkdtemp(prefix=".export-", dir=folder))   # same file system: os.replace is atomic
    try:
        names = write_files(result, stage, **files)
        sigint.check()
        with signals_deferred():     # microseconds: no half-moved set on Ctrl-C
            for name in names:
                os.replace(stage / name, folder / name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return names


def run(args) -> int:
    from airmat.atomic import check_out_dir
    from airmat.cli.sigint import staged
    from airmat.design.design_io import read_design
    from airmat.listing import listed
    from airmat.units import M_TO_MM

    if args.out is not None:
        check_out_dir(args.out, inputs=[args.design])
    papers, dxf, csv, rhino = requested(args)
    result = read_design(args.design)
    files = dict(papers=papers, dxf=dxf, csv=csv, rhino=rhino)
    if args.out is None:
        folder = args.design
        names = _in_place(result, Path(folder), **files)
        written = ", ".join(names)
    else:
        folder = args.out
        with staged(args.out) as tmp:
            names = write_files(result, tmp, **files)
        written = listed(args.out, names)
    m = result.approx.mattress
    print(f"airmat export: {result.name}, {len(result.pattern.strings)} strings on a {m.width * M_TO_MM:.0f} x "
          f"{m.height * M_TO_MM:.0f} mm mattress" + (" (refined lengths)" if result.refine is not None else ""))
    print(f"  wrote {written} to {folder}" if names else f"  wrote nothing to {folder}")
    return 0
