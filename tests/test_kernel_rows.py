"""The raster kernels' walk over rows of cells (``kernels.rows``) and the runs of samples each row holds."""

from __future__ import annotations

import numpy as np
import pytest

from fmr_editor.engine.kernels.grid import grid_arrays, grid_cell_runs, grid_cell_runs_reference
from fmr_editor.engine.kernels.rows import spread_rows


def walk(start) -> list[int]:
    return list(spread_rows(np.asarray(start, np.int64)))


@pytest.mark.parametrize("rows", [1, 2, 3, 7, 32, 64, 100, 128, 1024])
def test_every_row_is_visited_once(rows):
    assert sorted(walk(np.arange(rows + 1))) == list(range(rows))


def test_bits_reversed():
    assert walk(np.arange(9)) == [0, 4, 2, 6, 1, 5, 3, 7]


def test_only_the_rows_between_the_first_and_last_with_samples():
    # rows 0 and 5-6 hold no samples, row 3 none between rows that do
    assert sorted(walk([0, 0, 3, 5, 5, 9, 9, 9])) == [1, 2, 3, 4]
    assert walk([4, 4, 4]) == []


@pytest.mark.parametrize("rows", [16, 32, 63, 64, 200])
@pytest.mark.parametrize("threads", [2, 3, 4])
def test_each_threads_share_of_the_walk_spreads_over_all_rows(rows, threads):
    """numba's prange gives each thread a contiguous range of the walk: each must reach every part of the rows (a
    band of a picture, or its busier half, is not one thread's)."""
    order = walk(np.arange(rows + 1))
    for share in np.array_split(np.array(order), threads):
        gaps = np.diff(np.concatenate([[-1], np.sort(share), [rows]]))
        assert gaps.max() <= 2 * threads - 1  # rows reached apart by about ``threads``: every part of the picture


def test_cell_runs_against_numpy():
    rng = np.random.default_rng(5)
    for trial in range(300):
        n, size = int(rng.integers(1, 70)), float(rng.uniform(0.3, 20.0))
        coords = np.sort(rng.uniform(-10.0, n * size + 10.0, int(rng.integers(0, 300))))
        if trial % 3 == 0:  # on the cells' edges: the one with the larger index
            coords = np.round(coords / size) * size
        assert np.array_equal(grid_cell_runs(coords, size, n), grid_cell_runs_reference(coords, size, n))


def test_unsorted_or_nan_coordinates_are_refused():
    sorted_xs = np.linspace(0.0, 10.0, 11)
    for bad in (sorted_xs[::-1], np.array([0.0, np.nan, 2.0])):
        with pytest.raises(ValueError, match="sorted"):
            grid_arrays(bad, sorted_xs, None)
        with pytest.raises(ValueError, match="sorted"):
            grid_arrays(sorted_xs, bad, None)
    grid_arrays(np.array([1.0, 1.0, 2.0]), sorted_xs, None)  # equal neighbours are sorted
