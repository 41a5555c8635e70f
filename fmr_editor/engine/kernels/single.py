"""The near field in single precision: float32 layers of a segment and a cell's samples against its block.

A vector register holds twice as many float32 lanes as float64 ones, and the
float32 logarithm and arctangent need shorter polynomials (Cephes ``logf``,
no division; ``atanf`` with one), so a pair costs well under half as much
(measured 3.9 against 10.9 ns a pair on one core, segments in chains; the
rasters' near field at 1024^2, 32,768 pieces at level 7, every visit in
float32: 154 -> 76 ms).  ``grid.near_field_grid(..., precision="single")``
(``rasterise``'s default) takes it wherever the bound below keeps a sample's
error within ``SINGLE_BUDGET``; the float64 kernels are the reference.  On
the real files (lady_bug, zephyr, poivron: median |E| 0.002-0.008) some 99%
of the visits qualify; on the Hilbert benchmark, whose synthetic E is
standard normal, all at 2,048 and 8,192 pieces, 75% at 131,072 pieces
level 8 and 11% at 32,768 pieces level 7.

Precision is kept by working in cell units about the cell's centre: a
sample's offset and the block's end points are formed in float64 and
rounded once, so nothing near 1024 pixels meets float32's 6e-5 pixel
spacing.  In those units the single layer of a segment is
``S = r S_unit + h ln(r) / 2pi`` (``r`` the cell size, ``h`` the length in
pixels); the second term is the same at every sample of the cell, so its
sum over the block is added once, in float64 (``gather_single``).

Error bound (``u = 2^-24``; coordinates in cell units below 4 in magnitude,
as in a column of three cells about the middle one's centre, so each is
rounded by at most ``delta = 2u = 1.2e-7``).  For one pair whose sample is
at least ``END_DISTANCE`` from both end points and, inside the segment's
span, not within the flip band ``|cross| < LINE_CROSS`` of its line:

- ``D = theta / 2pi``, ``theta`` the subtended angle.  Moving the sample and
  the end points by ``sqrt 2 delta`` each moves ``theta`` by at most
  ``2 sqrt 2 delta (1/rho_p + 1/rho_q)`` (``rho`` the distances to the end
  points; ``D`` is smooth along the segment's interior on either side), at
  most 4.3e-5 for ``rho >= 1/64``; ``atanf`` adds 3 ulp of ``pi`` and the
  rounded cross and dot products ``4u``: ``|dD| <= 7.2e-6`` (``PAIR_DOUBLE``).
  In the flip band the rounded cross product (error below 4.2e-6 there) may
  take the other side of the segment, a jump of ``C``: such pairs, and those
  nearer an end point than ``END_DISTANCE``, are in doubt (``doubt_single``)
  and their samples are summed again in float64.
- ``4 pi S_unit = (h - a) ln|q - x|^2 + a ln|p - x|^2 - 2h + 2 |b| |theta|``
  with ``|a|, |h - a| <= 3`` and terms summing to at most 36: the moved points
  (gradient of ``S`` at most ``(1/2pi) integral ds / |x - y| <= 4.1`` outside
  the flip band) and the rounding of the terms (``logf`` 1 ulp, ``atanf`` 3)
  give ``|dS_unit| <= 2.5e-6`` (``PAIR_SINGLE``).
- A sample sums ``m`` terms ``r E S_unit - C D`` (``|S_unit| <= 0.5``,
  ``|D| <= 0.5``) in float32: at most ``(m + 1) u / 2`` of each weight more.

So a sample's float32 near field is within
``sum_j r |E_j| (PAIR_SINGLE + (m + 1) u / 2) + |C_j| (PAIR_DOUBLE + (m + 1) u / 2)``
over its block's ``m`` segments (channel by channel; ``error_bounds``) of the
float64 one.  Measured on 2e7 random pairs of that geometry:
``|dS_unit| <= 2.6e-7``, ``|dD| <= 5.8e-8 / rho``; on the Hilbert benchmark
(E standard normal) the images differ by at most 7e-4/255.

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
#: Error bounds of one pair in cell units (module docstring): ``|dS_unit|`` and ``|dD|``.
PAIR_SINGLE, PAIR_DOUBLE = 2.5e-6, 7.2e-6
#: The float32 unit roundoff.
ROUNDING = 2.0**-24
#: A sample nearer than this (cell units) to an end point, or with ``|cross| < LINE_CROSS`` inside a segment's
#: span, is in doubt: its sum is taken again in float64.
END_DISTANCE, LINE_CROSS = 1.0 / 64.0, 1e-5
_END2, _CROSS = F(END_DISTANCE**2), F(LINE_CROSS)
#: The largest bound a sample's float32 near field may have (colour units): a fifth of the 1/255 accuracy promise,
#: which the far field's truncation (at most 0.1/255 measured at the default degree) shares.
SINGLE_BUDGET = 0.2 / 255


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
def gather_single(m, seg, xc, yc, inv_size, size, block, terms, channels):
    """The ``m`` gathered segments of ``seg (7 + 2 channels, m)`` (``blocks``' layout, pixels) in cell units about
    ``(xc, yc)``, in float32 ``block`` of the same rows: E scaled by the cell size (``S = r S_unit + ...``).

    ``terms (channels,)`` = the float64 ``sum E h ln(r) / 2pi`` of each channel.
    """
    log_size = math.log(size) / (2.0 * math.pi)
    terms[:] = 0.0
    for k in range(m):
        block[0, k], block[1, k] = F((seg[0, k] - xc) * inv_size), F((seg[1, k] - yc) * inv_size)
        block[2, k], block[3, k] = F((seg[2, k] - xc) * inv_size), F((seg[3, k] - yc) * inv_size)
        block[4, k], block[5, k], block[6, k] = F(seg[4, k]), F(seg[5, k]), F(seg[6, k] * inv_size)
        h = seg[6, k] * log_size
        for c in range(channels):
            block[7 + c, k] = F(seg[7 + c, k] * size)
            block[7 + channels + c, k] = F(seg[7 + channels + c, k])
            terms[c] += seg[7 + c, k] * h


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def double_layer_single(x, y, px, py, qx, qy):
    """``fastmath.double_layer`` in float32."""
    return subtended_angle_single(px - x, py - y, qx - x, qy - y) * _INV_TWO_PI


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def doubt_single(x, y, px, py, qx, qy):
    """The pair may miss its float32 error bound: the sample is within ``END_DISTANCE`` of an end point or in
    the flip band of the segment's line (inside its span); see the module docstring."""
    v0x, v0y, v1x, v1y = px - x, py - y, qx - x, qy - y
    cross = v0x * v1y - v0y * v1x
    dot = v0x * v1x + v0y * v1y
    near_end = min(v0x * v0x + v0y * v0y, v1x * v1x + v1y * v1y) < _END2
    return near_end or (abs(cross) < _CROSS and dot <= _ZERO)


#: ``blocks.by_samples`` in float32: ``acc (3, count)`` from ``block (7 + 6, m)`` at ``sx, sy`` (all in cell units,
#: float32; ``acc`` lacks ``gather_single``'s terms); samples with a pair in doubt are marked.  ``4``: of four
#: channels.
by_samples_single = samples_loop(potentials_single, double_layer_single, log_r2_single, doubt_single)
by_samples_single4 = samples_loop(potentials_single, double_layer_single, log_r2_single, doubt_single, channels=4)


def _largest_channel(values: np.ndarray) -> np.ndarray:
    """``|values|.max(axis=1)`` of ``(k, channels)`` values, column by column (numpy's reduction over a short axis
    took 13 ms for 188,436)."""
    largest = np.abs(values[:, 0])
    for column in range(1, values.shape[1]):
        np.maximum(largest, np.abs(values[:, column]), out=largest)
    return largest


def error_bounds(cells_per_side: int, cell_size: float, cell_start: np.ndarray, flux: np.ndarray,
                 jump: np.ndarray) -> np.ndarray:
    """``(n, n)``: the bound of the float32 near field's error at any sample of each cell (module docstring).

    Samples in doubt excepted (they are summed in float64).  Per cell, over the
    segments of its 3x3 block: ``sum r |E| (PAIR_SINGLE + (m + 1) u / 2) + |C| (PAIR_DOUBLE + (m + 1) u / 2)``,
    the largest channel of each segment, ``m`` the block's segments.
    """
    n = int(cells_per_side)
    if len(flux) == 0:
        return np.zeros((n, n))
    cell = np.repeat(np.arange(n * n), np.diff(cell_start))
    flux_sum = np.bincount(cell, _largest_channel(flux) * cell_size, n * n)
    jump_sum = np.bincount(cell, _largest_channel(jump), n * n)
    count = np.bincount(cell, minlength=n * n).astype(float)
    totals = []
    for values in (flux_sum, jump_sum, count):
        padded = np.pad(values.reshape(n, n), 1)
        totals.append(sum(padded[1 + dy : 1 + dy + n, 1 + dx : 1 + dx + n] for dy in (-1, 0, 1) for dx in (-1, 0, 1)))
    flux_sum, jump_sum, count = totals
    rounding = 0.5 * (count + 1) * ROUNDING
    return flux_sum * (PAIR_SINGLE + rounding) + jump_sum * (PAIR_DOUBLE + rounding)
