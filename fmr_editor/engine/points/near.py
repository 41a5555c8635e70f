"""Near points: diffusion points too small for the cell polynomials, evaluated exactly (compiled).

A point is *near* when even a fine cell is wider than ``max_cell_ratio * r``
(``gauss.expansion_ratios`` gives 0).  It is listed in every fine cell of its
window (the same square rule as the polynomial points: rows and columns
nearer than its reach ``R``), and a sample in a cell sums exactly over that
cell's list.  Outside its window a point is below ``tolerance``.

``gauss.gaussian_sum_reference`` is the plain reference; on a tensor grid
the kernel works cell by cell like ``grid.near_field_grid``, with
``exp(-(dx^2 + dy^2) / r^2) = exp(-dx^2 / r^2) exp(-dy^2 / r^2)`` so a point
costs one exponential per sample row and column of the cell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from ..fmm.lattice import Lattice
from ..kernels.grid import far_field_grid, grid_arrays, grid_cell_runs, skip_flags
from ..kernels.rows import spread_rows
from .gauss import GaussPoints, PointSettings, cell_range, cutoff_radii, expansion_ratios


@dataclass(frozen=True, eq=False)
class NearPoints:
    """Near points listed by the fine cells they reach (CSR).

    Attributes
    ----------
    points : GaussPoints
        The near points.
    reach : numpy.ndarray
        ``(k,)`` cutoff radii.
    cell_start : numpy.ndarray
        ``(4^L + 1,)`` offsets: cell ``row * 2^L + column`` lists ``members[cell_start[c]:cell_start[c + 1]]``.
    members : numpy.ndarray
        Indices into ``points``, grouped by cell, each cell's in increasing order.
    lattice : Lattice
    """

    points: GaussPoints
    reach: np.ndarray
    cell_start: np.ndarray
    members: np.ndarray
    lattice: Lattice

    @classmethod
    def build(cls, points: GaussPoints, reach: np.ndarray, lattice: Lattice) -> NearPoints:
        """List ``points`` (with cutoff radii ``reach``) in the fine cells of their windows."""
        n = lattice.cells_per_side
        owner, cell = _memberships(points, reach, lattice)
        order = np.argsort(cell, kind="stable")
        cell_start = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=n * n))]).astype(np.int64)
        return cls(points, np.asarray(reach, dtype=np.float64), cell_start, owner[order].astype(np.int64), lattice)

    def with_points(self, added: GaussPoints, reach: np.ndarray) -> NearPoints:
        """These near points and ``added`` (indices ``len(self)`` on), each cell's list still in increasing order."""
        n = self.lattice.cells_per_side
        owner, cell = _memberships(added, reach, self.lattice)
        order = np.argsort(cell, kind="stable")
        owner, cell = owner[order] + len(self), cell[order]
        members = np.insert(self.members, self.cell_start[cell + 1], owner)  # at the end of each cell's run
        cell_start = self.cell_start + np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=n * n))])
        points = GaussPoints(*(np.concatenate([getattr(self.points, name), getattr(added, name)])
                               for name in ("positions", "radii", "weights")))
        return NearPoints(points, np.concatenate([self.reach, reach]), cell_start, members, self.lattice)

    def without(self, index: np.ndarray) -> NearPoints:
        """These near points with those at ``index`` weighing nothing (their slots stay, summing exact zeros)."""
        weights = self.points.weights.copy()
        weights[index] = 0.0
        points = GaussPoints(self.points.positions, self.points.radii, weights)
        return NearPoints(points, self.reach, self.cell_start, self.members, self.lattice)

    def __len__(self) -> int:
        return len(self.points)


def _memberships(points: GaussPoints, reach: np.ndarray, lattice: Lattice) -> tuple[np.ndarray, np.ndarray]:
    """``(owner, cell)`` of every (point, fine cell of its window) pair, ``cell = row * 2^L + column``."""
    n = lattice.cells_per_side
    col0, col1 = cell_range(points.positions[:, 0], reach, lattice.cell_size, n)
    row0, row1 = cell_range(points.positions[:, 1], reach, lattice.cell_size, n)
    cols, rows = np.maximum(col1 - col0 + 1, 0), np.maximum(row1 - row0 + 1, 0)
    counts = cols * rows
    owner = np.repeat(np.arange(len(points)), counts)
    local = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    safe = np.maximum(cols[owner], 1)
    return owner, (row0[owner] + local // safe) * n + col0[owner] + local % safe


def near_points(points: GaussPoints, lattice: Lattice, settings: PointSettings = PointSettings()) -> NearPoints:
    """The near points among ``points`` (``expansion_ratios == 0``), listed by cell."""
    chosen = np.flatnonzero(expansion_ratios(points, lattice, settings) == 0)
    reach = cutoff_radii(points, settings.tolerance)[chosen]
    return NearPoints.build(points.take(chosen), reach, lattice)


@numba.njit(parallel=True, cache=True, error_model="numpy")
def _near_grid(xs, ys, x_start, y_start, n, cell_start, members, px, py, inv_r2, w, skip, out):
    spread = spread_rows(y_start)
    for t in numba.prange(len(spread)):
        cy = spread[t]
        ya, yb = y_start[cy], y_start[cy + 1]
        if ya == yb:
            continue
        ey = np.empty(yb - ya)
        ex = np.empty(xs.shape[0])
        for cx in range(n):
            xa, xb = x_start[cx], x_start[cx + 1]
            if xa == xb or (skip.shape[0] > 0 and skip[cy, cx]):
                continue
            for e in range(cell_start[cy * n + cx], cell_start[cy * n + cx + 1]):
                p = members[e]
                for a in range(yb - ya):
                    d = ys[ya + a] - py[p]
                    ey[a] = math.exp(-d * d * inv_r2[p])
                for b in range(xb - xa):
                    d = xs[xa + b] - px[p]
                    ex[b] = math.exp(-d * d * inv_r2[p])
                for a in range(yb - ya):
                    for b in range(xb - xa):
                        v = ey[a] * ex[b]
                        for c in range(w.shape[1]):
                            out[ya + a, xa + b, c] += w[p, c] * v


def near_grid(near: NearPoints, xs: np.ndarray, ys: np.ndarray, out: np.ndarray | None = None,
              scalar: np.ndarray | None = None, skip: np.ndarray | None = None) -> np.ndarray:
    """The near points' exact sum on the tensor grid ``ys x xs``, ``(len(ys), len(xs), 3)``; with ``scalar``
    ``(3,)``, the one channel ``scalar . colour`` (a mask's luminance), ``(len(ys), len(xs), 1)``.

    Parameters
    ----------
    near : NearPoints
    xs, ys : numpy.ndarray
        Sorted sample coordinates in document pixels.
    out : numpy.ndarray, optional
        C-contiguous float64 of that shape; the sum is *added* to it.
    scalar : numpy.ndarray, optional
        ``(3,)``: the weights of the one channel.
    skip : numpy.ndarray, optional
        ``(n, n)`` bool: cells whose samples are left as they are (not needed).
    """
    xs, ys, out = grid_arrays(xs, ys, out, 3 if scalar is None else 1)
    if len(near) == 0 or out.size == 0:
        return out
    n, size = near.lattice.cells_per_side, near.lattice.cell_size
    p = near.points
    weights = p.weights if scalar is None else p.weights @ np.reshape(scalar, (3, 1))
    _near_grid(xs, ys, grid_cell_runs(xs, size, n), grid_cell_runs(ys, size, n), n, near.cell_start,
               near.members, p.positions[:, 0].copy(), p.positions[:, 1].copy(), 1.0 / p.radii**2, weights,
               skip_flags(skip), out)
    return out


@numba.njit(parallel=True, cache=True, error_model="numpy")
def _near_at(targets, n, size, cell_start, members, px, py, inv_r2, w, out):
    for t in numba.prange(targets.shape[0]):
        x, y = targets[t, 0], targets[t, 1]
        col = min(max(int(math.floor(x / size)), 0), n - 1)
        row = min(max(int(math.floor(y / size)), 0), n - 1)
        for e in range(cell_start[row * n + col], cell_start[row * n + col + 1]):
            p = members[e]
            v = math.exp(-((x - px[p]) ** 2 + (y - py[p]) ** 2) * inv_r2[p])
            for c in range(3):
                out[t, c] += w[p, c] * v


def near_at(near: NearPoints, targets: np.ndarray) -> np.ndarray:
    """The near points' exact sum at arbitrary ``targets (m, 2)``, ``(m, 3)``.

    Each target sums over the list of its cell (clamped to the lattice).
    """
    targets = np.ascontiguousarray(targets, dtype=np.float64).reshape(-1, 2)
    out = np.zeros((len(targets), 3))
    if len(near) and len(targets):
        p = near.points
        _near_at(targets, near.lattice.cells_per_side, near.lattice.cell_size, near.cell_start, near.members,
                 p.positions[:, 0].copy(), p.positions[:, 1].copy(), 1.0 / p.radii**2, p.weights, out)
    return out


def polynomials_at(poly: np.ndarray, targets: np.ndarray, cell_size: float) -> np.ndarray:
    """Cell polynomials ``(n, n, 3, P + 1, P + 1)`` at arbitrary ``targets (m, 2)``, ``(m, 3)`` (cells clamped)."""
    targets = np.asarray(targets, dtype=np.float64).reshape(-1, 2)
    n = poly.shape[0]
    cells = np.clip(np.floor(targets[:, ::-1] / cell_size).astype(np.int64), 0, n - 1)
    local = targets / cell_size - (cells[:, ::-1] + 0.5)
    degrees = np.arange(poly.shape[-1])
    xi, eta = local[:, 0:1] ** degrees, local[:, 1:2] ** degrees
    return np.einsum("mcij,mi,mj->mc", poly[cells[:, 0], cells[:, 1]], xi, eta)


def evaluate_grid(poly: np.ndarray, near: NearPoints, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Points' field on the grid ``ys x xs``: cell polynomials (``grid.far_field_grid``) plus near points."""
    return near_grid(near, xs, ys, out=far_field_grid(poly, xs, ys, near.lattice.cell_size))


def evaluate_at(poly: np.ndarray, near: NearPoints, targets: np.ndarray) -> np.ndarray:
    """Points' field at arbitrary ``targets (m, 2)``: cell polynomials plus near points."""
    return polynomials_at(poly, targets, near.lattice.cell_size) + near_at(near, targets)
