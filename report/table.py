"""HTML tables for the report, and the few lines of script that sort them by a click on a header.

:func:`html_table` turns columns and rows into a ``<table>``; a sortable table
sorts by a column when its header is clicked (numbers as numbers, a second
click reverses). :data:`SORT_JS` is the script, inlined once per page.
"""

from __future__ import annotations

from html import escape

__all__ = ["html_table", "SORT_JS"]

#: sorts a ``table.sortable`` by the clicked header; numeric when both cells parse as numbers
SORT_JS = """
document.querySelectorAll('table.sortable th').forEach(function (th, col) {
  th.addEventListener('click', function () {
    var table = th.closest('table'), body = table.tBodies[0];
    var idx = Array.prototype.indexOf.call(th.parentNode.children, th);
    var asc = th.getAttribute('data-sort') !== 'asc';
    table.querySelectorAll('th').forEach(function (h) { h.removeAttribute('data-sort'); });
    th.setAttribute('data-sort', asc ? 'asc' : 'desc');
    var rows = Array.prototype.slice.call(body.rows);
    rows.sort(function (a, b) {
      var x = a.cells[idx].textContent, y = b.cells[idx].textContent;
      var nx = parseFloat(x), ny = parseFloat(y);
      var c = (!isNaN(nx) && !isNaN(ny)) ? nx - ny : x.localeCompare(y);
      return asc ? c : -c;
    });
    rows.forEach(function (r) { body.appendChild(r); });
  });
});
"""


def _cell(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}" if abs(value) < 1e-3 and value != 0 else f"{value:.2f}"
    return escape(str(value))


def html_table(columns, rows, *, sortable: bool = False, table_id: str | None = None) -> str:
    """A ``<table>`` of ``rows`` under ``columns`` (text escaped; floats with 2 decimals).

    Parameters
    ----------
    columns : sequence of str
        Header texts.
    rows : iterable of sequence
        One sequence of cell values per row, as long as ``columns``.
    sortable : bool
        Headers sort the rows when clicked (needs :data:`SORT_JS` on the page).
    table_id : str, optional
        The table's ``id`` attribute.

    Returns
    -------
    str

    Examples
    --------
    >>> print(html_table(["id", "l (mm)"], [["k1-001-01", 123.456]]))
    <table><thead><tr><th>id</th><th>l (mm)</th></tr></thead>
    <tbody><tr><td>k1-001-01</td><td>123.46</td></tr></tbody></table>
    """
    columns = list(columns)
    body = []
    for row in rows:
        row = list(row)
        if len(row) != len(columns):
            raise ValueError(f"a row has {len(row)} cells for {len(columns)} columns: {row!r}")
        body.append("<tr>" + "".join(f"<td>{_cell(v)}</td>" for v in row) + "</tr>")
    attrs = (' class="sortable"' if sortable else "") + (f' id="{escape(table_id)}"' if table_id else "")
    head = "".join(f"<th>{escape(str(c))}</th>" for c in columns)
    return (f"<table{attrs}><thead><tr>{head}</tr></thead>\n<tbody>" + "".join(body) + "</tbody></table>")
