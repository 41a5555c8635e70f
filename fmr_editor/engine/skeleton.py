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

The boxes of one level are compressed independently (each sees its
neighbours as they were when the level began), on as many threads as numba
uses once the boxes are large enough (``THREADED_BOX``): the entry and
sketch kernels release the GIL, and so do BLAS and LAPACK.  The tall stacks
are sketched by sparse sign matrices (``SparseSign``) before the pivoted QR.

The factorisation costs far less than dense LU for large systems; its
accuracy follows ``tolerance``.  ``fast_solve`` uses it to precondition
GMRES (or to solve outright).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np
import scipy.linalg
from scipy.linalg import lapack
from threadpoolctl import threadpool_limits

from . import bem
from .fastmath import POLY_MATH
from .kernels import FAST_MATH, _layers, _segment_table
from .segments import Segments

#: Proxy circle radius over box width.
PROXY_RADIUS = 1.5
#: Charges on the proxy circle.
PROXY_POINTS = 64
#: Mean unknowns per box from which a level's boxes are compressed on several threads.  Smaller
#: boxes spend most of their time in Python, holding the GIL: on two threads the finest levels
#: (about 35 unknowns a box) ran 1.4x slower, levels of 80 unknowns and more 1.3-1.6x faster.
THREADED_BOX = 48


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
# stalls behind BLAS's spinning threads on a busy machine.  The serial kernel
# releases the GIL, so threads compressing different boxes run it side by side.
# (Two functions, not one compiled twice: numba's cache would confuse the two.)
@numba.njit(cache=True, nogil=True, fastmath=POLY_MATH, error_model="numpy")
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

    def block(self, rows: np.ndarray, columns: np.ndarray, parallel: bool = True) -> np.ndarray:
        """``A[rows][:, columns]``, ``(len(rows), len(columns))``; see ``at`` for ``parallel``."""
        return self.at(self.midpoints[rows], columns, rows, parallel)

    def at(
        self, points: np.ndarray, columns: np.ndarray, ids: np.ndarray | None = None, parallel: bool = True
    ) -> np.ndarray:
        """Field of unit densities on ``columns`` at ``points`` (not on those segments unless ``ids`` says so).

        Large blocks are computed on numba's threads unless ``parallel`` is
        false (for callers that run on threads of their own).
        """
        out = np.empty((len(points), len(columns)))
        ids = np.full(len(points), -1, np.int64) if ids is None else ids
        kernel = _entries_parallel if parallel and out.size >= PARALLEL_PAIRS else _entries_serial
        table = np.ascontiguousarray(self.table[:, columns])  # fancy indexing may not give C order
        kernel(np.ascontiguousarray(points), ids, columns, table, self.border[columns], out)
        return out


#: Nonzeros in each column of a ``SparseSign`` (Martinsson and Tropp recommend 8).
SPARSE_SIGNS = 8
#: Sketch rows beyond the columns (the largest rank possible): see ``sketch_rows``.
SKETCH_OVERSAMPLING = 16


@numba.njit(inline="always")
def _hash(key):
    """splitmix64's finaliser: 64 well-mixed bits of the ``uint64`` ``key``."""
    key = (key ^ (key >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    key = (key ^ (key >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return key ^ (key >> np.uint64(31))


@numba.njit(cache=True, nogil=True, fastmath=FAST_MATH)
def _apply_sparse_sign(matrix, transposed, first, rows, seed, out):
    """``out += S[:, first:first + n] @ M`` for the ``SparseSign`` ``S`` of ``rows`` rows and ``seed``,
    where ``M`` is ``matrix`` (n rows) or, if ``transposed``, its transpose (n columns)."""
    blocks = min(SPARSE_SIGNS, rows)
    starts = np.arange(blocks + 1) * rows // blocks
    key = np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15)
    for i in range(matrix.shape[1] if transposed else matrix.shape[0]):
        for k in range(blocks):
            bits = _hash(key + np.uint64((first + i) * blocks + k))
            size = np.uint64(starts[k + 1] - starts[k])
            row = starts[k] + np.int64(((bits >> np.uint64(32)) * size) >> np.uint64(32))  # in [0, size)
            sign = 1.0 if bits & np.uint64(1) else -1.0
            if transposed:
                for j in range(out.shape[1]):
                    out[row, j] += sign * matrix[j, i]
            else:
                for j in range(out.shape[1]):
                    out[row, j] += sign * matrix[i, j]


class SparseSign:
    """A random ``rows x columns`` sparse sign matrix, to sketch tall matrices with.

    Its rows are cut into ``min(SPARSE_SIGNS, rows)`` blocks and each column
    has one +-1 in each block, at a position and with a sign hashed from the
    column, block and ``seed``.  It embeds a subspace about as well as a
    Gaussian matrix of the same size (Martinsson and Tropp 2020, section 9.2)
    but applies in ``SPARSE_SIGNS`` operations an entry instead of ``rows``;
    applying it releases the GIL.  Only ``rows`` and ``seed`` matter: any
    column count gives the leading columns of one matrix.
    """

    def __init__(self, rows: int, columns: int, seed: int = 0) -> None:
        self.shape, self.seed = (rows, columns), seed

    def __matmul__(self, matrix: np.ndarray) -> np.ndarray:
        return self.stacked([matrix])

    def stacked(self, blocks: list[np.ndarray]) -> np.ndarray:
        """``self @ np.concatenate(blocks)`` without the copy; a block may be a transposed view."""
        if sum(len(block) for block in blocks) != self.shape[1]:
            raise ValueError(f"a {self.shape} sketch cannot multiply {[block.shape for block in blocks]}")
        out = np.zeros((self.shape[0], blocks[0].shape[1]))
        first = 0
        for block in blocks:
            transposed = block.T.flags.c_contiguous and not block.flags.c_contiguous and block.dtype == np.float64
            data = block.T if transposed else np.ascontiguousarray(block, dtype=np.float64)
            _apply_sparse_sign(data, transposed, first, self.shape[0], self.seed, out)
            first += len(block)
        return out


# LAPACK is called directly below: on the many small boxes, scipy.linalg's checks and workspace
# queries cost more than the factorisations (60 us against 22 us for a 46 x 30 pivoted QR).

def _checked(info: int, routine: str) -> None:
    if info > 0:
        raise np.linalg.LinAlgError(f"{routine}: singular matrix")
    if info < 0:
        raise ValueError(f"{routine}: illegal argument {-info}")


def _pivoted_qr(matrix: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray, int]:
    """R factor (upper triangle), column order and numerical rank (pivots above ``tolerance`` times the
    largest, at least 1); ``matrix`` is overwritten when it is in Fortran order."""
    columns = matrix.shape[1]
    r_factor, order, _, _, info = lapack.dgeqp3(matrix, lwork=2 * columns + 64 * (columns + 1),
                                                             overwrite_a=True)
    _checked(info, "dgeqp3")
    pivots = np.abs(np.diag(r_factor))
    rank = int(np.count_nonzero(pivots > tolerance * pivots[0])) if len(pivots) and pivots[0] > 0 else 0
    return r_factor, order - 1, max(rank, 1)


def _inverse(matrix: np.ndarray) -> np.ndarray:
    """``matrix^-1`` (overwriting ``matrix`` when it is in Fortran order)."""
    lu, pivots, info = lapack.dgetrf(matrix, overwrite_a=True)
    _checked(info, "dgetrf")
    inverse, info = lapack.dgetri(lu, pivots, lwork=64 * max(1, len(matrix)), overwrite_lu=True)
    _checked(info, "dgetri")
    return inverse


def sketch_rows(rows: int, columns: int) -> int:
    """Rows of the sketch ``interpolative`` takes of a ``rows x columns`` matrix; 0 if it takes none.

    A random sketch with a few more rows than the rank can be keeps the
    column relations and turns a tall pivoted QR into one matrix product
    (with a Gaussian, measured 2-3x faster; a sparse sign matrix is cheaper
    still).  Twice as many rows as columns cost 15-25% more in all on fruits
    and roses, for 10-30% smaller errors.
    """
    return min(2 * columns, columns + SKETCH_OVERSAMPLING) if rows > 4 * columns else 0


def interpolative(
    matrix: np.ndarray, tolerance: float, sketch: Callable[[int, int], np.ndarray | SparseSign] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Column interpolative decomposition by pivoted QR.

    ``sketch(rows, columns)``, when given, supplies random matrices
    (Gaussian, or ``SparseSign``) for sketching a tall ``matrix`` first.

    Returns
    -------
    skeleton, redundant : numpy.ndarray
        Column positions; ``matrix[:, redundant] ~ matrix[:, skeleton] @ T``
        to ``tolerance`` relative to the largest pivot.
    T : numpy.ndarray
        ``(len(skeleton), len(redundant))``.
    """
    rows, columns = matrix.shape
    if sketch is not None and sketch_rows(rows, columns):
        matrix = sketch(sketch_rows(rows, columns), rows) @ matrix
    r_factor, order, rank = _pivoted_qr(matrix, tolerance)
    T = np.zeros((rank, 0))
    if rank < columns:
        T, info = lapack.dtrtrs(r_factor[:rank, :rank], r_factor[:rank, rank:])
        _checked(info, "dtrtrs")
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
    r = len(redundant)
    order = np.concatenate([redundant, skeleton])
    permuted = block[np.ix_(order, order)]  # one gather for the four blocks
    a_rr, a_rs, a_sr, a_ss = permuted[:r, :r], permuted[:r, r:], permuted[r:, :r], permuted[r:, r:]
    m_rs = a_rs - T.T @ a_ss
    m_sr = a_sr - a_ss @ T
    m_rr = a_rr - T.T @ a_sr - m_rs @ T
    inverse = _inverse(m_rr)
    upper = inverse @ m_rs
    return inverse, m_sr, upper, a_ss - m_sr @ upper


@numba.njit(cache=True, nogil=True, fastmath=FAST_MATH, error_model="numpy")
def _forward(x, redundant, red_start, skeleton, skel_start, interpolation, inverse, lower, rs_start, rr_start):
    """``LevelSteps.forward``: box b's unknowns are ``redundant[red_start[b]:red_start[b + 1]]`` and
    likewise its skeleton; its factors start at ``rs_start[b]`` (T, M_SR) and ``rr_start[b]`` (M_RR^-1)."""
    for b in range(len(red_start) - 1):
        r0, nr = red_start[b], red_start[b + 1] - red_start[b]
        s0, ns = skel_start[b], skel_start[b + 1] - skel_start[b]
        t, m, low = interpolation[rs_start[b]:], inverse[rr_start[b]:], lower[rs_start[b]:]
        xr, xs, y = np.empty(nr), np.empty(ns), np.empty(nr)
        for c in range(x.shape[1]):
            for i in range(nr):
                xr[i] = x[redundant[r0 + i], c]
            for j in range(ns):
                xs[j] = x[skeleton[s0 + j], c]
            for j in range(ns):  # x_R -= T^T x_S
                for i in range(nr):
                    xr[i] -= t[j * nr + i] * xs[j]
            for i in range(nr):  # x_R <- M_RR^-1 x_R
                acc = 0.0
                for j in range(nr):
                    acc += m[i * nr + j] * xr[j]
                y[i] = acc
                x[redundant[r0 + i], c] = acc
            for i in range(ns):  # x_S -= M_SR x_R
                acc = 0.0
                for j in range(nr):
                    acc += low[i * nr + j] * y[j]
                x[skeleton[s0 + i], c] = xs[i] - acc


@numba.njit(cache=True, nogil=True, fastmath=FAST_MATH, error_model="numpy")
def _backward(x, redundant, red_start, skeleton, skel_start, interpolation, upper, rs_start):
    """``LevelSteps.backward``, laid out as for ``_forward``."""
    for b in range(len(red_start) - 1):
        r0, nr = red_start[b], red_start[b + 1] - red_start[b]
        s0, ns = skel_start[b], skel_start[b + 1] - skel_start[b]
        t, up = interpolation[rs_start[b]:], upper[rs_start[b]:]
        xr, xs = np.empty(nr), np.empty(ns)
        for c in range(x.shape[1]):
            for i in range(nr):
                xr[i] = x[redundant[r0 + i], c]
            for j in range(ns):
                xs[j] = x[skeleton[s0 + j], c]
            for i in range(nr):  # x_R -= M_RR^-1 M_RS x_S
                acc = 0.0
                for j in range(ns):
                    acc += up[i * ns + j] * xs[j]
                xr[i] -= acc
                x[redundant[r0 + i], c] = xr[i]
            for i in range(ns):  # x_S -= T x_R
                acc = 0.0
                for j in range(nr):
                    acc += t[i * nr + j] * xr[j]
                x[skeleton[s0 + i], c] = xs[i] - acc


class LevelSteps:
    """One level's eliminations, packed, applied box by box.

    The boxes of a level own disjoint unknowns, so their steps commute.
    Each box's dense factors are stored row by row, one box after another.
    The compiled loops run on one thread: a few milliseconds of short boxes,
    which numba's threads slowed several times over whenever another thread
    (BLAS's, spinning after the FMM's products, or another process's) held a
    core.
    """

    def __init__(self, steps: list[Elimination]) -> None:
        def starts(counts):
            return np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)

        def packed(name):
            return np.concatenate([np.ravel(getattr(s, name)) for s in steps])

        self.redundant, self.skeleton = packed("redundant"), packed("skeleton")
        self.red_start = starts([len(s.redundant) for s in steps])
        self.skel_start = starts([len(s.skeleton) for s in steps])
        self.rs_start = starts([len(s.redundant) * len(s.skeleton) for s in steps])
        self.rr_start = starts([len(s.redundant) ** 2 for s in steps])
        self.interpolation, self.inverse = packed("interpolation"), packed("inverse")
        self.lower, self.upper = packed("lower"), packed("upper")

    def forward(self, x: np.ndarray) -> None:
        """``x <- E L_T x`` and the redundant part of ``D^-1``, in place; ``x`` is ``(n, k)``."""
        _forward(x, self.redundant, self.red_start, self.skeleton, self.skel_start, self.interpolation,
                 self.inverse, self.lower, self.rs_start, self.rr_start)

    def backward(self, x: np.ndarray) -> None:
        """``x <- U_T F x``, in place; ``x`` is ``(n, k)``."""
        _backward(x, self.redundant, self.red_start, self.skeleton, self.skel_start, self.interpolation,
                  self.upper, self.rs_start)


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
    workers : int, optional
        Threads compressing boxes side by side; by default numba's thread
        count (``NUMBA_NUM_THREADS``: the number of cores unless set).  The
        result does not depend on it.
    """

    def __init__(
        self,
        segments: Segments,
        tolerance: float = 1e-8,
        leaf_size: int = 64,
        top_size: int = 1500,
        progress: Callable[[float], None] | None = None,
        workers: int | None = None,
    ) -> None:
        self.size = len(segments)
        self.entries = CollocationEntries(segments)
        self.tolerance = tolerance
        self.levels: list[LevelSteps] = []
        self.stored_bytes = 0
        self.memory_limit = bem.MEMORY_SHARE * bem.available_memory()
        self.workers = max(1, numba.get_num_threads() if workers is None else workers)
        mids = self.entries.midpoints
        self.origin = mids.min(axis=0) if len(mids) else np.zeros(2)
        self.side = float(np.ptp(mids, axis=0).max()) * (1 + 1e-9) + 1e-9 if len(mids) else 1.0
        self.reach = float(self.entries.length.max()) if len(mids) else 0.0
        levels = leaf_levels(mids, self.origin, self.side, leaf_size)
        boxes = {key: _Box(idx, self.entries.block(idx, idx)) for key, idx in _group(mids, self.origin, self.side, levels)}
        # Each box's algebra is small: BLAS threads would only wait on each other.
        pool = ThreadPoolExecutor(self.workers) if self.workers > 1 else None
        try:
            with threadpool_limits(1, user_api="blas"):
                for level in range(levels, 1, -1):
                    if sum(len(b.indices) for b in boxes.values()) <= top_size:
                        break
                    if level < levels:
                        boxes = self._merge(boxes)
                    self._compress_level(boxes, level, pool)
                    if progress:
                        progress((levels - level + 1) / levels)
        finally:
            if pool:
                pool.shutdown(cancel_futures=True)  # after a failure, start no more boxes
        self.top = np.concatenate([b.indices for b in boxes.values()]) if boxes else np.zeros(0, np.int64)
        self._account(8 * len(self.top) ** 2)
        top_block = self._merged_block(list(boxes.values()))
        self.top_lu = scipy.linalg.lu_factor(top_block, overwrite_a=True, check_finite=False) if len(self.top) else None

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

    def _compress_level(self, boxes: dict, level: int, pool: ThreadPoolExecutor | None) -> None:
        """Compress every box of ``level`` (on ``pool``'s threads if given) and keep the level's steps.

        Each box sees its neighbours' unknowns as they were when the level
        began.  Outside a box's own block every entry is an original matrix
        entry, so a neighbour's unknowns eliminated meanwhile only add rows to
        the decomposition: the boxes are independent.
        """
        width = self.side / 2**level
        active = {key: box.indices for key, box in boxes.items()}
        keys = [key for key, box in boxes.items() if len(box.indices) >= 2]
        # Largest first, so that no thread is left with a big box at the end.
        order = sorted(keys, key=lambda key: -len(boxes[key].indices))
        if sum(len(boxes[key].indices) for key in keys) < THREADED_BOX * len(keys):
            pool = None

        def compress(key):
            return self._compress_box(key, boxes[key], active, width)

        results = {}
        for key, result in zip(order, pool.map(compress, order) if pool else map(compress, order)):
            if result is not None:
                step = result[0]
                self._account(sum(a.nbytes for a in (step.interpolation, step.inverse, step.lower, step.upper)))
                results[key] = result
        steps = []
        for key in keys:  # in box order: the same on any number of threads
            if key in results:
                step, block = results[key]
                boxes[key].indices, boxes[key].block = step.skeleton, block
                steps.append(step)
        if steps:
            self.levels.append(LevelSteps(steps))

    def _compress_box(
        self, key: tuple[int, int], box: _Box, active: dict, width: float
    ) -> tuple[Elimination, np.ndarray] | None:
        """One box's elimination step and its skeleton's new block (None if nothing is redundant).

        ``active`` maps each box of the level to its unknowns.  The entries
        are computed on the calling thread only (the same kernel whatever
        ``workers`` is, so the same bits).
        """
        kx, ky = key
        radius = PROXY_RADIUS * width
        span = int(math.ceil((radius + self.reach) / width))
        mids = self.entries.midpoints
        centre = self.origin + (np.array([kx, ky]) + 0.5) * width
        near = [active[(kx + dx, ky + dy)] for dx in range(-span, span + 1) for dy in range(-span, span + 1)
                if (dx or dy) and (kx + dx, ky + dy) in active]
        near = np.concatenate(near) if near else np.zeros(0, np.int64)
        offset = mids[near] - centre
        near = near[np.einsum("ij,ij->i", offset, offset) < (radius + self.reach) ** 2]
        angles = 2 * np.pi * np.arange(PROXY_POINTS) / PROXY_POINTS
        proxy = centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        own = mids[box.indices]
        dx, dy = np.subtract.outer(proxy[:, 0], own[:, 0]), np.subtract.outer(proxy[:, 1], own[:, 1])
        charges = 0.5 * np.log(dx * dx + dy * dy)  # log |own - proxy|, (proxy, own)
        blocks = [
            self.entries.block(near, box.indices, parallel=False),
            self.entries.at(proxy, box.indices, parallel=False),
            self.entries.block(box.indices, near, parallel=False).T,
            charges,
        ]
        rows = sum(len(block) for block in blocks)
        size = sketch_rows(rows, len(box.indices))  # sketched here, the tall stack never formed
        stacked = SparseSign(size, rows).stacked(blocks) if size else np.concatenate(blocks)
        skeleton, redundant, T = interpolative(stacked, self.tolerance)
        if len(redundant) == 0:
            return None
        inverse, lower, upper, block = eliminate(box.block, skeleton, redundant, T)
        return Elimination(box.indices[redundant], box.indices[skeleton], T, inverse, lower, upper), block

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Approximate ``A^-1 rhs`` for ``rhs`` of shape ``(n,)`` or ``(n, k)``."""
        x = np.array(rhs, dtype=float, copy=True)
        columns = x.reshape(len(x), -1)  # a view: the levels work on it in place
        for level in self.levels:
            level.forward(columns)
        if len(self.top):
            x[self.top] = scipy.linalg.lu_solve(self.top_lu, x[self.top], check_finite=False)
        for level in reversed(self.levels):
            level.backward(columns)
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
