"""Multipole and local expansions of the complex potential (docs/design.md section 3).

The colour is u = Re Phi with::

    Phi(z) = (1/2pi) sum over segments of integral [E ln(z - z0) + C n0 / (z - z0)] ds

Expansions are *scaled* by their cell size r so that every translation is a
fixed matrix for its relative offset, the same at every level:

- multipole about zc: Phi = (1/2pi) [A_0 ln(z - zc) + sum_k A_k ((z - zc) / r)^-k]
- local about zL:     Phi = (1/2pi) sum_l L_l ((z - zL) / r)^l

Coefficient vectors have ``order + 1`` complex entries, index k = 0..order.
Every function here works on trailing axes ``(..., order + 1)`` so a whole
lattice level is translated by one matrix product.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.special import comb


def multipole_moments_reference(
    p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray, centre: np.ndarray, size: float, order: int
) -> np.ndarray:
    """Scaled multipole moments of each segment about its ``centre`` (P2M).

    Parameters
    ----------
    p, q : numpy.ndarray
        ``(n, 2)`` segment end points.
    flux, jump : numpy.ndarray
        ``(n, 3)`` E and C per segment.
    centre : numpy.ndarray
        ``(n, 2)`` expansion centre of each segment's cell.
    size : float
        Cell size r.
    order : int

    Returns
    -------
    numpy.ndarray
        ``(n, 3, order + 1)`` complex moments; sum them per cell.

    Notes
    -----
    With zeta = (z0 - zc) / r along the segment, the exact integral
    ``int zeta^k ds = r (zeta_q^(k+1) - zeta_p^(k+1)) / ((k+1) t)`` gives
    A_0 = E h and A_k = -(E / k) I_k + (C n0 / r) I_(k-1) for k >= 1.
    """
    zp = ((p[:, 0] - centre[:, 0]) + 1j * (p[:, 1] - centre[:, 1])) / size
    zq = ((q[:, 0] - centre[:, 0]) + 1j * (q[:, 1] - centre[:, 1])) / size
    d = (q[:, 0] - p[:, 0]) + 1j * (q[:, 1] - p[:, 1])
    h = np.abs(d)
    tangent = d / h
    normal = -1j * tangent
    k = np.arange(1, order + 2)
    # integrals[:, k] = int zeta^k ds, k = 0..order
    integrals = size * (zq[:, None] ** k - zp[:, None] ** k) / (k * tangent[:, None])
    moments = np.zeros((len(p), 3, order + 1), complex)
    moments[:, :, 0] = flux * h[:, None]
    kk = np.arange(1, order + 1)
    moments[:, :, 1:] = (
        -flux[:, :, None] / kk * integrals[:, None, 1:]
        + (jump[:, :, None] * (normal / size)[:, None, None]) * integrals[:, None, :-1]
    )
    return moments


@lru_cache(maxsize=None)
def m2m_matrix(offset: complex, order: int) -> np.ndarray:
    """Child multipole (size r) to parent (size 2r); ``offset = (child - parent centre) / 2r``.

    Returns ``T`` with ``parent = child @ T``.
    """
    t = np.zeros((order + 1, order + 1), complex)
    t[0, 0] = 1.0
    for l in range(1, order + 1):
        t[0, l] = -(offset**l) / l
        for k in range(1, l + 1):
            t[k, l] = 0.5**k * offset ** (l - k) * comb(l - 1, k - 1, exact=True)
    t.flags.writeable = False
    return t


@lru_cache(maxsize=None)
def m2l_matrix(offset: complex, order: int, log_size: float) -> np.ndarray:
    """Multipole to local between cells of one size r; ``offset = (source - target centre) / r``.

    ``log_size`` is ln r: the one level-dependent term (``L_0`` gains ``A_0 ln r``).
    Returns ``T`` with ``local = multipole @ T``.
    """
    t = _m2l_at_unit_size(complex(offset), order).copy()
    t[0, 0] += log_size
    t.flags.writeable = False
    return t


@lru_cache(maxsize=None)
def _m2l_at_unit_size(offset: complex, order: int) -> np.ndarray:
    """``m2l_matrix(offset, order, 0.0)``, shared by every level (a build asks for 40 offsets on each)."""
    t = np.zeros((order + 1, order + 1), complex)
    t[0, 0] = np.log(-offset)
    k = np.arange(1, order + 1)
    t[1:, 0] = (-1.0) ** k / offset**k
    t[0, 1:] = -1.0 / (k * offset**k)
    rows, columns = k[:, None], k[None, :]  # t[k, l]
    t[1:, 1:] = offset ** (-columns) * (-1.0) ** rows / offset**rows * comb(columns + rows - 1, rows - 1)
    return t


@lru_cache(maxsize=None)
def l2l_matrix(offset: complex, order: int) -> np.ndarray:
    """Parent local (size R) to child (size R/2); ``offset = (child - parent centre) / R``.

    Returns ``T`` with ``child = parent @ T``.
    """
    t = np.zeros((order + 1, order + 1), complex)
    for l in range(order + 1):
        for k in range(l, order + 1):
            t[k, l] = comb(k, l, exact=True) * offset ** (k - l) * 0.5**l
    t.flags.writeable = False
    return t


def evaluate_multipole(moments: np.ndarray, centre: complex, size: float, z: np.ndarray) -> np.ndarray:
    """u at points ``z`` (complex) from multipole ``moments (3, order + 1)``; ``(len(z), 3)``."""
    w = (z - centre)[:, None]
    k = np.arange(1, moments.shape[-1])
    phi = moments[None, :, 0] * np.log(w) + ((w / size)[:, :, None] ** -k * moments[None, :, 1:]).sum(-1)
    return phi.real / (2 * np.pi)


def evaluate_local(local: np.ndarray, centre: complex, size: float, z: np.ndarray) -> np.ndarray:
    """u at points ``z`` (complex) from local ``local (3, order + 1)``; ``(len(z), 3)``."""
    w = ((z - centre) / size)[:, None, None]
    l = np.arange(local.shape[-1])
    return (local[None] * w**l).sum(-1).real / (2 * np.pi)


@lru_cache(maxsize=None)
def harmonic_to_polynomial(order: int) -> np.ndarray:
    """Map from complex local coefficients to real bivariate monomials.

    Returns ``M`` of shape ``(order + 1, order + 1, order + 1)`` complex with
    ``Re sum_l L_l (xi + i eta)^l = sum_ij c_ij xi^i eta^j`` where
    ``c_ij = Re sum_l L_l M[l, i, j]``: ``M[l, l - j, j] = binom(l, j) i^j``.
    """
    m = np.zeros((order + 1,) * 3, complex)
    for l in range(order + 1):
        for j in range(l + 1):
            m[l, l - j, j] = comb(l, j, exact=True) * 1j**j
    m.flags.writeable = False
    return m


@lru_cache(maxsize=16)
def real_polynomial_map(order: int) -> np.ndarray:
    """``(2 (P + 1), (P + 1)^2)`` real map from ``(Re L, Im L)`` to the tensor coefficients ``c_ij`` of u.

    ``u = (1/2pi) Re sum_l L_l w^l = sum_ij c_ij xi^i eta^j`` with
    ``c = [Re L, Im L] @ map`` (``Re(L M) = Re L Re M - Im L Im M``, as one
    real matrix product; ``harmonic_to_polynomial`` gives M).
    """
    mapping = harmonic_to_polynomial(order).reshape(order + 1, -1)
    real = np.concatenate([mapping.real, -mapping.imag]) / (2 * np.pi)
    real.flags.writeable = False
    return real


def local_polynomials(local: np.ndarray, order: int) -> np.ndarray:
    """Tensor coefficients ``(..., P + 1, P + 1)`` of u from local expansions ``(..., >= P + 1)`` (degree P)."""
    local = local[..., : order + 1]
    coeffs = np.concatenate([local.real, local.imag], axis=-1) @ real_polynomial_map(order)
    return coeffs.reshape(local.shape[:-1] + (order + 1, order + 1))
