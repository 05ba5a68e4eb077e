"""The CLI's text output (romams.cli.text): 4 significant figures, fixed-width tables with units, progress bars."""

import io

import pytest
from rich.console import Console

from romams.cli.text import PIPE_WIDTH, cell, progress_bar, sig, table


@pytest.mark.parametrize(("x", "kw", "expected"), [
    (114.79, {}, "114.8"),
    (10686.0, {}, "10690"),
    (0.0021034, {}, "0.002103"),
    (99.996, {}, "100.0"),  # rounded before the decimals are chosen: 4 figures, not 5
    (-0.0675, {}, "-0.06750"),
    (0.18636, {"signed": True}, "+0.1864"),
    (-0.18636, {"signed": True}, "-0.1864"),
    (0.0, {}, "0"),
    (1.2e-7, {}, "1.200e-07"),
    (3.4e8, {}, "3.400e+08"),
    (0.999974, {"digits": 6}, "0.999974"),
    (None, {}, "-"),
    (float("nan"), {}, "-"),
])
def test_sig_gives_four_significant_figures(x, kw, expected):
    assert sig(x, **kw) == expected


def test_cells_and_table_are_fixed_width_with_numbers_right_aligned():
    assert [cell(v) for v in (3, 2.34567, None, True, "dlm")] == ["3", "2.346", "-", "yes", "dlm"]
    t = table("title", ["Mach", "V (m/s)", "solver"], [["0.87", 114.79, "dlm"], ["0.95", 96.066, "uvlm"]])
    buf = io.StringIO()
    Console(file=buf, width=PIPE_WIDTH, soft_wrap=True).print(t)
    lines = [ln.rstrip() for ln in buf.getvalue().splitlines() if ln.strip()]
    assert lines[0] == "title" and "V (m/s)" in lines[1]
    rows = lines[3:]
    assert [r.split()[1] for r in rows] == ["114.8", "96.07"]
    # right-aligned numbers: the numbers end in the same column; the text column starts in the same column
    assert rows[0].index("114.8") + 5 == rows[1].index("96.07") + 5
    assert rows[0].index("dlm") == rows[1].index("uvlm")


def test_progress_bar_reports_the_fraction_and_ends():
    buf = io.StringIO()
    con = Console(file=buf, force_terminal=True, width=100)
    with progress_bar(con, "work") as bar:
        bar(0.5, "half")
        bar(2.0, "clamped")
    assert "work" in buf.getvalue()
