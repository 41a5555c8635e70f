"""Boundary-element solve for the normal-derivative jumps (docs/design.md section 2).

Collocation at segment midpoints x_i.  On a curve segment the mean of both
sides is known::

    mean_i = sum_j [ E_j S_ij - C_j D_ij ]            (unknowns: E_j)

On the canvas border E = 0 and the colour C just inside is unknown; the
outside is 0, so the mean of both sides is C_i / 2::

    C_i / 2 = sum_j [ E_j S_ij - C_j D_ij ]

Curves and border are solved together; the three colour channels share one
matrix.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable

import numpy as np
import scipy.linalg

from ..geometry.segments import Segments
from ..kernels.potentials import pair_integrals
from ..kernels.segment_sums import collocation_system

#: Share of the available memory a solve may keep.
MEMORY_SHARE = 0.8


class SolveTooLargeError(MemoryError):
    """The boundary system is too large for the dense solve on this machine."""


class SingularSystemError(ValueError):
    """The boundary system is singular: curves coincide (or nearly), and no solver here can share them out."""


def available_memory() -> int:
    """Bytes of memory available to this process now (``MemAvailable``), or total physical memory."""
    try:
        with open("/proc/meminfo") as info:
            for line in info:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def check_dense_fits(count: int) -> None:
    """Raise ``SolveTooLargeError`` before allocating when ``count`` unknowns cannot be solved densely."""
    need = 8 * count * count
    available = available_memory()
    if need > MEMORY_SHARE * available:
        raise SolveTooLargeError(
            f"{count:,} boundary segments need a {need / 1e9:.1f} GB dense system "
            f"({available / 1e9:.1f} GB available)"
        )


def assemble_reference(segments: Segments, chunk: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Dense collocation matrix ``(n, n)`` and right-hand sides ``(n, 3)``.

    Unknown j is ``E_j`` on a curve segment and ``C_j`` on a border segment.
    Plain numpy; ``assemble`` is the compiled twin.
    """
    n = len(segments)
    border = segments.on_border
    curve_jump = np.where(border[:, None], 0.0, segments.jump)
    mids = segments.midpoints
    matrix = np.empty((n, n))
    rhs = np.where(border[:, None], 0.0, segments.mean)
    for start in range(0, n, chunk):
        rows = slice(start, min(start + chunk, n))
        single, double = pair_integrals(mids[rows], segments.p, segments.q)
        local = np.arange(rows.stop - start)
        double[local, start + local] = 0.0  # principal value on the segment itself
        matrix[rows] = np.where(border[None, :], -double, single)
        rhs[rows] += double @ curve_jump
    matrix[np.flatnonzero(border), np.flatnonzero(border)] -= 0.5
    return matrix, rhs


def assemble(segments: Segments) -> tuple[np.ndarray, np.ndarray]:
    """Dense collocation matrix ``(n, n)`` and right-hand sides ``(n, 3)`` (compiled)."""
    return collocation_system(segments.p, segments.q, segments.on_border, segments.jump, segments.mean)


def trivial(segments: Segments) -> bool:
    """True when ``segments`` hold no curve: the reflecting canvas alone holds black, and its system is singular."""
    return not np.any(~segments.on_border)


def dense_factors(matrix: np.ndarray,
                  again: Callable[[], np.ndarray]) -> tuple[Callable[[np.ndarray], np.ndarray], bool]:
    """A solver for ``matrix``: its LU factors, or least squares where it is nearly singular (then True).

    Where curves nearly coincide the system is nearly singular; the
    least-squares solution (rank-revealing QR) then shares the density of
    coinciding segments between them instead of blowing it up.  The LU
    overwrites ``matrix`` (one n x n array at a time), so that rare path
    asks ``again()`` for it.
    """
    norm = float(np.abs(matrix).sum(axis=0).max(initial=0.0))
    with warnings.catch_warnings():  # an exactly singular matrix is what the condition below reports
        warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
        lu, pivots = scipy.linalg.lu_factor(matrix, overwrite_a=True, check_finite=False)
    condition, _ = scipy.linalg.lapack.dgecon(lu, norm, norm="1")
    if condition >= np.finfo(float).eps:
        return (lambda rhs: scipy.linalg.lu_solve((lu, pivots), rhs, check_finite=False)), False
    lu = None  # free the factors before the matrix is made again
    matrix = again()
    return (lambda rhs: scipy.linalg.lstsq(matrix, rhs, cond=1e-12, lapack_driver="gelsy",
                                           check_finite=False)[0]), True


def solve_dense(segments: Segments) -> Segments:
    """Segments with ``flux`` (curves) and ``jump`` (border) solved.

    Raises
    ------
    SolveTooLargeError
        Before allocating anything, when the system does not fit (``check_dense_fits``).
    """
    check_dense_fits(len(segments))
    if trivial(segments):
        return segments
    matrix, rhs = assemble(segments)
    solve, _ = dense_factors(matrix, lambda: assemble(segments)[0])
    return segments.with_unknowns(solve(rhs))
