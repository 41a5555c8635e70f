"""Load the CPU raster's compiled kernels ahead of a render, on a tiny render of each kind.

``compile_kernels`` runs these to fill numba's cache; the editor's worker
thread runs ``load_raster_kernels`` after opening a document, because the
editor draws with shaders and its first CPU render is otherwise a save's
thumbnail or a PNG export, which would wait for the loading (0.2-0.7 s) or,
with a cache gone stale, the compiling (about 70 s).
"""

from __future__ import annotations

import numpy as np

from ..model.color_transform import IDENTITY
from ..model.layer import MASK_LUMA
from . import value_bounds
from .blending import blend_layer, layer_weights
from .composite import NEGLIGIBLE_WEIGHT
from .fmm.lattice import Lattice, sort_into_cells
from .geometry.segments import Segments
from .kernels.grid import cells_all, fill_cells
from .kernels.segment_sums import near_tables
from .kernels.subcells import subcell_field_grid


def _grid(cells: int, cell_size: float, split: int, samples_per_cell: int, channels: int = 3) -> None:
    """``subcell_field_grid`` of 40 random short segments on ``cells x cells``, both precisions, of ``channels``."""
    rng = np.random.default_rng(split)
    side = cells * cell_size
    p = rng.uniform(0.1 * side, 0.9 * side, (40, 2))
    q = p + rng.uniform(-2.0, 2.0, (40, 2))
    colours = rng.uniform(-1, 1, (40, channels))
    unsorted = Segments(p, q, colours, np.zeros((40, 3)), np.zeros(40, bool), colours[::-1].copy())
    seg, cell_start = sort_into_cells(unsorted, Lattice(int(np.log2(cells)), side))
    local = np.zeros((cells, cells, 3, 9), complex)
    coordinates = (np.arange(cells * samples_per_cell) + 0.5) * cell_size / samples_per_cell
    tables = near_tables(seg.p, seg.q, seg.flux, seg.jump)
    for precision in ("double", "single"):
        subcell_field_grid(local, 8, coordinates, coordinates, cell_size, cell_start, seg.p, seg.q, seg.flux,
                           seg.jump, split=split, tables=tables, precision=precision,
                           fourth=(local, None) if channels == 4 else None)


def near_grid() -> None:
    """The near and far field on a grid of cells not split (``grid``, ``near_rows``, ``local_grid``)."""
    _grid(8, 8.0, split=1, samples_per_cell=4)
    _grid(8, 8.0, split=1, samples_per_cell=2)


def sub_cells() -> None:
    """The raster of cells split into sub-cells (``subcells``)."""
    _grid(4, 64.0, split=2, samples_per_cell=32)


def four_channels() -> None:
    """``near_grid`` and ``sub_cells`` of four channels: a translucent layer's image with its alpha field."""
    _grid(8, 8.0, split=1, samples_per_cell=4, channels=4)
    _grid(8, 8.0, split=1, samples_per_cell=2, channels=4)
    _grid(4, 64.0, split=2, samples_per_cell=32, channels=4)


def blending() -> None:
    """The composition of a layered picture (``blending``), with the arguments ``composite.compose`` gives, the
    cells a layer is hidden in (``grid.cells_all``), a mask's bounds (``value_bounds``) and its settled cells'
    values (``grid.fill_cells``)."""
    samples = np.zeros((1, 3))
    blend_layer(np.zeros((1, 3)), np.zeros(1), samples, IDENTITY.matrix, IDENTITY.offset, False, samples, MASK_LUMA,
                1.0, True, False, NEGLIGIBLE_WEIGHT, samples, 0, 1.0, False, True, False)
    layer_weights(np.zeros(1), samples, MASK_LUMA, 1.0, True, False, NEGLIGIBLE_WEIGHT, samples, 0, 1.0)
    cells_all(np.ones((1, 1), bool), np.arange(2), np.arange(2))
    fill_cells(np.zeros((1, 1, 3)), np.ones((1, 1), bool), np.zeros((1, 1)), np.full(1, 0.5), np.full(1, 0.5), 1.0)
    value_bounds.load_kernels()


def load_raster_kernels() -> None:
    """Load (from numba's cache, else compile) the kernels of every kind of CPU render."""
    near_grid()
    sub_cells()
    four_channels()
    blending()
