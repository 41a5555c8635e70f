"""Fast multipole boundary-element solve: GMRES whose product is the FMM.

The collocation system of ``bem`` is never formed.  Its product with a
vector of unknowns x (E on curves, C on the border) is the field of those
densities at every segment midpoint: far field through the same upward and
downward passes that build the representation, near field (the 3x3 block)
by exact integrals; border rows subtract x / 2.  The near-field block, a
sparse matrix, factorised once, preconditions GMRES.  The three colour
channels are one stacked vector, so every product is one three-channel FMM
pass.

Status: the products are exact to the FMM's accuracy, but the near-field
preconditioner only tames the high-frequency part of this first-kind (log
kernel) system; GMRES then needs hundreds of iterations on real files
(poivron: 530 to 1e-10).  ``build`` therefore still uses the dense solve;
a stronger preconditioner is the next step.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from .kernels import near_block, near_sum
from .lattice import Lattice, downward_pass, upward_pass
from .segments import Segments


def far_field_at(local: np.ndarray, lattice: Lattice, cells: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The fine-level local expansions, all terms, at ``points`` in ``cells``; ``(m, 3)``."""
    w = (points / lattice.cell_size - (cells[:, ::-1] + 0.5)) @ np.array([1.0, 1.0j])
    coeffs = local[cells[:, 0], cells[:, 1]]  # (m, 3, P + 1)
    value = coeffs[:, :, -1]
    for term in range(coeffs.shape[-1] - 2, -1, -1):
        value = value * w[:, None] + coeffs[:, :, term]
    return value.real / (2 * np.pi)


@dataclass(frozen=True)
class SolveReport:
    """How the iterative solve went."""

    iterations: int
    residual: float


class CollocationOperator:
    """Products with the collocation matrix of sorted ``segments`` by FMM.

    Parameters
    ----------
    segments : Segments
        Sorted by fine cell of ``lattice``.
    cell_start : numpy.ndarray
        CSR offsets of each cell's segments.
    lattice : Lattice
    order : int
        Terms carried through the FMM passes.
    """

    def __init__(self, segments: Segments, cell_start: np.ndarray, lattice: Lattice, order: int) -> None:
        self.segments, self.cell_start, self.lattice, self.order = segments, cell_start, lattice, order
        self.cells = lattice.cell_of(segments.midpoints)
        self.border = segments.on_border[:, None]

    def field(self, flux: np.ndarray, jump: np.ndarray) -> np.ndarray:
        """``sum_j E_j S_ij - C_j D_ij`` at every midpoint (own double layer 0), ``(n, 3)``."""
        seg = replace(self.segments, flux=flux, jump=jump)
        local = downward_pass(upward_pass(seg, self.cell_start, self.lattice, self.order), self.lattice, self.order)
        far = far_field_at(local, self.lattice, self.cells, seg.midpoints)
        lattice = self.lattice
        near = near_sum(
            seg.midpoints, lattice.cells_per_side, lattice.cell_size, self.cell_start, seg.p, seg.q,
            np.ascontiguousarray(flux), np.ascontiguousarray(jump), own=np.arange(len(seg)),
        )
        return far + near

    def apply(self, unknown: np.ndarray) -> np.ndarray:
        """Collocation matrix times ``unknown (n, 3)``."""
        flux = np.where(self.border, 0.0, unknown)
        jump = np.where(self.border, unknown, 0.0)
        return self.field(flux, jump) - np.where(self.border, 0.5 * unknown, 0.0)

    def right_hand_side(self) -> np.ndarray:
        """``mean_i + sum over curves of D_ij C_j``, zero mean on the border rows."""
        curve_jump = np.where(self.border, 0.0, self.segments.jump)
        mean = np.where(self.border, 0.0, self.segments.mean)
        return mean - self.field(np.zeros_like(curve_jump), curve_jump)

    def near_matrix(self) -> scipy.sparse.csr_matrix:
        """The collocation matrix restricted to the 3x3 blocks (the preconditioner)."""
        seg = self.segments
        row_start, columns, values = near_block(
            self.cells, self.lattice.cells_per_side, self.cell_start, seg.p, seg.q, seg.on_border
        )
        return scipy.sparse.csr_matrix((values, columns, row_start), shape=(len(seg), len(seg)))


def solve_fmm(
    segments: Segments,
    cell_start: np.ndarray,
    lattice: Lattice,
    order: int = 20,
    rtol: float = 1e-10,
    initial: np.ndarray | None = None,
    progress: Callable[[float], None] | None = None,
) -> tuple[Segments, SolveReport]:
    """Solve the collocation system iteratively.

    Parameters
    ----------
    segments : Segments
        Sorted by fine cell of ``lattice``.
    cell_start : numpy.ndarray
    lattice : Lattice
    order : int
        Terms carried through the FMM passes of each product.
    rtol : float
        GMRES relative residual tolerance.
    initial : numpy.ndarray, optional
        ``(n, 3)`` starting guess (a previous solution).
    progress : callable, optional
        Called with the fraction of the residual reduction reached (log scale).

    Returns
    -------
    segments : Segments
        With ``flux`` (curves) and ``jump`` (border) solved.
    report : SolveReport
    """
    n = len(segments)
    operator = CollocationOperator(segments, cell_start, lattice, order)
    lu = scipy.sparse.linalg.splu(operator.near_matrix().tocsc())
    rhs = operator.right_hand_side()
    shape = (3 * n, 3 * n)
    matrix = scipy.sparse.linalg.LinearOperator(shape, lambda v: operator.apply(v.reshape(n, 3)).ravel(), dtype=float)
    preconditioner = scipy.sparse.linalg.LinearOperator(shape, lambda v: lu.solve(v.reshape(n, 3)).ravel(), dtype=float)
    target = np.log(rtol)
    iterations = 0

    def step(residual_norm: float) -> None:
        nonlocal iterations
        iterations += 1
        if progress:
            progress(min(1.0, np.log(max(residual_norm, 1e-300)) / target))

    x0 = None if initial is None else initial.ravel()
    unknown, info = scipy.sparse.linalg.gmres(
        matrix, rhs.ravel(), x0=x0, rtol=rtol, atol=0.0, restart=60, maxiter=20,
        M=preconditioner, callback=step, callback_type="pr_norm",
    )
    unknown = unknown.reshape(n, 3)
    residual = float(np.linalg.norm(operator.apply(unknown) - rhs) / max(np.linalg.norm(rhs), 1e-300))
    return segments.with_unknowns(unknown), SolveReport(iterations, residual)
