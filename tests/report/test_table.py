import pytest

from airmat.report.table import SORT_JS, html_table


def test_cells_are_escaped_and_rows_checked():
    html = html_table(["a", "b"], [["<script>", 1.0]], sortable=True, table_id="t")
    assert "&lt;script&gt;" in html and "<script>" not in html
    assert '<table class="sortable" id="t">' in html and "<td>1.00</td>" in html
    with pytest.raises(ValueError, match="2 cells for 3 columns"):
        html_table(["a", "b", "c"], [[1, 2]])


def test_the_sort_script_sorts_numbers_as_numbers():
    assert "parseFloat" in SORT_JS and "localeCompare" in SORT_JS
