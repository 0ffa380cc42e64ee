"""The airmat error hierarchy.

Every error a user can cause derives from :class:`InputError`; the command
line turns it into exit code 2 and a single line on stderr,
``"<path>: <message>"``. Errors carry the offending data as attributes.
"""

from __future__ import annotations

from os import PathLike
from typing import Any

__all__ = ["AirmatError", "InputError", "NotACylinderError", "ConvergenceError", "TaskError"]


class AirmatError(Exception):
    """Base class of all airmat errors.

    Parameters
    ----------
    message : str
        What is wrong and, where possible, what to do about it.
    path : str or PathLike, optional
        The file the problem is in.
    **data
        Offending values, kept as attributes (``err.data["kappa"]``).
    """

    def __init__(self, message: str, *, path: str | PathLike | None = None, **data: Any):
        super().__init__(message)
        self.message = message
        self.path = None if path is None else str(path)
        self.data = data

    def one_line(self) -> str:
        """The message as one line, prefixed with the file when known."""
        msg = " ".join(str(self.message).split())
        return f"{self.path}: {msg}" if self.path else msg

    def with_path(self, path: str | PathLike) -> "AirmatError":
        """Set the file the problem is in (when not set yet) and return self."""
        if self.path is None:
            self.path = str(path)
        return self


class InputError(AirmatError, ValueError):
    """Bad user input: a file, a parameter or a combination of them."""


class NotACylinderError(InputError):
    """A scan that is not a cylindrical arc (a sphere, a box, random points)."""


class ConvergenceError(AirmatError, RuntimeError):
    """A solver diverged (NaN, energy blow-up) or could not reach its tolerance."""


class TaskError(AirmatError, RuntimeError):
    """A task failed on a Dask worker with an exception that is not airmat's (kept as ``__cause__``)."""
