"""Diffusion points into fine-cell polynomials: the batch build.

The output has ``Representation.polynomials()``'s layout,
``c[row, column, channel, i, j]`` of ``xi^i eta^j``, so it adds to the curves'
tensor.  ``point_polynomials_reference`` is the plain numpy twin;
``increments`` adds and removes points on a built tensor, ``near``
handles the points too small for polynomials.

Points are expanded on the grid of their ratio (``gauss.expansion_ratios``),
accumulated there, and grids are carried down (ratio ``m`` into ``m / 2``, 3
into 1) by exact changes of variable.  On a grid, a point's coefficients in a
cell are ``w (x) ux (x) uy`` with ``ux`` depending only on the cell's column and
``uy`` only on its row, so for the ``K`` points of one source block the sum
into each target cell is a small matrix product
``(3 (P+1) x K) (K x (P+1))``, done by a register-blocked kernel
(``tensor_kernels``; 7-15 G multiply-adds/s a core measured here for K >= 48,
against 1-2 for one read-modify-write of the cell a point).  Blocks are
``B x B`` source cells with ``B`` chosen for some ``BLOCK_POINTS`` points a
block.  Threads take stripes of source rows two apart, so no two write the
same target row (small grids: private copies, summed).
"""

from __future__ import annotations

import numba
import numpy as np

from ..fmm.lattice import Lattice
from .gauss import (
    GaussPoints,
    PointSettings,
    cell_range,
    cutoff_radii,
    expansion_ratios,
    scaled_hermite,
    shift_matrices,
)
from .tensor_kernels import accumulate

#: Points a source block should hold on average (measured: 48 beat 12, 24 and 96).
BLOCK_POINTS = 48.0
#: Largest grid (cells a side) that threads accumulate in private copies rather than stripes.
PRIVATE_CELLS = 48


def accumulate_grid(out: np.ndarray, points: GaussPoints, reach: np.ndarray, size: float) -> None:
    """Add ``points``' expansions to the grid ``out (g, g, 3, P + 1, P + 1)`` of cells ``size`` wide (in place).

    Points are grouped by source blocks of ``B x B`` cells, ``B`` chosen so a
    block holds some ``BLOCK_POINTS`` points (the blocked product's union
    window grows by ``B - 1`` cells, which costs less than thin products).
    """
    if not out.flags.c_contiguous:
        raise ValueError("the grid must be C-contiguous (it is filled through a reshaped view)")
    g = out.shape[0]
    x, y = points.positions[:, 0], points.positions[:, 1]
    col0, col1 = cell_range(x, reach, size, g)
    row0, row1 = cell_range(y, reach, size, g)
    keep = np.flatnonzero((col0 <= col1) & (row0 <= row1))
    if len(keep) == 0:
        return
    own_col = np.clip(np.floor(x[keep] / size), 0, g - 1).astype(np.int64)
    own_row = np.clip(np.floor(y[keep] / size), 0, g - 1).astype(np.int64)
    col0, col1, row0, row1 = col0[keep], col1[keep], row0[keep], row1[keep]
    around = int(max((own_col - col0).max(), (col1 - own_col).max(), (own_row - row0).max(), (row1 - own_row).max()))
    occupied = len(np.unique(own_row * g + own_col))
    block = int(np.clip(np.ceil(np.sqrt(BLOCK_POINTS * occupied / len(keep))), 1, max(1, around // 2)))
    blocks = -(-g // block)
    own = (own_row // block) * blocks + own_col // block
    order = np.lexsort((-reach[keep], own))
    block_start = np.searchsorted(own[order], np.arange(blocks * blocks + 1)).astype(np.int64)
    index = keep[order]
    # stripes two apart never write the same rows: 2 * around cells at least
    stripe = -(-max(2 * around, 1) // block)
    threads = numba.get_num_threads()
    private = g <= PRIVATE_CELLS and threads > 1 and -(-blocks // stripe) < 2 * threads
    flat = out.reshape(1, g, g, -1, out.shape[-1])
    target = np.zeros((threads,) + flat.shape[1:]) if private else flat
    accumulate(target, x[index], y[index], points.radii[index], points.weights[index],
                col0[order], col1[order], row0[order], row1[order], block_start, blocks, float(size),
                stripe, 2 * around + block, private)
    if private:
        flat[0] += target.sum(axis=0)


def shift_grid(grid: np.ndarray, factor: int, count: int) -> np.ndarray:
    """A grid's polynomials re-expanded on its cells' ``factor x factor`` children; ``count`` cells a side kept."""
    shift = shift_matrices(factor, grid.shape[-1] - 1)
    g = grid.shape[0]
    child = np.empty((g * factor, g * factor) + grid.shape[2:])
    for a in range(factor):  # row offset: eta
        for b in range(factor):  # column offset: xi
            # broadcast matmul: 8x faster here than einsum or tensordot
            child[a::factor, b::factor] = shift[b] @ grid @ shift[a].T
    return np.ascontiguousarray(child[:count, :count])


def point_polynomials(points: GaussPoints, lattice: Lattice, settings: PointSettings = PointSettings()) -> np.ndarray:
    """The polynomial points' fine-cell tensor ``(2^L, 2^L, 3, P + 1, P + 1)``.

    Near and dropped points (``expansion_ratios`` <= 0) are left out; see
    ``near`` for the former.
    """
    n, width = lattice.cells_per_side, settings.order + 1
    ratios = expansion_ratios(points, lattice, settings)
    reach = cutoff_radii(points, settings.tolerance)
    used = np.unique(ratios[ratios > 0])
    if len(used) == 0:
        return np.zeros((n, n, 3, width, width))
    pending: dict[int, np.ndarray] = {}
    for m in _chain(int(used.max())):
        count = -(-n // m)
        grid = pending.pop(m, None)
        chosen = np.flatnonzero(ratios == m)
        if len(chosen):
            if grid is None:
                grid = np.zeros((count, count, 3, width, width))
            accumulate_grid(grid, points.take(chosen), reach[chosen], m * lattice.cell_size)
        if grid is None:
            continue
        if m == 1:
            return grid
        target = m // 2 if m % 2 == 0 else 1
        child = shift_grid(grid, m // target, -(-n // target))
        pending[target] = child if target not in pending else pending[target] + child
    return pending.get(1, np.zeros((n, n, 3, width, width)))


def _chain(largest: int) -> list[int]:
    """Grid ratios from ``largest`` down to 1 in the order they are carried down (2^a and 3 * 2^a)."""
    ratios = set()
    for start in (1, 3):
        m = start
        while m <= largest:
            ratios.add(m)
            m *= 2
    return sorted(ratios, reverse=True)


def point_polynomials_reference(points: GaussPoints, lattice: Lattice, settings: PointSettings) -> np.ndarray:
    """The fine-cell tensor ``(2^L, 2^L, 3, P + 1, P + 1)`` point by point in plain numpy (slow; for tests).

    Each point's Hermite coefficients on its grid's cells, each carried to
    the fine cells below by ``shift_matrices``.
    """
    order, n = settings.order, lattice.cells_per_side
    out = np.zeros((n, n, 3, order + 1, order + 1))
    ratios = expansion_ratios(points, lattice, settings)
    reach = cutoff_radii(points, settings.tolerance)
    for i in np.flatnonzero(ratios > 0):
        m = int(ratios[i])
        size, count, shift = m * lattice.cell_size, -(-n // m), shift_matrices(m, order)
        (x, y), r = points.positions[i], points.radii[i]
        col0, col1 = cell_range(x, reach[i], size, count)
        row0, row1 = cell_range(y, reach[i], size, count)
        for row in range(row0, row1 + 1):
            uy = scaled_hermite((y - (row + 0.5) * size) / r, size / r, order)
            for col in range(col0, col1 + 1):
                ux = scaled_hermite((x - (col + 0.5) * size) / r, size / r, order)
                # fine[a, b] = S[b] (ux uy^T) S[a]^T for the fine cell (a, b) below
                fine = np.einsum("c,bq,ap->abcqp", points.weights[i], shift @ ux, shift @ uy)
                rows, cols = slice(row * m, min(row * m + m, n)), slice(col * m, min(col * m + m, n))
                out[rows, cols] += fine[: rows.stop - rows.start, : cols.stop - cols.start]
    return out
