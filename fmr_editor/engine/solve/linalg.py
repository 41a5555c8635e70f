"""Randomised and small dense linear algebra for the skeleton factorisation.

Sparse sign sketches (``SparseSign``), the column interpolative
decomposition (``interpolative``) and LAPACK routines called directly
(``pivoted_qr``, ``inverse``): general tools, independent of the
collocation system they serve.
"""

from __future__ import annotations

from collections.abc import Callable

import numba
import numpy as np
from scipy.linalg import lapack

from ..kernels.fastmath import FAST_MATH

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

def checked(info: int, routine: str) -> None:
    if info > 0:
        raise np.linalg.LinAlgError(f"{routine}: singular matrix")
    if info < 0:
        raise ValueError(f"{routine}: illegal argument {-info}")


def pivoted_qr(matrix: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray, int]:
    """R factor (upper triangle), column order and numerical rank (pivots above ``tolerance`` times the
    largest, at least 1); ``matrix`` is overwritten when it is in Fortran order."""
    columns = matrix.shape[1]
    r_factor, order, _, _, info = lapack.dgeqp3(matrix, lwork=2 * columns + 64 * (columns + 1),
                                                             overwrite_a=True)
    checked(info, "dgeqp3")
    pivots = np.abs(np.diag(r_factor))
    rank = int(np.count_nonzero(pivots > tolerance * pivots[0])) if len(pivots) and pivots[0] > 0 else 0
    return r_factor, order - 1, max(rank, 1)


def dense_inverse(matrix: np.ndarray) -> np.ndarray:
    """``matrix^-1`` (overwriting ``matrix`` when it is in Fortran order)."""
    lu, pivots, info = lapack.dgetrf(matrix, overwrite_a=True)
    checked(info, "dgetrf")
    inverse, info = lapack.dgetri(lu, pivots, lwork=64 * max(1, len(matrix)), overwrite_lu=True)
    checked(info, "dgetri")
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
    r_factor, order, rank = pivoted_qr(matrix, tolerance)
    T = np.zeros((rank, 0))
    if rank < columns:
        T, info = lapack.dtrtrs(r_factor[:rank, :rank], r_factor[:rank, rank:])
        checked(info, "dtrtrs")
    return order[:rank], order[rank:], T
