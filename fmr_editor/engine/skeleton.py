"""Recursive skeletonization: a compressed LU factorisation of the collocation system.

The collocation matrix A (``bem``) is dense, but the block coupling a box of
segments to everything outside it has low numerical rank.  Working up a
quadtree from small boxes, each box keeps a *skeleton* of its unknowns
through which all of that coupling passes; its other (*redundant*) unknowns
are eliminated through a small dense inverse (Ho and Greengard 2012, in the
factorised form of Minden, Ho, Damle and Ying 2017, weak admissibility).
Whatever is left at the top is factorised densely.

Compressing a box needs its coupling to every other unknown.  The nearby
ones (within the proxy circle) are computed exactly; the field of everything
further away is harmonic inside the circle, so point charges on the circle
stand in for it, and likewise the box's own field outside the circle is
determined by its values on the circle.  One interpolative decomposition of
the stacked rows and transposed columns gives a skeleton serving both::

    A[N, R] ~ A[N, S] T        A[R, N] ~ T^T A[S, N]

Eliminating R then only changes the box's own skeleton block, so every other
entry the next levels need is an original matrix entry, computed on demand.

The factorisation costs far less than dense LU for large systems; its
accuracy follows ``tolerance``.  ``fast_solve`` uses it to precondition
GMRES (or to solve outright).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np
import scipy.linalg
import scipy.sparse
from threadpoolctl import threadpool_limits

from . import bem
from .fastmath import POLY_MATH
from .kernels import _layers, _segment_table
from .segments import Segments

#: Proxy circle radius over box width.
PROXY_RADIUS = 1.5
#: Charges on the proxy circle.
PROXY_POINTS = 64


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def _entries_row(x, y, own, columns, table, border, row):
    for b in range(table.shape[1]):  # contiguous rows, branch-free: vectorises
        s, d = _layers(x, y, table[0, b], table[1, b], table[2, b], table[3, b], table[4, b], table[5, b], table[6, b])
        d = 0.0 if columns[b] == own else d  # principal value on the segment itself
        row[b] = -d if border[b] else s
    if own >= 0:
        for b in range(table.shape[1]):
            if columns[b] == own and border[b]:
                row[b] -= 0.5


# Small blocks run serially: waking threads costs more than they save, and
# stalls behind BLAS's spinning threads on a busy machine.  (Two functions, not
# one compiled twice: numba's cache would confuse the two.)
@numba.njit(cache=True, fastmath=POLY_MATH, error_model="numpy")
def _entries_serial(targets, target_ids, columns, table, border, out):
    for a in range(targets.shape[0]):
        _entries_row(targets[a, 0], targets[a, 1], target_ids[a], columns, table, border, out[a])


@numba.njit(parallel=True, cache=True, fastmath=POLY_MATH, error_model="numpy")
def _entries_parallel(targets, target_ids, columns, table, border, out):
    for a in numba.prange(targets.shape[0]):
        _entries_row(targets[a, 0], targets[a, 1], target_ids[a], columns, table, border, out[a])


#: Pairs from which a block is computed in parallel.
PARALLEL_PAIRS = 200_000


class CollocationEntries:
    """Entries of the collocation matrix of ``segments`` on demand.

    Row i evaluates the field of unit densities at midpoint i: column j is
    ``S_ij`` on a curve segment, ``-D_ij`` on a border segment, with the
    principal value and the border's ``-1/2`` on the diagonal (``bem``).
    """

    def __init__(self, segments: Segments) -> None:
        self.table = _segment_table(segments.p, segments.q)
        self.border = np.asarray(segments.on_border, np.bool_)
        self.midpoints = segments.midpoints
        self.length = self.table[6]

    def block(self, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
        """``A[rows][:, columns]``, ``(len(rows), len(columns))``."""
        return self.at(self.midpoints[rows], columns, rows)

    def at(self, points: np.ndarray, columns: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
        """Field of unit densities on ``columns`` at ``points`` (not on those segments unless ``ids`` says so)."""
        out = np.empty((len(points), len(columns)))
        ids = np.full(len(points), -1, np.int64) if ids is None else ids
        kernel = _entries_parallel if out.size >= PARALLEL_PAIRS else _entries_serial
        table = np.ascontiguousarray(self.table[:, columns])  # fancy indexing may not give C order
        kernel(np.ascontiguousarray(points), ids, columns, table, self.border[columns], out)
        return out


def _pivoted_qr(matrix: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray, int]:
    """R factor, column order and numerical rank (pivots above ``tolerance`` times the largest, at least 1)."""
    r_factor, order = scipy.linalg.qr(matrix, mode="r", pivoting=True, overwrite_a=True, check_finite=False)
    pivots = np.abs(np.diag(r_factor))
    rank = int(np.count_nonzero(pivots > tolerance * pivots[0])) if len(pivots) and pivots[0] > 0 else 0
    return r_factor, order, max(rank, 1)


def interpolative(
    matrix: np.ndarray, tolerance: float, sketch: Callable[[int, int], np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Column interpolative decomposition by pivoted QR.

    ``sketch(rows, columns)``, when given, supplies Gaussian matrices for
    sketching a tall ``matrix`` first.

    Returns
    -------
    skeleton, redundant : numpy.ndarray
        Column positions; ``matrix[:, redundant] ~ matrix[:, skeleton] @ T``
        to ``tolerance`` relative to the largest pivot.
    T : numpy.ndarray
        ``(len(skeleton), len(redundant))``.
    """
    rows, columns = matrix.shape
    if sketch is not None and rows > 4 * columns:
        # A Gaussian sketch with twice as many rows as columns keeps the
        # column relations, well conditioned, and turns a tall pivoted QR
        # into one matrix product (measured 2-3x faster).
        matrix = sketch(2 * columns, rows) @ matrix
    r_factor, order, rank = _pivoted_qr(matrix, tolerance)
    T = scipy.linalg.solve_triangular(r_factor[:rank, :rank], r_factor[:rank, rank:], check_finite=False)
    return order[:rank], order[rank:], T


@dataclass(frozen=True)
class Elimination:
    """One box's step: its redundant unknowns R eliminated through its skeleton S."""

    redundant: np.ndarray
    skeleton: np.ndarray
    interpolation: np.ndarray  # T, (S, R)
    inverse: np.ndarray  # M_RR^-1
    lower: np.ndarray  # M_SR
    upper: np.ndarray  # M_RR^-1 M_RS


def eliminate(block: np.ndarray, skeleton: np.ndarray, redundant: np.ndarray, T: np.ndarray):
    """Eliminate ``redundant`` from a box's block given its interpolation ``T``.

    Returns the step's factors ``(inverse, lower, upper)`` and the skeleton's new block.
    """
    a_rr = block[np.ix_(redundant, redundant)]
    a_rs = block[np.ix_(redundant, skeleton)]
    a_sr = block[np.ix_(skeleton, redundant)]
    a_ss = block[np.ix_(skeleton, skeleton)]
    m_rs = a_rs - T.T @ a_ss
    m_sr = a_sr - a_ss @ T
    m_rr = a_rr - T.T @ a_sr - m_rs @ T
    inverse = scipy.linalg.inv(m_rr, overwrite_a=True, check_finite=False)
    upper = inverse @ m_rs
    return inverse, m_sr, upper, a_ss - m_sr @ upper


class LevelSteps:
    """One level's eliminations as sparse ``n x n`` matrices, applied at once.

    The boxes of a level own disjoint unknowns, so their steps commute.
    """

    def __init__(self, steps: list[Elimination], size: int) -> None:
        def sparse(pairs):
            rows = np.concatenate([np.repeat(r, len(c)) for r, c, _ in pairs])
            columns = np.concatenate([np.tile(c, len(r)) for r, c, _ in pairs])
            values = np.concatenate([block.ravel() for _, _, block in pairs])
            return scipy.sparse.csr_matrix((values, (rows, columns)), shape=(size, size))

        self.redundant = np.concatenate([s.redundant for s in steps])
        self.interpolation = sparse([(s.skeleton, s.redundant, s.interpolation) for s in steps])
        self.interpolation_t = self.interpolation.T.tocsr()
        self.inverse = sparse([(s.redundant, s.redundant, s.inverse) for s in steps])
        self.lower = sparse([(s.skeleton, s.redundant, s.lower) for s in steps])
        self.upper = sparse([(s.redundant, s.skeleton, s.upper) for s in steps])

    def forward(self, x: np.ndarray) -> None:
        """``x <- E L_T x`` and the redundant part of ``D^-1``, in place."""
        x -= self.interpolation_t @ x
        x[self.redundant] = (self.inverse @ x)[self.redundant]
        x -= self.lower @ x

    def backward(self, x: np.ndarray) -> None:
        """``x <- U_T F x``, in place."""
        x -= self.upper @ x
        x -= self.interpolation @ x


@dataclass
class _Box:
    indices: np.ndarray  # active unknowns (global)
    block: np.ndarray  # their current diagonal block


class SkeletonFactorization:
    """Compressed LU factorisation of a collocation matrix; ``solve`` applies its inverse.

    Parameters
    ----------
    segments : Segments
    tolerance : float
        Relative accuracy of each compression.
    leaf_size : int
        Largest mean number of unknowns per occupied leaf box.
    top_size : int
        Stop compressing when at most this many unknowns remain.
    progress : callable, optional
        Called with the fraction of the work done.
    """

    def __init__(
        self,
        segments: Segments,
        tolerance: float = 1e-8,
        leaf_size: int = 64,
        top_size: int = 1500,
        progress: Callable[[float], None] | None = None,
    ) -> None:
        self.size = len(segments)
        self.entries = CollocationEntries(segments)
        self.tolerance = tolerance
        self.levels: list[LevelSteps] = []
        self.stored_bytes = 0
        self.memory_limit = bem.MEMORY_SHARE * bem.available_memory()
        self._random = np.zeros((0, 0))
        mids = self.entries.midpoints
        self.origin = mids.min(axis=0) if len(mids) else np.zeros(2)
        self.side = float(np.ptp(mids, axis=0).max()) * (1 + 1e-9) + 1e-9 if len(mids) else 1.0
        self.reach = float(self.entries.length.max()) if len(mids) else 0.0
        levels = leaf_levels(mids, self.origin, self.side, leaf_size)
        boxes = {key: _Box(idx, self.entries.block(idx, idx)) for key, idx in _group(mids, self.origin, self.side, levels)}
        # Each box's algebra is small: BLAS threads would only wait on each other.
        with threadpool_limits(1, user_api="blas"):
            for level in range(levels, 1, -1):
                if sum(len(b.indices) for b in boxes.values()) <= top_size:
                    break
                if level < levels:
                    boxes = self._merge(boxes)
                self._compress_level(boxes, level)
                if progress:
                    progress((levels - level + 1) / levels)
        self.top = np.concatenate([b.indices for b in boxes.values()]) if boxes else np.zeros(0, np.int64)
        self._account(8 * len(self.top) ** 2)
        top_block = self._merged_block(list(boxes.values()))
        self.top_lu = scipy.linalg.lu_factor(top_block, overwrite_a=True, check_finite=False) if len(self.top) else None

    def _gaussian(self, rows: int, columns: int) -> np.ndarray:
        """A Gaussian matrix, cut from one drawn array (drawing dominated the sketches' cost)."""
        if rows > self._random.shape[0] or columns > self._random.shape[1]:
            shape = (max(rows, 2 * self._random.shape[0]), max(columns, 2 * self._random.shape[1]))
            self._random = np.random.default_rng(len(self._random)).standard_normal(shape)
        return self._random[:rows, :columns]

    def _account(self, size: int) -> None:
        """Count ``size`` more bytes kept; fail early, before the machine runs out."""
        self.stored_bytes += size
        if self.stored_bytes > self.memory_limit:
            raise bem.SolveTooLargeError(
                f"{self.size:,} boundary segments: the compressed factorisation needs more than "
                f"{self.memory_limit / 1e9:.1f} GB, the share of memory available"
            )

    def _merged_block(self, children: list[_Box]) -> np.ndarray:
        indices = np.concatenate([c.indices for c in children]) if children else np.zeros(0, np.int64)
        block = self.entries.block(indices, indices)
        start = 0
        for child in children:
            stop = start + len(child.indices)
            block[start:stop, start:stop] = child.block
            start = stop
        return block

    def _merge(self, boxes: dict) -> dict:
        parents: dict = {}
        for (kx, ky), box in boxes.items():
            parents.setdefault((kx // 2, ky // 2), []).append(box)
        return {key: _Box(np.concatenate([c.indices for c in kids]), self._merged_block(kids))
                for key, kids in parents.items()}

    def _compress_level(self, boxes: dict, level: int) -> None:
        width = self.side / 2**level
        radius = PROXY_RADIUS * width
        angles = 2 * np.pi * np.arange(PROXY_POINTS) / PROXY_POINTS
        circle = radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        span = int(math.ceil((radius + self.reach) / width))
        mids = self.entries.midpoints
        steps = []
        for (kx, ky), box in boxes.items():
            if len(box.indices) < 2:
                continue
            centre = self.origin + (np.array([kx, ky]) + 0.5) * width
            near = [boxes[(kx + dx, ky + dy)].indices for dx in range(-span, span + 1) for dy in range(-span, span + 1)
                    if (dx or dy) and (kx + dx, ky + dy) in boxes]
            near = np.concatenate(near) if near else np.zeros(0, np.int64)
            near = near[np.hypot(*(mids[near] - centre).T) < radius + self.reach]
            proxy = centre + circle
            own = mids[box.indices]
            charges = np.log(np.hypot(own[:, None, 0] - proxy[None, :, 0], own[:, None, 1] - proxy[None, :, 1]))
            stacked = np.concatenate([
                self.entries.block(near, box.indices),
                self.entries.at(proxy, box.indices),
                self.entries.block(box.indices, near).T,
                charges.T,
            ])
            skeleton, redundant, T = interpolative(stacked, self.tolerance, self._gaussian)
            if len(redundant) == 0:
                continue
            inverse, lower, upper, block = eliminate(box.block, skeleton, redundant, T)
            steps.append(Elimination(box.indices[redundant], box.indices[skeleton], T, inverse, lower, upper))
            self._account(2 * sum(a.nbytes for a in (T, inverse, lower, upper)))  # values and sparse indices
            box.indices, box.block = box.indices[skeleton], block
        if steps:
            self.levels.append(LevelSteps(steps, self.size))

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Approximate ``A^-1 rhs`` for ``rhs`` of shape ``(n,)`` or ``(n, k)``."""
        x = np.array(rhs, dtype=float, copy=True)
        for level in self.levels:
            level.forward(x)
        if len(self.top):
            x[self.top] = scipy.linalg.lu_solve(self.top_lu, x[self.top], check_finite=False)
        for level in reversed(self.levels):
            level.backward(x)
        return x


def _box_keys(points: np.ndarray, origin: np.ndarray, side: float, level: int) -> np.ndarray:
    count = 2**level
    return np.clip(np.floor((points - origin) / (side / count)).astype(np.int64), 0, count - 1)


def leaf_levels(points: np.ndarray, origin: np.ndarray, side: float, leaf_size: int) -> int:
    """Coarsest depth whose occupied boxes hold at most ``leaf_size`` points on average (at least 2)."""
    for level in range(2, 30):
        keys = _box_keys(points, origin, side, level)
        occupied = len(np.unique(keys[:, 0] * 2**level + keys[:, 1]))
        if len(points) <= leaf_size * occupied:
            return level
    return 30


def _group(points: np.ndarray, origin: np.ndarray, side: float, level: int):
    """``(key, indices)`` of each occupied box at ``level``."""
    keys = _box_keys(points, origin, side, level)
    flat = keys[:, 0] * 2**level + keys[:, 1]
    order = np.argsort(flat, kind="stable")
    unique, start = np.unique(flat[order], return_index=True)
    for box, indices in zip(unique, np.split(order, start[1:])):
        yield (int(box) // 2**level, int(box) % 2**level), indices
