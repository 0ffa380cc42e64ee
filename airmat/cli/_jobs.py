"""The ``--jobs N`` and ``--scheduler ADDRESS`` options of the commands that run several independent inflations."""

from __future__ import annotations

import os

from airmat.errors import InputError

__all__ = ["add_jobs_argument", "jobs", "scheduler"]


def add_jobs_argument(parser) -> None:
    """Register ``--jobs N`` (default: the CPU cores)."""
    parser.add_argument("--jobs", type=int, default=None, metavar="N",
                        help="inflations at a time, one process each (default: the CPU cores; "
                             "never more than there are runs)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run the inflations on an existing Dask cluster (tcp://host:port; default "
                             "$AIRMAT_SCHEDULER, else --jobs local worker processes); its workers need airmat")


def jobs(args) -> int:
    """The number of worker processes ``args.jobs`` asks for; InputError below 1."""
    n = (os.cpu_count() or 1) if args.jobs is None else args.jobs
    if n < 1:
        raise InputError(f"--jobs must be at least 1, got {n}")
    return n


def scheduler(args) -> str | None:
    """The Dask scheduler address: ``--scheduler``, else ``$AIRMAT_SCHEDULER``, else None (local workers)."""
    from airmat.inflation.executor import scheduler_address

    return scheduler_address(getattr(args, "scheduler", None))
