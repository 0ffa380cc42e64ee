"""The ``--jobs N`` option of the commands that run several independent inflations."""

from __future__ import annotations

import os

from airmat.errors import InputError

__all__ = ["add_jobs_argument", "jobs"]


def add_jobs_argument(parser) -> None:
    """Register ``--jobs N`` (default: the CPU cores)."""
    parser.add_argument("--jobs", type=int, default=None, metavar="N",
                        help="inflations at a time, one process each (default: the CPU cores; "
                             "never more than there are runs)")


def jobs(args) -> int:
    """The number of worker processes ``args.jobs`` asks for; InputError below 1."""
    n = (os.cpu_count() or 1) if args.jobs is None else args.jobs
    if n < 1:
        raise InputError(f"--jobs must be at least 1, got {n}")
    return n
