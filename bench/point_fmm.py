"""The engine's FMM applied to point charges and dipoles (docs/design.md section 3), for ``bench_fmm2d``.

Computes, at every target x (a complex number z),

    u(x) = sum_j c_j ln|x - y_j| - d_j . (x - y_j) / |x - y_j|^2
         = Re sum_j [c_j ln(z - y_j) - d_j / (z - y_j)]          (d_j as x + iy)

which is exactly the potential of fmm2d's ``rfmm2d`` (Flatiron's Fortran FMM,
``fmm2dpy``) with ``charges = c`` and ``dipstr * dipvec = d``; fmm2d's
docstring writes the dipole term with a plus sign, its math page and its
output (checked numerically against fmm2dpy 0.0.5) with the minus sign used
here.  A source closer to the target than ``side * 2^-52`` (side of the
bounding square of sources and targets) is left out of the sum, as fmm2d
does, so sources can be their own targets.  There is no 1/2pi: the engine's
densities on a short segment (length h, normal n0 as a complex number) map
as ``c = E h / 2pi`` and ``d = -C h n0 / 2pi``.

The far field goes through the engine's own passes: point-to-multipole
here (the point limit of ``expansions.multipole_moments_reference``), the M2M loop of
``lattice.upward_pass`` and ``lattice.downward_pass`` unchanged, run on one
channel rather than the three colour channels (the passes are generic in
the channel count; three cost 2.5-2.9x as much, measured: 1.40 s against
0.57 s for the downward pass of 65,536 cells at order 18).  Near field (the 3x3
block of each target's cell) and the evaluation of the fine-level locals are
compiled kernels (the engine's ``far_field_at`` evaluates the locals).
``evaluate_points_reference`` is the plain reference.  Not part of the editor:
``bench_fmm2d.py`` and ``tests/test_point_fmm.py`` use it.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

from fmr_editor.engine.fmm.far_field import far_field_at
from fmr_editor.engine.fmm.lattice import Lattice, coarser_multipoles, downward_pass
from fmr_editor.engine.kernels.fastmath import FAST_MATH
from fmr_editor.engine.kernels.segment_sums import cells_of, counting_sort

#: Time of one term-pair of the lattice passes (one cell, (order + 1)^2) against one near-field
#: source-target pair; measured here (2 cores, order 16: 0.38 s for the passes of 65,536 cells,
#: about 2.2 ns a near pair).  Sets the depth, ``fmm_levels``.
PASS_TO_PAIR_COST = 7.0


def fmm_levels(sources: int, targets: int, order: int) -> int:
    """Lattice depth with the least modelled time for spread-out (uniform-like) points.

    Near-field pairs ``9 * targets * sources / 4^L`` against the passes'
    ``4^L (order + 1)^2`` weighted by ``PASS_TO_PAIR_COST``.  At order 16 this
    gives 15-60 sources per fine cell (1e6 points: depth 8, 15 a cell;
    1e5: depth 6, 24 a cell), where timing every depth found the fastest.
    """
    def cost(levels: int) -> float:
        cells = 4.0**levels
        return 9.0 * targets * sources / cells + PASS_TO_PAIR_COST * cells * (order + 1) ** 2

    return min(range(2, 13), key=cost)


def _dipole_vectors(dipoles: np.ndarray | None, count: int) -> np.ndarray:
    """Dipoles ``(n, 2)`` vectors or ``(n,)`` complex ``d_x + i d_y`` as ``(n, 2)`` float64."""
    if dipoles is None:
        return np.zeros((count, 2))
    dipoles = np.asarray(dipoles)
    if np.iscomplexobj(dipoles):
        dipoles = dipoles.reshape(count)
        return np.stack([dipoles.real, dipoles.imag], axis=1).astype(np.float64)
    return np.asarray(dipoles, dtype=np.float64).reshape(count, 2)


def evaluate_points_reference(
    sources: np.ndarray,
    charges: np.ndarray | None,
    dipoles: np.ndarray | None,
    targets: np.ndarray | None = None,
    block: int = 2**16,
) -> np.ndarray:
    """The plain sum ``u(x)`` (module docstring) at ``targets``; ``(m,)``.

    Numpy over blocks of ``block`` source-target pairs (about 100 M pairs/s
    here), with the same exclusion radius as ``evaluate_points_fmm``.

    Parameters
    ----------
    sources : numpy.ndarray
        ``(n, 2)`` positions.
    charges : numpy.ndarray or None
        ``(n,)`` real charge strengths c.
    dipoles : numpy.ndarray or None
        ``(n, 2)`` dipole vectors d (fmm2d's ``dipstr * dipvec``) or ``(n,)`` complex ``d_x + i d_y``.
    targets : numpy.ndarray, optional
        ``(m, 2)``; the sources themselves when omitted (own term left out).
    block : int
        Source-target pairs per numpy operation.
    """
    sources = np.asarray(sources, dtype=np.float64).reshape(-1, 2)
    targets = sources if targets is None else np.asarray(targets, dtype=np.float64).reshape(-1, 2)
    n, m = len(sources), len(targets)
    charge = np.zeros(n) if charges is None else np.asarray(charges, dtype=np.float64).reshape(n)
    dipole = _dipole_vectors(dipoles, n)
    both = sources if targets is sources else np.concatenate([sources, targets])
    extent = float(np.ptp(both, axis=0).max()) if len(both) else 0.0
    tiny2 = (max(extent, 1e-300) * (1.0 + 1e-12) * 2.0**-52) ** 2
    sx, sy = np.ascontiguousarray(sources.T)
    dx_s, dy_s = np.ascontiguousarray(dipole.T)
    cols = max(1, min(n, block // 16))
    rows = max(1, block // cols)
    buffers = np.empty((4, rows, cols))
    out = np.zeros(m)
    for t0 in range(0, m, rows):
        tx, ty = targets[t0 : t0 + rows, 0:1], targets[t0 : t0 + rows, 1:2]
        for s0 in range(0, n, cols):
            part = slice(s0, min(s0 + cols, n))
            dx, dy, r2, square = buffers[:, : len(tx), : part.stop - s0]
            np.subtract(tx, sx[part], out=dx)
            np.subtract(ty, sy[part], out=dy)
            np.multiply(dx, dx, out=r2)
            np.multiply(dy, dy, out=square)
            r2 += square
            dx *= dx_s[part]
            dy *= dy_s[part]
            dx += dy  # d . (x - y)
            own = r2 <= tiny2
            if own.any():
                r2[own], dx[own] = 1.0, 0.0
            dx /= r2
            np.log(r2, out=r2)
            out[t0 : t0 + len(tx)] += 0.5 * (r2 @ charge[part]) - dx.sum(axis=1)
    return out


@intrinsic
def _bits(typingctx, x):
    """The IEEE-754 bits of a float64 as an int64 (a bitcast, which LLVM vectorises)."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.int64))
    return types.int64(types.float64), codegen


@intrinsic
def _from_bits(typingctx, i):
    """The float64 with the IEEE-754 bits of an int64."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float64))
    return types.float64(types.int64), codegen


_SQRT_HALF_BITS = 0x3FE6A09E667F3BCD
_LN2 = math.log(2.0)


@numba.njit(cache=True, inline="always", fastmath=FAST_MATH, error_model="numpy")
def _log_parts(x):
    """``(k, m)`` with ``x = 2^k m``, ``m`` in ``[sqrt(1/2), sqrt(2))``, for a positive normal x."""
    u = _bits(x) + (0x3FF0000000000000 - _SQRT_HALF_BITS)
    return (u >> 52) - 1023, _from_bits((u & 0x000FFFFFFFFFFFFF) + _SQRT_HALF_BITS)


@numba.njit(cache=True, inline="always", fastmath=FAST_MATH, error_model="numpy")
def _log_series(k, s):
    """``k ln 2 + 2 atanh(s)`` for ``|s| <= 0.172`` (11 terms: below 1e-18 truncation)."""
    s2 = s * s
    p = 1.0 / 21.0
    p = p * s2 + 1.0 / 19.0
    p = p * s2 + 1.0 / 17.0
    p = p * s2 + 1.0 / 15.0
    p = p * s2 + 1.0 / 13.0
    p = p * s2 + 1.0 / 11.0
    p = p * s2 + 1.0 / 9.0
    p = p * s2 + 1.0 / 7.0
    p = p * s2 + 1.0 / 5.0
    p = p * s2 + 1.0 / 3.0
    return k * _LN2 + 2.0 * s + (2.0 * s * s2) * p


@numba.njit(cache=True, error_model="numpy")
def _bounds(points, extra):
    """Lower corner and side of the bounding square of two ``(n, 2)`` point sets."""
    lo_x = lo_y = np.inf
    hi_x = hi_y = -np.inf
    for pts in (points, extra):
        for i in range(pts.shape[0]):
            lo_x, hi_x = min(lo_x, pts[i, 0]), max(hi_x, pts[i, 0])
            lo_y, hi_y = min(lo_y, pts[i, 1]), max(hi_y, pts[i, 1])
    return lo_x, lo_y, max(hi_x - lo_x, hi_y - lo_y)


@numba.njit(parallel=True, cache=True, error_model="numpy")
def _gather_points(perm, points, lo_x, lo_y):
    """Sorted x and y, shifted to the lattice origin, contiguous."""
    x, y = np.empty(perm.shape[0]), np.empty(perm.shape[0])
    for j in numba.prange(perm.shape[0]):
        x[j] = points[perm[j], 0] - lo_x
        y[j] = points[perm[j], 1] - lo_y
    return x, y


@numba.njit(parallel=True, cache=True, error_model="numpy")
def _gather_strengths(perm, charge, dipole):
    """Sorted charges and dipole components (``dipole (n, 2)``), contiguous."""
    c, dx, dy = np.empty(perm.shape[0]), np.empty(perm.shape[0]), np.empty(perm.shape[0])
    for j in numba.prange(perm.shape[0]):
        c[j], dx[j], dy[j] = charge[perm[j]], dipole[perm[j], 0], dipole[perm[j], 1]
    return c, dx, dy


def _sort_points(points: np.ndarray, lo_x: float, lo_y: float, lattice: Lattice):
    """Permutation sorting ``points`` by fine cell, CSR offsets of the cells, sorted shifted x and y."""
    cells = lattice.cells_per_side
    perm, start = counting_sort(cells_of(points - [lo_x, lo_y], cells, lattice.cell_size), cells * cells)
    x, y = _gather_points(perm, points, lo_x, lo_y)
    return perm, start, x, y


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH, error_model="numpy")
def _p2m(sx, sy, charge, dip_x, dip_y, cell_start, cells_per_side, cell_size, order, out):
    """Scaled multipoles of every fine cell from its sorted point sources; ``out (cells, P + 1)``.

    The point limit of ``expansions.multipole_moments_reference``: about the cell centre
    zc, with zeta = (y - zc) / r, ``A_0 = sum c`` and
    ``A_k = sum [-(c / k) zeta^k - (d / r) zeta^(k-1)]``.
    """
    n = cells_per_side
    for cell in numba.prange(n * n):
        cx = ((cell % n) + 0.5) * cell_size
        cy = ((cell // n) + 0.5) * cell_size
        for j in range(cell_start[cell], cell_start[cell + 1]):
            zeta = complex((sx[j] - cx) / cell_size, (sy[j] - cy) / cell_size)
            mu = -complex(dip_x[j], dip_y[j]) / cell_size
            out[cell, 0] += charge[j]
            power = 1.0 + 0.0j
            for k in range(1, order + 1):
                out[cell, k] += mu * power
                power *= zeta
                out[cell, k] -= (charge[j] / k) * power


@numba.njit(cache=True, inline="always", fastmath=FAST_MATH, error_model="numpy")
def _near_run(x, y, sx, sy, charge, dip_x, dip_y, lo, hi, tiny2):
    """Sum over sources ``lo:hi`` at (x, y), those within ``sqrt(tiny2)`` left out.

    One division per pair serves both 1/r^2 and the logarithm's
    ``(m - 1) / (m + 1)``; with the branch-free logarithm (within 4e-16 of
    ``math.log``, tested) the loop vectorises, which ``math.log`` prevents
    here (numba has no vector maths library on this machine): 350 against
    146 M pairs/s at 1e6 points, 61 a cell, 2 threads.
    """
    total = 0.0
    for j in range(lo, hi):
        dx = x - sx[j]
        dy = y - sy[j]
        r2 = dx * dx + dy * dy
        k, m = _log_parts(r2)
        m1 = m + 1.0
        rec = 1.0 / (r2 * m1)
        log_r2 = _log_series(k, (m - 1.0) * (rec * r2))
        term = 0.5 * charge[j] * log_r2 - (dip_x[j] * dx + dip_y[j] * dy) * (rec * m1)
        total += term if r2 > tiny2 else 0.0
    return total


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH, error_model="numpy")
def _near_field(tx, ty, target_start, sx, sy, charge, dip_x, dip_y, source_start, cells_per_side, tiny2, out):
    """Add the near field to ``out`` at targets sorted by cell.

    The sources of the three cells of one row of a 3x3 block are one
    contiguous run (cells are numbered row by row).
    """
    n = cells_per_side
    for cell in numba.prange(n * n):
        row, col = cell // n, cell % n
        c0, c1 = max(col - 1, 0), min(col + 1, n - 1)
        r0, r1 = max(row - 1, 0), min(row + 1, n - 1)
        for i in range(target_start[cell], target_start[cell + 1]):
            total = 0.0
            for r in range(r0, r1 + 1):
                total += _near_run(
                    tx[i], ty[i], sx, sy, charge, dip_x, dip_y,
                    source_start[r * n + c0], source_start[r * n + c1 + 1], tiny2,
                )
            out[i] += total


def evaluate_points_fmm(
    sources: np.ndarray,
    charges: np.ndarray | None,
    dipoles: np.ndarray | None,
    targets: np.ndarray | None = None,
    levels: int | None = None,
    order: int = 16,
    timings: dict[str, float] | None = None,
) -> np.ndarray:
    """``u(x)`` (module docstring) at ``targets`` by the lattice FMM; ``(m,)``.

    Parameters
    ----------
    sources : numpy.ndarray
        ``(n, 2)`` positions.
    charges : numpy.ndarray or None
        ``(n,)`` real charge strengths c.
    dipoles : numpy.ndarray or None
        ``(n, 2)`` dipole vectors d (fmm2d's ``dipstr * dipvec``) or ``(n,)`` complex ``d_x + i d_y``.
    targets : numpy.ndarray, optional
        ``(m, 2)``; the sources themselves when omitted (own term left out).
    levels : int, optional
        Lattice depth (``2^levels`` cells a side); by default ``fmm_levels``.
    order : int
        Highest expansion term carried and evaluated.
    timings : dict, optional
        Filled with the seconds spent in each stage (sort, p2m, m2m, downward, evaluate).

    Notes
    -----
    The lattice covers the bounding square of sources and targets.
    """
    clock = _Clock(timings)
    sources = np.ascontiguousarray(sources, dtype=np.float64).reshape(-1, 2)
    n = len(sources)
    same = targets is None
    targets = sources if same else np.ascontiguousarray(targets, dtype=np.float64).reshape(-1, 2)
    charge = np.zeros(n) if charges is None else np.ascontiguousarray(charges, dtype=np.float64).reshape(n)
    dipole = _dipole_vectors(dipoles, n)
    if n == 0 or len(targets) == 0:
        return np.zeros(len(targets))
    if levels is None:
        levels = fmm_levels(n, len(targets), order)
    lo_x, lo_y, extent = _bounds(sources, targets)
    side = max(extent, 1e-300) * (1.0 + 1e-12)
    lattice = Lattice(levels, side)
    cells = lattice.cells_per_side
    perm, source_start, sx, sy = _sort_points(sources, lo_x, lo_y, lattice)
    charge, dip_x, dip_y = _gather_strengths(perm, charge, dipole)
    clock("sort")

    fine = np.zeros((cells * cells, order + 1), complex)
    _p2m(sx, sy, charge, dip_x, dip_y, source_start, cells, lattice.cell_size, order, fine)
    clock("p2m")
    multipoles = coarser_multipoles(fine.reshape(cells, cells, 1, order + 1), order)
    clock("m2m")
    local = downward_pass(multipoles, lattice, order)
    clock("downward")

    if same:
        target_perm, target_start, tx, ty = perm, source_start, sx, sy
    else:
        target_perm, target_start, tx, ty = _sort_points(targets, lo_x, lo_y, lattice)
        clock("sort")
    tiny2 = (side * 2.0**-52) ** 2
    flat = np.repeat(np.arange(cells * cells), np.diff(target_start))
    # the engine's locals carry 1/2pi (docs/design.md section 3); these sums do not
    sorted_out = 2 * np.pi * far_field_at(local, lattice, np.stack(np.divmod(flat, cells), axis=1),
                                          np.stack([tx, ty], axis=1))[:, 0]
    _near_field(tx, ty, target_start, sx, sy, charge, dip_x, dip_y, source_start, cells, tiny2, sorted_out)
    clock("evaluate")
    out = np.empty(len(targets))
    out[target_perm] = sorted_out
    clock("sort")
    return out


class _Clock:
    """Adds the seconds since the previous call to ``timings[stage]`` (a no-op without a dict)."""

    def __init__(self, timings: dict[str, float] | None) -> None:
        self.timings, self.last = timings, time.perf_counter()

    def __call__(self, stage: str) -> None:
        if self.timings is not None:
            now = time.perf_counter()
            self.timings[stage] = self.timings.get(stage, 0.0) + now - self.last
            self.last = now
