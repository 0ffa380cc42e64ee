"""`airmat report DIR [--out DIR]`: a folder's report.html, rebuilt from the files the folder holds."""

from __future__ import annotations

from pathlib import Path

from airmat.errors import InputError

EPILOG = """\
what it rebuilds, by the file DIR holds:
  design.json       a design or a refined design ('airmat design', 'airmat refine'): the design part
  calibration.json  a calibration ('airmat calibrate'): the calibration part, beside the truth that
                    calibration.json kept ('airmat calibrate --truth')
  inflate.json      a check ('airmat check'): the design part of the design folder inflate.json names
                    (when it is still there) and the check's numbers from inflate.json as a summary.
                    The check's figures (the inflated shapes, the deviation map, the envelope and
                    Monte-Carlo tables) need the inflation itself, which the folder does not keep and
                    which is not re-run here: 'airmat check DESIGN_DIR' makes them again.
Nothing is recomputed. Without --out, report.html is replaced in DIR in one step and nothing else
there is touched; with --out DIR: a new folder holding only report.html."""


def add_parser(sub, parents):
    import argparse

    p = sub.add_parser("report", parents=parents,
                       help="rebuild report.html of a design, calibration or check folder from its files",
                       description=__doc__.splitlines()[0].split(": ", 1)[1], epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folder", metavar="DIR", help="output folder of 'airmat design', 'refine', 'calibrate' or 'check'")
    p.add_argument("--out", metavar="DIR", default=None,
                   help="output folder holding only report.html (default: replace it in DIR)")
    p.set_defaults(func=run)


def _json(path: Path) -> dict:
    from airmat.json_doc import read_object

    return read_object(path)


def _check_design(folder: Path, doc: dict):
    """The design a check folder was made from: the folder inflate.json names, as given or beside DIR."""
    from airmat.design.design_io import read_design

    named = Path(str(doc.get("design", "")))
    for where in (named, folder.parent / named):
        if str(named) and (where / "design.json").is_file():
            return read_design(where)
    raise InputError(f"inflate.json names the design folder {str(named)!r}, which is not there (neither as given "
                     "nor beside this folder); the page needs the design", path=folder)


def report_args(folder) -> tuple[str, dict]:
    """What the page holds (a phrase for stdout) and the keyword arguments of
    :func:`airmat.report.page.write_report` that rebuild it from ``folder``'s files."""
    folder = Path(folder)
    if folder.is_file():
        raise InputError("is a file: give an output folder of 'airmat design', 'refine', 'calibrate' or 'check'",
                         path=folder)
    if not folder.is_dir():
        raise InputError("folder not found", path=folder)
    if (folder / "inflate.json").is_file():
        from airmat.check.report import summary_text

        doc = _json(folder / "inflate.json")
        design = _check_design(folder, doc)
        try:     # its last line names the files of the run that wrote the folder
            lines = summary_text(doc, folder).splitlines()[:-1]
        except (KeyError, TypeError, ValueError) as err:
            raise InputError(f"not an inflate.json written by 'airmat check': no field {err}",
                             path=folder / "inflate.json") from None
        lines.append("  (rebuilt by 'airmat report' from inflate.json: the check's figures need the inflation; "
                     "'airmat check' makes them)")
        return ("the design part and the check's numbers (its figures need the inflation)",
                dict(design=design, summary="\n".join(lines), title=f"airmat check: {design.name}"))
    if (folder / "design.json").is_file():
        from airmat.design.design_io import read_design

        design = read_design(folder)
        command = "refine" if design.refine is not None else "design"
        return "the design part", dict(design=design, title=f"airmat {command}: {design.name}")
    if (folder / "calibration.json").is_file():
        from airmat.calib.calibration_io import read_calibration

        cal = read_calibration(folder)
        truth = _json(folder / "calibration.json").get("truth")
        return "the calibration part", dict(calibration=cal, truth=truth if isinstance(truth, dict) else None,
                                   title=f"airmat calibrate: {cal.manifest.path or folder}")
    raise InputError("holds no design.json, calibration.json or inflate.json: give an output folder of "
                     "'airmat design', 'refine', 'calibrate' or 'check'", path=folder)


def run(args) -> int:
    from airmat.atomic import check_out_dir
    from airmat.cli.sigint import staged
    from airmat.report.page import REPORT_NAME, write_report

    if args.out is not None:
        check_out_dir(args.out, inputs=[args.folder])
    what, kwargs = report_args(args.folder)
    if args.out is None:
        write_report(args.folder, **kwargs)     # one file, replaced atomically
    else:
        with staged(args.out) as tmp:
            write_report(tmp, **kwargs)
    folder = args.folder if args.out is None else args.out
    print(f"airmat report: {what}, from {args.folder}")
    print(f"  wrote {REPORT_NAME} to {folder}")
    return 0
