"""The near field in single precision: float32 layers of a segment and a cell's samples against its block.

A vector register holds twice as many float32 lanes as float64 ones, and the
float32 logarithm and arctangent need shorter polynomials (Cephes ``logf``,
no division; ``atanf`` with one), so a pair costs well under half as much
(measured 3.9 against 10.9 ns a pair on one core of the shared
machine, segments in chains).  The price is precision:
about 1e-7 relative per pair, so only ``grid.near_field_grid(..., precision="single")``
uses it; the float64 kernels stay the default and the
reference.

Precision is kept by working in cell units about the cell's centre: a
sample's offset and the block's end points are formed in float64 and
rounded once, so nothing near 1024 pixels meets float32's 6e-5 pixel
spacing.  In those units the single layer of a segment is
``S = r S_unit + h ln(r) / 2pi`` (``r`` the cell size, ``h`` the length in
pixels); the second term is the same at every sample of the cell, so its
sum over the block is added once, in float64 (``ln_size_terms``).

Like ``fastmath``, every function is inlined and must be compiled with
``fastmath=POLY_MATH, error_model="numpy"`` (no reassociation, no division
checks) so the loops calling them vectorise and the error bounds hold.
Constants are float32 (``F``); a float64 literal would promote the loop.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .blocks import samples_loop
from .fastmath import POLY_MATH

F = np.float32
_ZERO, _HALF, _ONE, _TWO = F(0.0), F(0.5), F(1.0), F(2.0)
#: Smallest squared distance the logarithm sees (a target on an end point).
_TINY = F(1e-30)
_LN2_HI, _LN2_LO = F(0.693359375), F(-2.12194440e-4)
_LOG0, _LOG1, _LOG2 = F(7.0376836292e-2), F(-1.1514610310e-1), F(1.1676998740e-1)
_LOG3, _LOG4, _LOG5 = F(-1.2420140846e-1), F(1.4249322787e-1), F(-1.6668057665e-1)
_LOG6, _LOG7, _LOG8 = F(2.0000714765e-1), F(-2.4999993993e-1), F(3.3333331174e-1)
_ATAN0, _ATAN1 = F(8.05374449538e-2), F(-1.38776856032e-1)
_ATAN2, _ATAN3 = F(1.99777106478e-1), F(-3.33329491539e-1)
_TAN_PI_8 = F(math.tan(math.pi / 8))
_PI_4, _PI_2, _PI = F(math.pi / 4), F(math.pi / 2), F(math.pi)
_INV_TWO_PI, _INV_FOUR_PI = F(1 / (2 * math.pi)), F(1 / (4 * math.pi))


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def log_single(x):
    """``log(x)`` for finite normal float32 ``x > 0`` (Cephes ``logf``: within 1 ulp, no division)."""
    bits = np.float32(x).view(np.int32) + np.int32(0x3F800000 - 0x3F3504F3)
    exponent = F((bits >> np.int32(23)) - np.int32(127))
    m = np.int32((bits & np.int32(0x007FFFFF)) + np.int32(0x3F3504F3)).view(np.float32)  # [sqrt(1/2), sqrt(2))
    f = m - _ONE
    z = f * f
    p = ((((((((_LOG0 * f + _LOG1) * f + _LOG2) * f + _LOG3) * f + _LOG4) * f + _LOG5) * f + _LOG6) * f
          + _LOG7) * f + _LOG8)
    y = f * z * p + exponent * _LN2_LO - _HALF * z
    return f + y + exponent * _LN2_HI


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def atan2_single(y, x):
    """``atan2(y, x)`` in float32 (Cephes ``atanf`` on ``min/max`` of ``|x|, |y|``: within 3 ulp).

    NaN when ``x == y == 0``; ``subtended_angle_single`` never passes that.
    """
    ax, ay = abs(x), abs(y)
    lo, hi = min(ax, ay), max(ax, ay)
    big = lo > _TAN_PI_8 * hi
    t = (lo - hi if big else lo) / (lo + hi if big else hi)  # one division, selected operands
    z = t * t
    r = (((_ATAN0 * z + _ATAN1) * z + _ATAN2) * z + _ATAN3) * z * t + t
    if big:
        r = r + _PI_4
    if ay > ax:
        r = _PI_2 - r
    if x < _ZERO:
        r = _PI - r
    if y < _ZERO:
        r = -r
    return r


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def subtended_angle_single(v0x, v0y, v1x, v1y):
    """``fastmath.subtended_angle`` in float32."""
    cross = v0x * v1y - v0y * v1x
    dot = v0x * v1x + v0y * v1y
    subtends = cross != _ZERO or dot > _ZERO
    return atan2_single(cross if subtends else _ZERO, dot if subtends else _ONE)


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def log_r2_single(x, y, px, py):
    """``log |p - x|^2`` in float32, guarded at ``_TINY``."""
    vx, vy = px - x, py - y
    return log_single(max(vx * vx + vy * vy, _TINY))


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def potentials_single(x, y, px, py, qx, qy, tx, ty, h, log_p):
    """``fastmath.potentials_from`` in float32: ``(S, D, log|q - x|^2)`` given ``log|p - x|^2``."""
    v0x, v0y = px - x, py - y
    v1x, v1y = qx - x, qy - y
    a = -(v0x * tx + v0y * ty)
    b_abs = abs(v0x * ty - v0y * tx)
    angle = subtended_angle_single(v0x, v0y, v1x, v1y)
    log_q = log_single(max(v1x * v1x + v1y * v1y, _TINY))
    single = ((h - a) * log_q + a * log_p - _TWO * h + _TWO * b_abs * abs(angle)) * _INV_FOUR_PI
    return single, angle * _INV_TWO_PI, log_q


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def gather_single(m, seg, xc, yc, inv_size, size, block):
    """The ``m`` gathered segments of ``seg (13, m)`` (``blocks``' layout, pixels) in cell units about
    ``(xc, yc)``, in float32 ``block (13, m)``: E scaled by the cell size (``S = r S_unit + ...``).

    Returns the float64 ``sum E h ln(r) / 2pi`` of each channel (``ln_size_terms``).
    """
    log_size = math.log(size) / (2.0 * math.pi)
    t0 = t1 = t2 = 0.0
    for k in range(m):
        block[0, k], block[1, k] = F((seg[0, k] - xc) * inv_size), F((seg[1, k] - yc) * inv_size)
        block[2, k], block[3, k] = F((seg[2, k] - xc) * inv_size), F((seg[3, k] - yc) * inv_size)
        block[4, k], block[5, k], block[6, k] = F(seg[4, k]), F(seg[5, k]), F(seg[6, k] * inv_size)
        for c in range(3):
            block[7 + c, k] = F(seg[7 + c, k] * size)
            block[10 + c, k] = F(seg[10 + c, k])
        h = seg[6, k] * log_size
        t0 += seg[7, k] * h
        t1 += seg[8, k] * h
        t2 += seg[9, k] * h
    return t0, t1, t2


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def double_layer_single(x, y, px, py, qx, qy):
    """``fastmath.double_layer`` in float32."""
    return subtended_angle_single(px - x, py - y, qx - x, qy - y) * _INV_TWO_PI


#: ``blocks.by_samples`` in float32: ``acc (3, count)`` from ``block (13, m)`` at ``sx, sy`` (all in cell units,
#: float32; ``acc`` lacks the ``ln_size_terms``).
by_samples_single = samples_loop(potentials_single, double_layer_single, log_r2_single)
