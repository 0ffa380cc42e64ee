"""`airmat presets`: the built-in targets of ``design --preset``, ``gallery`` and ``demo``, with their sizes."""

from __future__ import annotations

#: one line on each preset (airmat.design.presets's docstring; a test keeps the names equal)
DESCRIPTIONS = {
    "vault1": "a vault with a sharper crown, nearly developable",
    "saddle": "vault across, sag along: curvatures of opposite signs",
    "dome": "an ellipsoidal dome, strongly double-curved: made with drape-like folds",
    "vault2": "a wide vault, slightly double-curved",
    "roof": "freeform: a vault whose crown sharpens and flattens along its length, over a wavy ridge",
}


def add_parser(sub, parents):
    p = sub.add_parser("presets", parents=parents,
                       help="list the preset targets: mattress W x H x thickness and target size (mm)",
                       description=__doc__.splitlines()[0].split(": ", 1)[1]
                       + " Whether a preset is constructible is what 'airmat design --preset NAME' "
                         "(or 'airmat gallery', for all of them) finds out.")
    p.set_defaults(func=run)


def rows() -> list[dict]:
    """One dict per preset, in ``PRESETS`` order: name, mattress and target sizes (mm), description."""
    import numpy as np

    from airmat.design.presets import PRESETS, preset
    from airmat.units import M_TO_MM

    out = []
    for name in PRESETS:
        target, m = preset(name)
        v = np.asarray(target.vertices)
        size = (v.max(axis=0) - v.min(axis=0)) * M_TO_MM
        out.append({"name": name, "mattress_mm": (m.width * M_TO_MM, m.height * M_TO_MM, m.thickness * M_TO_MM),
                    "target_mm": tuple(float(x) for x in size), "description": DESCRIPTIONS.get(name, "")})
    return out


def table(items: list[dict]) -> str:
    """The lines ``airmat presets`` prints."""
    def size(values):
        return " x ".join(f"{x:.0f}" for x in values)

    head = ("name", "mattress W x H x thickness (mm)", "target x y z extent (mm)", "shape")
    body = [(r["name"], size(r["mattress_mm"]), size(r["target_mm"]), r["description"]) for r in items]
    widths = [max(len(row[i]) for row in [head, *body]) for i in range(3)]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(row[:3], widths)) + "  " + row[3]
                     for row in [head, *body])


def run(args) -> int:
    print(table(rows()))
    print("\nuse: airmat design --preset NAME [--out DIR]; constructible or not: 'airmat design' says, "
          "'airmat gallery' for all five")
    return 0
