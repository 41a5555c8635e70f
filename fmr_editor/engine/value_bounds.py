"""Bounds on a field's value over each fine cell, from the sizes of its terms (compiled loops).

Inside a cell, ``|xi|, |eta| <= 1/2`` and ``|w| <= 2^(-1/2)``, so:

- far field, ``(1/2pi) Re sum_l L_l w^l``: within ``(1/2pi) sum_{l >= 1} |L_l| 2^(-l/2)`` of its constant term,
  at any degree the raster evaluates;
- diffusion points' polynomials ``sum c_ij xi^i eta^j``: within ``sum_{ij > 0} |c_ij| 2^(-i-j)`` of ``c_00``;
  a near point adds at most its weight (its Gaussian is at most 1);
- a segment of length ``h`` in the cell's 3x3 block adds at most ``|E| max|S| + |C| / 2``
  (``single_layer_bound``; the double layer of a straight segment is at most 1/2).

The raster computes the segments' part in float32 where its bound allows (``kernels.single``), and, in
sub-cells, the part of the segments far from a sub-cell by their series (``kernels.subcells``): the raster's
bounds (``scalar_bounds``) count both errors too.

The renderer bounds the changes of an edit with them and culls the layers they settle (``render.bounds``,
``render.culling``); the raster leaves out the cells where a mask's bounds settle its layer's weight
(``composite.settled``).
"""

from __future__ import annotations

import numba
import numpy as np

from .kernels.fastmath import INV_TWO_PI
from .kernels.subcells import SEPARATION

SQRT_HALF = np.sqrt(0.5)


def single_layer_bound(length: np.ndarray, cell_size: float) -> np.ndarray:
    """Bound on ``|S|`` of segments of ``length`` over the pixels of any cell in whose 3x3 block they lie."""
    far = 2.0 * np.sqrt(2.0) * cell_size
    m = np.minimum(np.asarray(length, np.float64) / 2, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        singular = np.where(m > 0, 2 * m * (1 - np.log(m)), 0.0)
    return (length * max(np.log(far), 0.0) + singular) / (2 * np.pi)


def scalar_bounds(rep, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each fine cell's ``weights . value`` of ``rep`` at its centre's far field, and how far the raster's value
    (``engine.raster``, to ``rep.order``) may get from that at any point of the cell, ``(2^L, 2^L)`` each: its
    terms' sizes (``near_spread``), the float32 near field's error bound (``Representation.near_bounds``)
    and the sub-cells' series' tails (``subcell_tails``), not its final rounding.

    Parameters
    ----------
    rep : Representation
        (This module sits below ``representation``, which keeps the bounds: ``Representation.scalar_bounds``.)
    weights : numpy.ndarray
        ``(3,)``, at least 0, summing to at most 1 (a mask's luminance weights, say): the float32 bound is per
        channel.
    """
    n, order = rep.lattice.cells_per_side, rep.order
    if rep.points is not None and rep.points.tensor.shape[:2] != (n, n):
        raise ValueError("the points' lattice must be the representation's")
    weights = np.ascontiguousarray(weights, np.float64)
    centre = rep.centre_values @ weights
    segments = len(rep.near[0].p) > 0
    tails = subcell_tails(order, rep.lattice.cell_size) if order >= 1 else (0.0, 0.0)
    spread = np.ascontiguousarray(near_spread(rep, weights[:, None], tails)[..., 0])
    if segments:
        spread += rep.near_bounds
    _far_spread(np.ascontiguousarray(rep.local), weights, min(order, rep.local.shape[-1] - 1), spread)
    if rep.points is not None:
        tensor = rep.points.tensor
        _tensor_spread(np.ascontiguousarray(tensor), weights, min(order, tensor.shape[-1] - 1), centre, spread)
    if segments and order < 1:  # the sub-cells' series' logarithmic first term is not bounded so: nothing settles
        spread[...] = np.inf
    return centre, spread


def subcell_tails(order: int, cell_size: float) -> tuple[float, float]:
    """What the series of the raster's sub-cells (``kernels.subcells``, cells cut in two or more a side) of degree
    ``order`` (at least 1) may leave out of a segment's field, per unit of its ``|E|`` and of its ``|C|``.  A
    segment at least ``SEPARATION`` sub-cells ``s`` from a sub-cell's centre has ``|J_m| <= 2 SEPARATION^(1 - m) /
    (m - 1)`` (its ``v`` at least that far), so its terms past the order ``P`` sum to at most ``(|E| s SEPARATION
    / (P (P + 1)) + |C| / (P + 1)) 2 rho^(P + 1) / ((1 - rho) 2 pi)``, ``rho = 1 / (sqrt 2 SEPARATION)``, ``s``
    at most half a cell."""
    rho = 1.0 / (np.sqrt(2.0) * SEPARATION)
    tail = 2.0 * rho ** (order + 1) / (1.0 - rho) * INV_TWO_PI
    return tail * cell_size / 2 * SEPARATION / (order * (order + 1)), tail / (order + 1)


@numba.njit(parallel=True, cache=True)
def _far_spread(local, weights, order, spread):
    """Add ``(1/2pi) sum_{1 <= l <= order} |weights . L_l| 2^(-l/2)`` of each cell's ``local (n, n, 3, K)`` to
    ``spread (n, n)``."""
    n = local.shape[0]
    for cy in numba.prange(n):
        for cx in range(n):
            total, size = 0.0, 1.0
            for l in range(1, order + 1):
                size *= SQRT_HALF
                term = (weights[0] * local[cy, cx, 0, l] + weights[1] * local[cy, cx, 1, l]
                        + weights[2] * local[cy, cx, 2, l])
                total += np.sqrt(term.real * term.real + term.imag * term.imag) * size  # abs's hypot: 5x slower
            spread[cy, cx] += total * INV_TWO_PI


@numba.njit(parallel=True, cache=True)
def _tensor_spread(tensor, weights, order, centre, spread):
    """Add each cell's ``weights . c_00`` of ``tensor (n, n, 3, P + 1, P + 1)`` to ``centre (n, n)`` and
    ``sum_{0 < i + j, i, j <= order} |weights . c_ij| 2^(-i-j)`` to ``spread``."""
    n = tensor.shape[0]
    sizes = np.empty(2 * order + 1)
    sizes[0] = 0.0  # the constant term: the centre's
    for k in range(1, 2 * order + 1):
        sizes[k] = 0.5**k
    for cy in numba.prange(n):
        for cx in range(n):
            total = 0.0
            for i in range(order + 1):
                for j in range(order + 1):
                    term = (weights[0] * tensor[cy, cx, 0, i, j] + weights[1] * tensor[cy, cx, 1, i, j]
                            + weights[2] * tensor[cy, cx, 2, i, j])
                    total += abs(term) * sizes[i + j]
            centre[cy, cx] += (weights[0] * tensor[cy, cx, 0, 0, 0] + weights[1] * tensor[cy, cx, 1, 0, 0]
                               + weights[2] * tensor[cy, cx, 2, 0, 0])
            spread[cy, cx] += total


@numba.njit(parallel=True, cache=True)
def _segment_spread(cell_start, flux, jump, flux_sizes, jump_size, weights, spread):
    """Add ``|weights[:, k] . E| flux_sizes + |weights[:, k] . C| jump_size`` of each segment (sorted by cell) to the
    3x3 block of its cell in ``spread (n, n, k)``; rows of cells in three strides, so that no two threads add to
    one cell."""
    n, channels = spread.shape[0], spread.shape[2]
    for stride in range(3):
        for cy in numba.prange((n - stride + 2) // 3):
            row = 3 * cy + stride
            for cx in range(n):
                for j in range(cell_start[row * n + cx], cell_start[row * n + cx + 1]):
                    for k in range(channels):
                        e = flux[j, 0] * weights[0, k] + flux[j, 1] * weights[1, k] + flux[j, 2] * weights[2, k]
                        c = jump[j, 0] * weights[0, k] + jump[j, 1] * weights[1, k] + jump[j, 2] * weights[2, k]
                        size = abs(e) * flux_sizes[j] + abs(c) * jump_size
                        for y in range(max(row - 1, 0), min(row + 2, n)):
                            for x in range(max(cx - 1, 0), min(cx + 2, n)):
                                spread[y, x, k] += size


def load_kernels() -> None:
    """Load (from numba's cache, else compile) this module's kernels, on one cell (``raster_kernels``)."""
    weights, cell = np.ones(3), np.zeros((1, 1))
    _far_spread(np.zeros((1, 1, 3, 2), complex), weights, 1, cell)
    _tensor_spread(np.zeros((1, 1, 3, 2, 2)), weights, 1, cell, cell.copy())
    _segment_spread(np.zeros(2, np.int64), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), 0.5, np.ones((3, 1)),
                    np.zeros((1, 1, 1)))


def near_spread(rep, weights: np.ndarray, tails: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """``(2^L, 2^L, k)``: how far the segments of each fine cell's 3x3 block and the near points it lists may move
    ``weights.T @ value`` (``weights (3, k)``; the identity: each channel) at any point of the cell; ``tails``: more
    a segment, per unit of its ``|E|`` and of its ``|C|`` (``subcell_tails``)."""
    n, k = rep.lattice.cells_per_side, weights.shape[1]
    spread = np.zeros((n, n, k))
    seg, cell_start = rep.near
    if len(seg.p):
        single = single_layer_bound(np.hypot(*(seg.q - seg.p).T), rep.lattice.cell_size) + tails[0]
        _segment_spread(np.ascontiguousarray(cell_start, np.int64), np.ascontiguousarray(seg.flux, np.float64),
                        np.ascontiguousarray(seg.jump, np.float64), single, 0.5 + tails[1],
                        np.ascontiguousarray(weights, np.float64), spread)
    near = rep.points.near if rep.points is not None else None
    if near is not None and len(near):
        cell = np.repeat(np.arange(n * n), np.diff(near.cell_start))
        sizes = np.abs(near.points.weights @ weights)[near.members]
        for channel in range(k):
            spread[..., channel] += np.bincount(cell, sizes[:, channel], minlength=n * n).reshape(n, n)
    return spread
