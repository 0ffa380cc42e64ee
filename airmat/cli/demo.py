"""`airmat demo`: not implemented yet."""

from __future__ import annotations

from airmat.errors import InputError


def add_parser(sub, parents):
    p = sub.add_parser("demo", parents=parents, help="(not implemented yet)")
    p.set_defaults(func=run)


def run(args) -> int:
    raise InputError("'airmat demo' is not implemented yet")
