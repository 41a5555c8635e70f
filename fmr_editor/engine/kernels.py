"""Compiled (numba) sums of segment integrals; ``layers`` holds the numpy reference.

The near field is the engine's bottleneck: numpy manages about 10 M
target-segment pairs per second, these loops ten to twenty times that
(DESIGN section 4; ``bench/bench_engine.py`` prints both).
"""

from __future__ import annotations

import math

import numba
import numpy as np

_TWO_PI = 2.0 * math.pi


@numba.njit(cache=True, inline="always")
def _antiderivative(w: float, b_abs: float) -> float:
    r2 = max(w * w + b_abs * b_abs, 1e-300)
    return 0.5 * (w * math.log(r2) - 2.0 * w + 2.0 * b_abs * math.atan2(w, b_abs))


@numba.njit(cache=True, inline="always")
def _layers(x: float, y: float, px: float, py: float, qx: float, qy: float, tx: float, ty: float, h: float):
    """Single and double layer of one segment at (x, y); see ``layers``."""
    v0x, v0y = px - x, py - y
    v1x, v1y = qx - x, qy - y
    a = -(v0x * tx + v0y * ty)
    b_abs = abs(v0x * ty - v0y * tx)
    single = (_antiderivative(h - a, b_abs) - _antiderivative(-a, b_abs)) / _TWO_PI
    cross = v0x * v1y - v0y * v1x
    dot = v0x * v1x + v0y * v1y
    double = 0.0
    if cross != 0.0 or dot > 0.0:
        double = math.atan2(cross, dot) / _TWO_PI
    return single, double


def segment_frames(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents ``(n, 2)`` and lengths ``(n,)`` of segments."""
    d = q - p
    h = np.hypot(d[:, 0], d[:, 1])
    return d / h[:, None], h


@numba.njit(parallel=True, cache=True)
def _direct_sum(targets, p, q, tangent, length, flux, jump, out):
    for i in numba.prange(targets.shape[0]):
        x, y = targets[i, 0], targets[i, 1]
        acc = np.zeros(3)
        for j in range(p.shape[0]):
            s, d = _layers(x, y, p[j, 0], p[j, 1], q[j, 0], q[j, 1], tangent[j, 0], tangent[j, 1], length[j])
            for c in range(3):
                acc[c] += flux[j, c] * s - jump[j, c] * d
        for c in range(3):
            out[i, c] = acc[c]


def direct_sum(targets: np.ndarray, p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray) -> np.ndarray:
    """``sum_j E_j S_j(x) - C_j D_j(x)`` over every segment, ``(m, 3)``.

    Compiled twin of ``layers.direct_sum_reference``.
    """
    tangent, length = segment_frames(p, q)
    out = np.empty((len(targets), 3))
    _direct_sum(np.ascontiguousarray(targets, dtype=np.float64), p, q, tangent, length, flux, jump, out)
    return out


@numba.njit(parallel=True, cache=True)
def _near_sum(targets, cells_per_side, cell_size, cell_start, p, q, tangent, length, flux, jump, out):
    n = cells_per_side
    for i in numba.prange(targets.shape[0]):
        x, y = targets[i, 0], targets[i, 1]
        cx = min(max(int(x / cell_size), 0), n - 1)
        cy = min(max(int(y / cell_size), 0), n - 1)
        acc = np.zeros(3)
        for ny in range(max(cy - 1, 0), min(cy + 2, n)):
            for nx in range(max(cx - 1, 0), min(cx + 2, n)):
                cell = ny * n + nx
                for j in range(cell_start[cell], cell_start[cell + 1]):
                    s, d = _layers(x, y, p[j, 0], p[j, 1], q[j, 0], q[j, 1], tangent[j, 0], tangent[j, 1], length[j])
                    for c in range(3):
                        acc[c] += flux[j, c] * s - jump[j, c] * d
        for c in range(3):
            out[i, c] = acc[c]


def near_sum(
    targets: np.ndarray,
    cells_per_side: int,
    cell_size: float,
    cell_start: np.ndarray,
    p: np.ndarray,
    q: np.ndarray,
    flux: np.ndarray,
    jump: np.ndarray,
) -> np.ndarray:
    """Sum over the segments in the 3x3 cells around each target, ``(m, 3)``.

    Parameters
    ----------
    targets : numpy.ndarray
        ``(m, 2)`` points in document pixels.
    cells_per_side : int
        Fine lattice size ``2^L``.
    cell_size : float
        Fine cell size in pixels.
    cell_start : numpy.ndarray
        ``(cells_per_side**2 + 1,)`` offsets: the segments of cell
        ``row * cells_per_side + column`` are ``cell_start[c]:cell_start[c+1]``.
    p, q, flux, jump : numpy.ndarray
        Segments sorted by cell.
    """
    tangent, length = segment_frames(p, q)
    out = np.empty((len(targets), 3))
    _near_sum(
        np.ascontiguousarray(targets, dtype=np.float64),
        cells_per_side, float(cell_size), cell_start, p, q, tangent, length, flux, jump, out,
    )
    return out
