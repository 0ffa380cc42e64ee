"""`airmat gallery`: not implemented yet."""

from __future__ import annotations

from airmat.errors import InputError


def add_parser(sub, parents):
    p = sub.add_parser("gallery", parents=parents, help="(not implemented yet)")
    p.set_defaults(func=run)


def run(args) -> int:
    raise InputError("'airmat gallery' is not implemented yet")
