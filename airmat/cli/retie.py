"""`airmat retie DESIGN_A DESIGN_B --out DIR`: which strings stay, are re-tied, removed or added from shape A to B."""

from __future__ import annotations


def add_parser(sub, parents):
    p = sub.add_parser("retie", parents=parents,
                       help="the re-tie list between two designs on the same mattress (one mattress, many shapes)",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("design_a", metavar="DESIGN_A", help="output folder of 'airmat design': the shape now")
    p.add_argument("design_b", metavar="DESIGN_B", help="output folder of 'airmat design': the next shape")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder: retie.json, retie.csv, retie.png")
    p.set_defaults(func=run)


def run(args) -> int:
    from airmat.atomic import check_out_dir, staged_dir
    from airmat.listing import listed
    from airmat.design.design_io import read_design
    from airmat.design.export.retie_files import write_retie
    from airmat.design.retie import retie_plan

    check_out_dir(args.out, inputs=[args.design_a, args.design_b])
    a, b = read_design(args.design_a), read_design(args.design_b)
    plan = retie_plan(a, b)
    m = a.approx.mattress
    with staged_dir(args.out) as tmp:
        doc = write_retie(tmp, plan, design_a=str(args.design_a), design_b=str(args.design_b),
                          width=m.width, height=m.height)
    c = doc["counts"]
    print(f"airmat retie: {len(a.pattern.strings)} strings -> {len(b.pattern.strings)}: keep {c['keep']} "
          f"(same nodes), re-tie {c['retie']}, remove {c['remove']}, add {c['add']}\n"
          f"  wrote {listed(args.out, ('retie.json',))} to {args.out}")
    return 0
