"""The envelope of every JSON file airmat writes: versions first, no bare NaN.

Each document starts with ``schema_version`` (the version of its JSON
Schema in the package folder ``airmat/schemas/``, ``<name>.schema.json``) and
``airmat_version``. JSON has no NaN: a value that is not a finite number
becomes ``null`` and its JSON Pointer is listed in ``null_reasons`` with the
reason (the writer's own words where it gave one, else "not a finite
number"), so a script can tell a missing value from a zero.
"""

from __future__ import annotations

import json
import math

import numpy as np

from airmat import __version__

__all__ = ["SCHEMA_VERSION", "finish", "dumps", "read_object"]

#: version of the JSON layouts described by ``airmat/schemas/*.schema.json``; bump on an incompatible change
SCHEMA_VERSION = 1


def finish(doc: dict, *, reasons: dict | None = None) -> dict:
    """``doc`` with the versions first and every non-finite number replaced by null (with its reason).

    Parameters
    ----------
    doc : dict
        The document; numpy scalars and arrays are turned into plain JSON values.
    reasons : dict, optional
        Reason per field name (a key on the value's path, the nearest one wins, e.g.
        ``"radius_mm"``) for a value that may be missing; the default reason is
        "not a finite number".

    Returns
    -------
    dict
        ``{"schema_version", "airmat_version", **doc}`` and, when some value was
        missing, ``null_reasons`` ``{JSON Pointer: reason}``.

    Examples
    --------
    >>> finish({"kappa_per_m": float("nan"), "n": 3})["null_reasons"]
    {'/kappa_per_m': 'not a finite number (nan)'}
    """
    missing: dict[str, str] = {}
    body = {k: v for k, v in doc.items() if k not in ("schema_version", "airmat_version", "null_reasons")}
    clean = _clean(body, "", missing, reasons or {})
    out = {"schema_version": SCHEMA_VERSION, "airmat_version": __version__, **clean}
    if missing or doc.get("null_reasons"):
        out["null_reasons"] = {**doc.get("null_reasons", {}), **missing}
    return out


def dumps(doc: dict, *, indent: int | None = 1, reasons: dict | None = None, **kwargs) -> str:
    """``json.dumps(finish(doc))`` with ``allow_nan=False`` (a NaN left over is a bug, not a file)."""
    return json.dumps(finish(doc, reasons=reasons), indent=indent, allow_nan=False, **kwargs)


def read_object(path) -> dict:
    """The JSON object in ``path``; an :class:`airmat.errors.InputError` naming the file if it is not one.

    Parameters
    ----------
    path : str or PathLike

    Returns
    -------
    dict
    """
    from pathlib import Path

    from airmat.errors import InputError

    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:      # ValueError: JSONDecodeError and UnicodeDecodeError
        raise InputError(f"cannot read as JSON: {err}", path=path) from None
    if not isinstance(doc, dict):
        raise InputError("expected a JSON object at the top level", path=path)
    return doc


def _clean(node, pointer: str, missing: dict, reasons: dict):
    if isinstance(node, dict):
        return {k: _clean(v, f"{pointer}/{_escape(k)}", missing, reasons) for k, v in node.items()}
    if isinstance(node, (list, tuple)):
        return [_clean(v, f"{pointer}/{i}", missing, reasons) for i, v in enumerate(node)]
    if isinstance(node, np.ndarray):
        return _clean(node.tolist(), pointer, missing, reasons)
    if isinstance(node, (bool, np.bool_)):
        return bool(node)
    if isinstance(node, np.integer):
        return int(node)
    if isinstance(node, (float, np.floating)):
        if math.isfinite(node):
            return float(node)
        named = [k for k in reversed(pointer.split("/")) if k in reasons]
        missing[pointer] = reasons[named[0]] if named else f"not a finite number ({float(node)})"
        return None
    return node


def _escape(key) -> str:
    return str(key).replace("~", "~0").replace("/", "~1")
