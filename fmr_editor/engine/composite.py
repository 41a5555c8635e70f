"""Composition on the cell polynomials: colour transforms and mask blends (paper appendix E, DESIGN section 6).

A layer's far field in a cell is a polynomial ``V = sum c_ij xi^i eta^j``
(``Representation.polynomials``), and so is a mask's field ``M``.  Since a
layer is linear in its colours, an affine colour transform ``T(v) = A v + b``
applies exactly to the coefficients (``transformed``).  Blending a layer over
what lies below it, ``M V_top + (1 - M) V_below = V_below + M (V_top -
V_below)``, is a product of polynomials; kept to the tensor's degree per axis
(``blended``), it is the paper's merged coefficient set (its equation 32), as
accurate as each factor where their product's dropped terms are small.  Near
segments and where ``M`` leaves [0, 1] inside a cell, the per-pixel terms
take over (not here).  ``truncated_product_reference`` is the plain loop.
"""

from __future__ import annotations

import numpy as np

from ..model.color_transform import ColorTransform


def transformed(poly: np.ndarray, transform: ColorTransform) -> np.ndarray:
    """Cell polynomials ``(..., 3, P + 1, P + 1)`` of ``T(V)``: ``A`` on every coefficient, ``b`` on the constant."""
    out = np.einsum("kc,...cij->...kij", transform.matrix, poly)
    out[..., :, 0, 0] += transform.offset
    return out


def truncated_product(mask: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """``mask * poly`` per cell, terms ``xi^i eta^j`` with ``i, j <= P`` kept.

    Parameters
    ----------
    mask : numpy.ndarray
        ``(..., P + 1, P + 1)`` one scalar polynomial per cell.
    poly : numpy.ndarray
        ``(..., C, P + 1, P + 1)`` ``C`` channels per cell.
    """
    size = poly.shape[-1]
    out = np.zeros(np.broadcast_shapes(mask.shape[:-2] + (1, size, size), poly.shape))
    for i in range(size):
        for j in range(size):
            weight = mask[..., None, i, j, None, None]
            if np.any(weight):
                out[..., i:, j:] += weight * poly[..., : size - i, : size - j]
    return out


def blended(mask: np.ndarray, top: np.ndarray, below: np.ndarray) -> np.ndarray:
    """``M top + (1 - M) below`` per cell (``truncated_product``); shapes as ``truncated_product``'s."""
    return below + truncated_product(mask, top - below)


def truncated_product_reference(mask: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """``truncated_product`` by a plain loop over every pair of terms (for tests)."""
    size = poly.shape[-1]
    out = np.zeros(np.broadcast_shapes(mask.shape[:-2] + (1, size, size), poly.shape))
    for i in range(size):
        for j in range(size):
            for k in range(size - i):
                for m in range(size - j):
                    out[..., i + k, j + m] += mask[..., None, i, j] * poly[..., k, m]
    return out
