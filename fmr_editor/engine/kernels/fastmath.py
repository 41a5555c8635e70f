"""Vectorisable scalar math shared by the compiled kernels: ``log``, ``atan2`` and one segment's layers.

``math.log`` and ``math.atan2`` compile to scalar libm calls, which keep LLVM
from vectorising a loop (numba has no SVML here).  ``log_poly`` and
``atan2_poly`` are the classic fdlibm logarithm and Cephes arctangent in
plain arithmetic, so a loop calling them vectorises; measured against libm
they are within 1 ulp (log) and 2 ulp (atan2), the same rounding envelope as
numpy's own (``potentials.pair_integrals``).

Two compile options decide whether those bounds hold and whether the loop
vectorises.  Everything here is ``inline="always"``, and numba compiles
inlined code with the *caller's* options, so they are really requirements on
the kernels that call these functions:

- ``fastmath=POLY_MATH``: no reassociation (the compensated sums of the
  polynomials rely on their order; with ``reassoc`` the logarithm's error grows
  to 2 ulp) and no reciprocal approximation.
- ``error_model="numpy"``: under numba's default ``"python"`` model every
  division checks its divisor for zero to raise ``ZeroDivisionError``, and that
  branch alone stops the loop vectorising.  (The functions never divide by
  zero on the inputs the kernels give them, so they are also safe, only
  slower, in a ``"python"``-model caller.)
"""

from __future__ import annotations

import math

import numba
import numpy as np

TWO_PI = 2.0 * math.pi
INV_TWO_PI = 1.0 / TWO_PI
INV_FOUR_PI = 0.5 / TWO_PI

#: Fast-math flags for loops calling the functions below: contraction only (no reassociation).
POLY_MATH = {"nsz", "contract"}
#: Fast-math flags for every other compiled loop: without "no NaNs / no infinities", so guards keep
#: working; with reassociation, so reductions vectorise.  Not for code calling the polynomials below.
FAST_MATH = {"nsz", "arcp", "contract", "afn", "reassoc"}

_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_LG1 = 6.666666666666735130e-01
_LG2 = 3.999999999940941908e-01
_LG3 = 2.857142874366239149e-01
_LG4 = 2.222219843214978396e-01
_LG5 = 1.818357216161805012e-01
_LG6 = 1.531383769920937332e-01
_LG7 = 1.479819860511658591e-01


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def log_poly(x):
    """``log(x)`` for finite normal ``x > 0`` without a libm call (fdlibm ``__ieee754_log``).

    ``x = 2^k m`` with ``m`` in ``[sqrt(2)/2, sqrt(2))``; ``log m`` from
    ``s = f / (2 + f)``, ``f = m - 1``, and a degree-14 odd polynomial.
    """
    bits = np.float64(x).view(np.int64) + (0x3FF0000000000000 - 0x3FE6A09E00000000)
    k = (bits >> 52) - 0x3FF
    m = np.int64((bits & 0x000FFFFFFFFFFFFF) + 0x3FE6A09E00000000).view(np.float64)
    f = m - 1.0
    half_f2 = 0.5 * f * f
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    even = w * (_LG2 + w * (_LG4 + w * _LG6))
    odd = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    dk = np.float64(k)
    return s * (half_f2 + odd + even) + dk * _LN2_LO - half_f2 + f + dk * _LN2_HI


_ATAN_P0 = -8.750608600031904122785e-1
_ATAN_P1 = -1.615753718733365076637e1
_ATAN_P2 = -7.500855792314704667340e1
_ATAN_P3 = -1.228866684490136173410e2
_ATAN_P4 = -6.485021904942025371773e1
_ATAN_Q0 = 2.485846490142306297962e1
_ATAN_Q1 = 1.650270098316988542046e2
_ATAN_Q2 = 4.328810604912902668951e2
_ATAN_Q3 = 4.853903996359136964868e2
_ATAN_Q4 = 1.945506571482613964425e2
#: pi/2 minus its double (the low part Cephes adds back).
_PI_2_LO = 6.123233995736765886130e-17


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def atan2_poly(y, x):
    """``atan2(y, x)`` without a libm call (Cephes ``atan`` on ``min/max`` of ``|x|, |y|``).

    NaN when ``x == y == 0``; ``potentials_from`` never passes that.
    """
    ax, ay = abs(x), abs(y)
    lo, hi = min(ax, ay), max(ax, ay)
    big = lo > 0.66 * hi
    t = (lo - hi if big else lo) / (lo + hi if big else hi)  # one division, selected operands
    z = t * t
    num = (((_ATAN_P0 * z + _ATAN_P1) * z + _ATAN_P2) * z + _ATAN_P3) * z + _ATAN_P4
    den = ((((z + _ATAN_Q0) * z + _ATAN_Q1) * z + _ATAN_Q2) * z + _ATAN_Q3) * z + _ATAN_Q4
    r = t + t * (z * num / den)
    if big:
        r = 0.25 * math.pi + (r + 0.5 * _PI_2_LO)
    if ay > ax:
        r = (0.5 * math.pi - r) + _PI_2_LO
    if x < 0.0:
        r = (math.pi - r) + 2.0 * _PI_2_LO
    if y < 0.0:
        r = -r
    return r


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def log_r2(x, y, px, py):
    """``log |p - x|^2``, guarded at 1e-300 (a target on an end point)."""
    vx, vy = px - x, py - y
    return log_poly(max(vx * vx + vy * vy, 1e-300))


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def subtended_angle(v0x, v0y, v1x, v1y):
    """The signed angle from ``v0`` to ``v1`` (end points minus target), 0 where they are collinear and not apart.

    ``atan2(cross, dot)``, taken as 0 where the cross product is 0 and the dot
    product not positive (at an end point, and inside the segment when the
    rounded cross product is exactly 0); never ``atan2(0, 0)``.  Branch-free.
    """
    cross = v0x * v1y - v0y * v1x
    dot = v0x * v1x + v0y * v1y
    subtends = cross != 0.0 or dot > 0.0
    return atan2_poly(cross if subtends else 0.0, dot if subtends else 1.0)


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def potentials_from(x, y, px, py, qx, qy, tx, ty, h, log_p):
    """Single and double layer of one segment at (x, y) given ``log|p - x|^2``; also ``log|q - x|^2``.

    The closed form of ``potentials.pair_integrals`` (docs/design.md section 2).  The two
    arctangents of the single layer differ by the angle the segment subtends,
    which the double layer computes anyway, so one ``atan2`` and two
    logarithms serve both.  Guards: the logarithms' arguments are at least
    1e-300 (a target on an end point), and the angle is ``subtended_angle``'s
    (a target on the segment gets one side's +-1/2 unless the rounded cross
    product is 0, and callers wanting the principal value there select it
    themselves).  Branch-free, so a loop over targets or segments vectorises.
    Consecutive segments of a curve share an end point, so a caller may pass
    one segment's ``log_q`` on as the next one's ``log_p``.
    """
    v0x, v0y = px - x, py - y
    v1x, v1y = qx - x, qy - y
    a = -(v0x * tx + v0y * ty)
    b_abs = abs(v0x * ty - v0y * tx)
    angle = subtended_angle(v0x, v0y, v1x, v1y)
    log_q = log_poly(max(v1x * v1x + v1y * v1y, 1e-300))
    single = ((h - a) * log_q + a * log_p - 2.0 * h + 2.0 * b_abs * abs(angle)) * INV_FOUR_PI
    return single, angle * INV_TWO_PI, log_q


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def double_layer(x, y, px, py, qx, qy):
    """The double layer alone of one segment at (x, y): ``potentials_from``'s second value, without logarithms."""
    return subtended_angle(px - x, py - y, qx - x, qy - y) * INV_TWO_PI
