"""The raster kernels' bookkeeping: their walk over rows of cells (``kernels.rows``), the runs of samples each row
holds and the sizes of their scratch, against plain numpy forms."""

from __future__ import annotations

import numpy as np
import pytest

from fmr_editor.engine.kernels.grid import (
    _column_sizes,
    _single_windows,
    grid_arrays,
    grid_cell_runs,
    grid_cell_runs_reference,
)
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
    assert walk([4, 4, 4]) == [] and walk([]) == []


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
        if trial % 5 == 0:  # far beyond the lattice: its first and last cells
            coords = np.concatenate([[-np.inf, -1e300], coords, [1e300, np.inf]])
        assert np.array_equal(grid_cell_runs(coords, size, n), grid_cell_runs_reference(coords, size, n))


def test_unsorted_or_nan_coordinates_are_refused():
    sorted_xs = np.linspace(0.0, 10.0, 11)
    for bad in (sorted_xs[::-1], np.array([0.0, np.nan, 2.0]), np.array([np.nan])):
        with pytest.raises(ValueError, match="sorted"):
            grid_arrays(bad, sorted_xs, None)
        with pytest.raises(ValueError, match="sorted"):
            grid_arrays(sorted_xs, bad, None)
    grid_arrays(np.array([1.0, 1.0, 2.0]), sorted_xs, None)  # equal neighbours are sorted


def runs(rng: np.random.Generator, n: int, most: int) -> np.ndarray:
    return np.concatenate([[0], np.cumsum(rng.integers(0, most + 1, n))]).astype(np.int64)


def test_scratch_sizes_against_numpy():
    """The most segments in a column of three cells, and the most samples in a window of three cells of a row."""
    rng = np.random.default_rng(2)
    for _ in range(300):
        n = int(rng.integers(1, 20))
        cell_start = runs(rng, n * n, 4) * (rng.uniform(size=1) < 0.9)  # and lattices without a segment
        x_start, y_start = runs(rng, n, 3), runs(rng, n, 3)
        counts = np.diff(cell_start).reshape(n, n)
        column = counts.copy()
        column[1:] += counts[:-1]
        column[:-1] += counts[1:]
        cells = np.arange(n)
        windows = x_start[np.minimum(cells + 2, n)] - x_start[np.maximum(cells - 1, 0)]
        expected = max(1, int(column.max())), max(1, int(np.diff(y_start).max() * windows.max()))
        assert _column_sizes(n, cell_start, x_start, y_start) == expected


def test_float32_windows_against_numpy():
    """A row's window of three cells runs in float32 where each of its cells' bounds is within the budget."""
    rng = np.random.default_rng(3)
    for n in (1, 2, 5, 16):
        bounds = rng.uniform(0.0, 2.0, (n, n))
        within = np.pad(bounds <= 1.0, ((0, 0), (1, 1)), constant_values=True)
        expected = within[:, :-2] & within[:, 1:-1] & within[:, 2:]
        np.testing.assert_array_equal(_single_windows(bounds, 1.0), expected)
