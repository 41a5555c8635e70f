"""Closed-form single- and double-layer integrals of straight segments.

For a segment from p to q (length h, unit tangent t, left normal n) and a
target x, with a = (x - p).t and b = (x - p).n (docs/design.md section 2)::

    S(x) = (1/2pi) integral ln|x - y| ds = (F(h - a, b) - F(-a, b)) / 2pi
    D(x) = (1/2pi) integral (y - x).n / |x - y|^2 ds = angle(p - x, q - x) / 2pi

with F(w, b) = (w ln(w^2 + b^2) - 2w + 2|b| atan2(w, |b|)) / 2 and the
signed angle from p - x to q - x; D = -1/2 just left of the segment and +1/2
just right of it.  ``pair_integrals`` is the plain numpy reference; the
compiled kernels in ``segment_sums`` must agree with it.
"""

from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi


def _antiderivative(w: np.ndarray, b_abs: np.ndarray) -> np.ndarray:
    r2 = np.maximum(w * w + b_abs * b_abs, 1e-300)
    return 0.5 * (w * np.log(r2) - 2.0 * w + 2.0 * b_abs * np.arctan2(w, b_abs))


def pair_integrals(targets: np.ndarray, p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Single layer ``S`` and double layer ``D`` for every target and segment.

    Parameters
    ----------
    targets : numpy.ndarray
        ``(m, 2)`` points.
    p, q : numpy.ndarray
        ``(n, 2)`` segment end points.

    Returns
    -------
    S, D : numpy.ndarray
        ``(m, n)`` each.  A target on a segment gets ``D = 0`` (the principal
        value, the mean of both sides).
    """
    d = q - p
    h = np.hypot(d[:, 0], d[:, 1])
    t = d / h[:, None]
    v0 = p[None, :, :] - targets[:, None, :]
    v1 = q[None, :, :] - targets[:, None, :]
    a = -(v0[..., 0] * t[:, 0] + v0[..., 1] * t[:, 1])
    # n = (t_y, -t_x): b = (x - p).n
    b = -(v0[..., 0] * t[:, 1] - v0[..., 1] * t[:, 0])
    b_abs = np.abs(b)
    single = (_antiderivative(h - a, b_abs) - _antiderivative(-a, b_abs)) / TWO_PI
    cross = v0[..., 0] * v1[..., 1] - v0[..., 1] * v1[..., 0]
    dot = v0[..., 0] * v1[..., 0] + v0[..., 1] * v1[..., 1]
    double = np.arctan2(cross, dot) / TWO_PI
    double[(cross == 0) & (dot <= 0)] = 0.0
    return single, double


def direct_sum_reference(
    targets: np.ndarray, p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray, chunk: int = 2048
) -> np.ndarray:
    """``u(x) = sum_j E_j S_j(x) - C_j D_j(x)`` by plain numpy, ``(m, 3)``."""
    out = np.empty((len(targets), flux.shape[1]))
    for start in range(0, len(targets), chunk):
        single, double = pair_integrals(targets[start : start + chunk], p, q)
        out[start : start + chunk] = single @ flux - double @ jump
    return out
