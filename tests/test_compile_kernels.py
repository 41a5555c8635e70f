"""``engine.compile_kernels``: each part reaches the kernels it is there to compile (numba records a signature
for every compiled or cache-loaded specialisation), so setup leaves none of them to a user's first render."""

from __future__ import annotations

import pytest

from fmr_editor.engine import blending, compile_kernels, value_bounds
from fmr_editor.engine.fmm import level_kernels
from fmr_editor.engine.kernels import grid, local_grid, near_rows, subcells
from fmr_editor.engine.points import tensor_kernels
from fmr_editor.engine.solve import entries, skeleton

#: The kernels each part calls from Python, of three channels or four.
KERNELS = {
    "near_grid": (grid._NEAR_GRID[3], near_rows._NEAR_ROWS[3], local_grid._LOCAL_GRID[3]),
    "sub_cells": (subcells._SUBCELL_GRID[3],),
    "four_channels": (grid._NEAR_GRID[4], near_rows._NEAR_ROWS[4], local_grid._LOCAL_GRID[4],
                      subcells._SUBCELL_GRID[4]),
    "solver": (skeleton._forward, skeleton._backward, entries._entries_parallel, level_kernels.level_local),
    "points": (tensor_kernels.accumulate,),
    "blending": (blending.blend_layer, grid._fill_cells, value_bounds._far_spread, value_bounds._tensor_spread,
                 value_bounds._segment_spread),
}


@pytest.mark.parametrize("part", sorted(compile_kernels.PARTS))
def test_each_part_compiles_the_kernels_it_names(part):
    compile_kernels.PARTS[part]()
    missing = [kernel.py_func.__qualname__ for kernel in KERNELS[part] if not kernel.signatures]
    assert not missing, f"{part} left {missing} uncompiled"


def test_the_parts_are_the_ones_checked_here():
    assert set(KERNELS) == set(compile_kernels.PARTS)
