"""The fine cells' local expansions evaluated at scattered points (the collocation products, clones' seams).

``far_field_at_reference`` is the plain numpy Horner sum; ``far_field_at``
its compiled twin.
"""

from __future__ import annotations

import numba
import numpy as np

from .lattice import Lattice


def far_field_at_reference(local: np.ndarray, lattice: Lattice, cells: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The fine-level local expansions, all terms, at ``points`` in ``cells``; ``(m, 3)`` (numpy reference)."""
    w = (points / lattice.cell_size - (cells[:, ::-1] + 0.5)) @ np.array([1.0, 1.0j])
    coeffs = local[cells[:, 0], cells[:, 1]]  # (m, 3, P + 1)
    value = coeffs[:, :, -1]
    for term in range(coeffs.shape[-1] - 2, -1, -1):
        value = value * w[:, None] + coeffs[:, :, term]
    return value.real / (2 * np.pi)


@numba.njit(parallel=True, cache=True)
def _far_field(local, rows, cells, points, cell_size, out):
    for i in numba.prange(points.shape[0]):
        row, col = cells[i, 0], cells[i, 1]
        w = complex(points[i, 0] / cell_size - (col + 0.5), points[i, 1] / cell_size - (row + 0.5))
        for channel in range(local.shape[1]):
            coeffs = local[rows[i], channel]
            value = coeffs[-1]
            for term in range(coeffs.shape[0] - 2, -1, -1):
                value = value * w + coeffs[term]
            out[i, channel] = value.real / (2 * np.pi)


def far_field_at(local: np.ndarray, lattice: Lattice, cells: np.ndarray, points: np.ndarray,
                 rows: np.ndarray | None = None) -> np.ndarray:
    """Compiled twin of ``far_field_at_reference``.

    With ``rows``, ``local`` holds some cells' expansions only, ``(k, 3, P + 1)``: point ``i``'s at ``rows[i]``.
    """
    if rows is None:
        n = lattice.cells_per_side
        local, rows = local.reshape(n * n, *local.shape[2:]), cells[:, 0] * n + cells[:, 1]
    out = np.empty((len(points), local.shape[1]))
    _far_field(local, np.asarray(rows, np.int64), np.ascontiguousarray(cells), np.ascontiguousarray(points, np.float64),
               float(lattice.cell_size), out)
    return out
