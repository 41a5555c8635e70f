"""Recursive skeletonization: a compressed LU factorisation of the collocation system.

The collocation matrix A (``dense``) is dense, but the block coupling a box of
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
accuracy follows ``tolerance``.  ``solver`` uses it to precondition
GMRES (or to solve outright).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np
import scipy.linalg
from threadpoolctl import threadpool_limits

from ..geometry.segments import Segments
from ..kernels.fastmath import FAST_MATH
from ..threads import factorisation_threads
from . import dense
from .boxes import group, leaf_levels
from .entries import CollocationEntries
from .linalg import SparseSign, dense_inverse, interpolative, sketch_rows

#: Proxy circle radius over box width.  1.25 rather than 1.5: a quarter fewer near entries to compute
#: (roses: 211 against 276 million) for slightly larger skeletons, the same GMRES iterations.
PROXY_RADIUS = 1.25
#: Charges on the proxy circle.
PROXY_POINTS = 64
#: Largest mean number of unknowns per occupied leaf box.  96 rather than 64 put lady_bug's leaves one level
#: higher: its solve 504 -> 426 ms (best of 7, factorisation, right-hand side and GMRES, alternating) and an apply
#: to 64 columns 43 -> 34 ms; zephyr, poivron and fruits the same within the noise, roses' boxes unchanged.
LEAF_SIZE = 96
#: Mean unknowns per box from which a level's boxes are compressed on several threads.  Smaller
#: boxes spend most of their time in Python, holding the GIL: on two threads the finest levels
#: (about 35 unknowns a box) ran 1.4x slower, levels of 80 unknowns and more 1.3-1.6x faster.
THREADED_BOX = 48


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
    inverse = dense_inverse(m_rr)
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
        leaf_size: int = LEAF_SIZE,
        top_size: int = 1500,
        progress: Callable[[float], None] | None = None,
        workers: int | None = None,
    ) -> None:
        self.size = len(segments)
        self.entries = CollocationEntries(segments)
        self.scale = self.entries.flux_scale()
        self.tolerance = tolerance
        self.levels: list[LevelSteps] = []
        self.stored_bytes = 0
        self.memory_limit = dense.MEMORY_SHARE * dense.available_memory()
        self.workers = max(1, numba.get_num_threads() if workers is None else workers)
        mids = self.entries.midpoints
        self.origin = mids.min(axis=0) if len(mids) else np.zeros(2)
        self.side = float(np.ptp(mids, axis=0).max()) * (1 + 1e-9) + 1e-9 if len(mids) else 1.0
        self.reach = float(self.entries.length.max()) if len(mids) else 0.0
        levels = leaf_levels(mids, self.origin, self.side, leaf_size)
        boxes = {key: _Box(idx, self._block(idx, idx)) for key, idx in group(mids, self.origin, self.side, levels)}
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
        except np.linalg.LinAlgError as error:  # a box's block M_RR, or its interpolation, is singular
            raise _singular(self.size) from error
        finally:
            if pool:
                pool.shutdown(cancel_futures=True)  # after a failure, start no more boxes
        self.top = np.concatenate([b.indices for b in boxes.values()]) if boxes else np.zeros(0, np.int64)
        self._account(8 * len(self.top) ** 2)
        top_block = self._merged_block(list(boxes.values()))
        with factorisation_threads(len(self.top)):
            self.top_lu = _top_factors(top_block, self.size) if len(self.top) else None

    def _account(self, size: int) -> None:
        """Count ``size`` more bytes kept; fail early, before the machine runs out."""
        self.stored_bytes += size
        if self.stored_bytes > self.memory_limit:
            raise dense.SolveTooLargeError(
                f"{self.size:,} boundary segments: the compressed factorisation needs more than "
                f"{self.memory_limit / 1e9:.1f} GB, the share of memory available"
            )

    def _merged_block(self, children: list[_Box]) -> np.ndarray:
        indices = np.concatenate([c.indices for c in children]) if children else np.zeros(0, np.int64)
        block = self._block(indices, indices)
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
            self._block(near, box.indices, parallel=False),
            self.entries.at(proxy, box.indices, parallel=False) * self.scale[box.indices],
            self._block(box.indices, near, parallel=False).T,
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

    def _block(self, rows: np.ndarray, columns: np.ndarray, parallel: bool = True) -> np.ndarray:
        """``(A D)[rows][:, columns]``, the matrix factorised (``D``: ``scale``); ``parallel`` as ``entries.at``."""
        block = self.entries.block(rows, columns, parallel)
        block *= self.scale[columns]
        return block

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Approximate ``A^-1 rhs = D (A D)^-1 rhs`` for ``rhs`` of shape ``(n,)`` or ``(n, k)``."""
        x = np.array(rhs, dtype=float, copy=True)
        columns = x.reshape(len(x), -1)  # a view: the levels work on it in place
        for level in self.levels:
            level.forward(columns)
        if len(self.top):
            x[self.top] = scipy.linalg.lu_solve(self.top_lu, x[self.top], check_finite=False)
        for level in reversed(self.levels):
            level.backward(columns)
        columns *= self.scale[:, None]
        return x


def _singular(size: int) -> dense.SingularSystemError:
    return dense.SingularSystemError(
        f"{size:,} boundary segments: their system is singular (curves coincide or nearly coincide), "
        "and the compressed factorisation cannot solve it"
    )


def _top_factors(block: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """LU factors of the top block (overwritten); ``SingularSystemError`` where it is exactly singular."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", scipy.linalg.LinAlgWarning)  # lu_factor's word for an exactly singular one
        try:
            lu, pivots = scipy.linalg.lu_factor(block, overwrite_a=True, check_finite=False)
        except scipy.linalg.LinAlgWarning:
            raise _singular(size) from None
    if not np.isfinite(np.diagonal(lu)).all():
        raise _singular(size)
    return lu, pivots
