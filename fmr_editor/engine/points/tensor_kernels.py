"""Compiled kernels of the diffusion-point build (``tensor``): Hermite columns and blocked products."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..kernels.fastmath import FAST_MATH

#: Points of one source block handled together (bounds the per-thread buffers).
CHUNK = 128
#: Below this many points a chunk is added point by point (measured: 8 beat 2, 16 and 32).
FEW = 8


@numba.njit(cache=True, fastmath=FAST_MATH, inline="always")
def hermite_column(s, rho, inv, u, column):
    """``u[n, column] = h_n(s) rho^n / n!`` (``gauss.scaled_hermite``)."""
    order = inv.shape[0] - 1
    a, b = 2.0 * s * rho, 2.0 * rho * rho
    u0 = math.exp(-s * s)
    u[0, column] = u0
    if order >= 1:
        u1 = a * u0
        u[1, column] = u1
        for n in range(1, order):
            u0, u1 = u1, (a * u1 - b * u0) * inv[n + 1]
            u[n + 1, column] = u1


@numba.njit(cache=True, fastmath=FAST_MATH)
def _product_add(ax, by, count, cell):
    """``cell[ci, j] += sum_(k < count) ax[ci, k] by[j, k]``, in 3 x 3 blocks of ``(ci, j)``.

    Nine running sums share each load (6 loads a 9 multiply-adds); measured
    7-15 G multiply-adds/s a core here against 5-12 for blocks of 3 x 1.
    """
    width = by.shape[0]
    for ci in range(0, ax.shape[0], 3):
        j = 0
        while j + 3 <= width:
            s00 = s01 = s02 = s10 = s11 = s12 = s20 = s21 = s22 = 0.0
            for k in range(count):
                b0, b1, b2 = by[j, k], by[j + 1, k], by[j + 2, k]
                a0, a1, a2 = ax[ci, k], ax[ci + 1, k], ax[ci + 2, k]
                s00 += a0 * b0
                s01 += a0 * b1
                s02 += a0 * b2
                s10 += a1 * b0
                s11 += a1 * b1
                s12 += a1 * b2
                s20 += a2 * b0
                s21 += a2 * b1
                s22 += a2 * b2
            cell[ci, j] += s00
            cell[ci, j + 1] += s01
            cell[ci, j + 2] += s02
            cell[ci + 1, j] += s10
            cell[ci + 1, j + 1] += s11
            cell[ci + 1, j + 2] += s12
            cell[ci + 2, j] += s20
            cell[ci + 2, j + 1] += s21
            cell[ci + 2, j + 2] += s22
            j += 3
        for j in range(j, width):
            s0 = s1 = s2 = 0.0
            for k in range(count):
                b = by[j, k]
                s0 += ax[ci, k] * b
                s1 += ax[ci + 1, k] * b
                s2 += ax[ci + 2, k] * b
            cell[ci, j] += s0
            cell[ci + 1, j] += s1
            cell[ci + 2, j] += s2


@numba.njit(cache=True, fastmath=FAST_MATH)
def _scatter_chunk(k0, k1, x, y, r, w, col0, col1, row0, row1, size, inv, ax, by, out):
    """Add points ``k0:k1`` (one source block, largest reach first) to their grid cells.

    ``ax[col]`` holds ``w (x) ux`` and ``by[row]`` holds ``uy`` for the chunk's
    points (zero where a point does not reach), so a target cell gets one
    blocked product over the points up to the last one reaching it.
    """
    width = inv.shape[0]
    count = k1 - k0
    xa, xb, ya, yb = col0[k0], col1[k0], row0[k0], row1[k0]
    for p in range(k0 + 1, k1):
        xa, xb = min(xa, col0[p]), max(xb, col1[p])
        ya, yb = min(ya, row0[p]), max(yb, row1[p])
    ax[: xb - xa + 1, :, :count] = 0.0
    by[: yb - ya + 1, :, :count] = 0.0
    for k in range(count):
        p = k0 + k
        rho = size / r[p]
        for col in range(col0[p], col1[p] + 1):
            slot = ax[col - xa]
            hermite_column((x[p] - (col + 0.5) * size) / r[p], rho, inv, slot, k)
            for i in range(width):
                u = slot[i, k]
                slot[i, k] = u * w[p, 0]
                slot[width + i, k] = u * w[p, 1]
                slot[2 * width + i, k] = u * w[p, 2]
        for row in range(row0[p], row1[p] + 1):
            hermite_column((y[p] - (row + 0.5) * size) / r[p], rho, inv, by[row - ya], k)
    if count < FEW:
        # too few points for the blocked product: one rank-one update per point and cell
        for k in range(count):
            p = k0 + k
            for row in range(row0[p], row1[p] + 1):
                uy = by[row - ya]
                for col in range(col0[p], col1[p] + 1):
                    slot, cell = ax[col - xa], out[row, col]
                    for ci in range(3 * width):
                        a = slot[ci, k]
                        for j in range(width):
                            cell[ci, j] += a * uy[j, k]
        return
    for row in range(ya, yb + 1):
        for col in range(xa, xb + 1):
            # points past the last one reaching this cell add only zeros
            last = 0
            for k in range(count - 1, -1, -1):
                p = k0 + k
                if col0[p] <= col <= col1[p] and row0[p] <= row <= row1[p]:
                    last = k + 1
                    break
            if last:
                _product_add(ax[col - xa], by[row - ya], last, out[row, col])


@numba.njit(cache=True, fastmath=FAST_MATH)
def _scatter_block(block, x, y, r, w, col0, col1, row0, row1, block_start, size, inv, ax, by, out):
    for k0 in range(block_start[block], block_start[block + 1], CHUNK):
        k1 = min(k0 + CHUNK, block_start[block + 1])
        _scatter_chunk(k0, k1, x, y, r, w, col0, col1, row0, row1, size, inv, ax, by, out)


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH)
def accumulate(out, x, y, r, w, col0, col1, row0, row1, block_start, blocks, size, stripe, span, private):
    """Points sorted by source block into ``out (copies, g, g, 3 (P+1), P+1)``.

    With one copy, threads take stripes of ``stripe`` block rows, first the
    even ones then the odd ones; with ``private`` copies (small grids, few
    stripes), thread ``t`` takes every ``copies``-th block into copy ``t``.
    """
    width = out.shape[-1]
    inv = np.ones(width)
    for k in range(1, width):
        inv[k] = 1.0 / k
    stripes = (blocks + stripe - 1) // stripe
    for phase in range(1 if private else 2):
        tasks = out.shape[0] if private else (stripes - phase + 1) // 2
        for t in numba.prange(tasks):
            ax = np.empty((span, 3 * width, CHUNK))
            by = np.empty((span, width, CHUNK))
            if private:
                for block in range(t, blocks * blocks, tasks):
                    _scatter_block(block, x, y, r, w, col0, col1, row0, row1, block_start, size, inv, ax, by, out[t])
            else:
                s = 2 * t + phase
                for block in range(s * stripe * blocks, min((s + 1) * stripe, blocks) * blocks):
                    _scatter_block(block, x, y, r, w, col0, col1, row0, row1, block_start, size, inv, ax, by, out[0])
