"""``benchmarks.tsd_steady_check --grid KEY=VALUE``: values typed like the GridSpec field, usage errors otherwise."""

from __future__ import annotations

import argparse
from dataclasses import replace

import pytest

from benchmarks.tsd_steady_check import grid_overrides
from romams_core.aero.tsd.grid import GridSpec


def test_grid_overrides_are_typed_like_the_field_and_build_a_valid_grid():
    """Integers stay integers, floats floats; the result replaces the defaults."""
    ap = argparse.ArgumentParser()
    mods = grid_overrides(ap, GridSpec(), ["n_z=33", "dz0=0.0133", "z_max=16"])
    assert mods == {"n_z": 33, "dz0": 0.0133, "z_max": 16.0}
    assert isinstance(mods["n_z"], int) and isinstance(mods["z_max"], float)
    grid = replace(GridSpec(), **mods)
    assert (grid.n_z, grid.dz0, grid.z_max, grid.n_chord) == (33, 0.0133, 16.0, 40)


@pytest.mark.parametrize("item, says", [("foo=1", "GridSpec field"), ("n_z", "GridSpec field"),
                                        ("n_z=2.5", "needs a int")])
def test_bad_grid_overrides_are_usage_errors(item, says, capsys):
    """An unknown key, a missing value or a value of the wrong type exits with status 2 and names the item."""
    with pytest.raises(SystemExit) as exc:
        grid_overrides(argparse.ArgumentParser(prog="tsd_steady_check"), GridSpec(), [item])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert item in err and says in err
