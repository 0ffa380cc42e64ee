"""Short text and HTML summaries of result objects (``repr`` and Jupyter's ``_repr_html_``).

A result class lists what a user looks at first as ``(label, value)`` rows in
``_summary()``; :class:`Summarized` turns those rows into a one-line ``repr`` and
a small HTML table. The full data stays in the attributes.

Examples
--------
>>> from dataclasses import dataclass
>>> @dataclass(frozen=True, repr=False)
... class Fit(Summarized):
...     radius: float
...     def _summary(self):
...         return "Fit", [("radius", f"{self.radius * 1e3:.1f} mm")]
>>> Fit(0.15)
<Fit: radius 150.0 mm>
"""

from __future__ import annotations

import html

__all__ = ["Summarized", "summary_text", "summary_html"]


def summary_text(title: str, rows) -> str:
    """``<title: label value, label value, ...>``."""
    return f"<{title}: " + ", ".join(f"{k} {v}" for k, v in rows) + ">"


def summary_html(title: str, rows) -> str:
    """A two-column HTML table headed by ``title``."""
    body = "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th>"
                   f"<td style='text-align:left'>{html.escape(str(v))}</td></tr>" for k, v in rows)
    return f"<table><caption style='text-align:left'><b>{html.escape(title)}</b></caption>{body}</table>"


class Summarized:
    """Mixin: ``repr`` and ``_repr_html_`` from the class's ``_summary() -> (title, rows)``.

    A dataclass using it must pass ``repr=False`` (dataclasses replace an inherited ``__repr__``).
    """

    __slots__ = ()

    def _summary(self):  # pragma: no cover - every user overrides it
        raise NotImplementedError

    def __repr__(self) -> str:
        return summary_text(*self._summary())

    def _repr_html_(self) -> str:
        return summary_html(*self._summary())


def mm(x: float, digits: int = 1) -> str:
    """Metres as a millimetre string."""
    return f"{x * 1e3:.{digits}f} mm"


def band_mm(s, digits: int = 2) -> str:
    """A ParamSummary (m) as ``median [lo95, hi95] mm``."""
    return f"{s.median * 1e3:.{digits}f} [{s.lo95 * 1e3:.{digits}f}, {s.hi95 * 1e3:.{digits}f}] mm"
