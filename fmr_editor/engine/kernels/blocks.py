"""Gathered blocks of segments and the loop that sums them at a run of samples, in either precision (compiled).

The grid kernels copy the segments near a group of samples (a cell's 3x3
block, a column of three cells, a sub-cell's near part) into one table of
``GEOMETRY + 2 channels`` rows, so the loop over the samples reads contiguous memory
(``gather_block``), and sum them with the samples innermost, where the loop
vectorises (``samples_loop``).  The loop is written once and made for a
precision from that precision's layer functions: ``by_samples`` here from
``fastmath``'s float64 ones, ``single.by_samples_single`` from the float32
ones.

Like ``fastmath``, everything is inlined and must be compiled with
``fastmath=POLY_MATH, error_model="numpy"`` (the callers' options).
"""

from __future__ import annotations

import numba

from .fastmath import POLY_MATH, double_layer, log_r2, potentials_from

#: Rows of a gathered table: p, q, tangent, length (as ``segment_sums.segment_table``), the channels of E, then of
#: C; the first ``GEOMETRY`` are the segment's geometry.  Three channels (colour) or four (an alpha field with the
#: same segments after them: ``raster``'s carried alpha).
GEOMETRY = 7


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def gather_block(cy, first, last, n, cell_start, table, weights, seg, shares_p, flux_free):
    """Copy the segments of cells ``first <= cx < last`` in rows ``cy - 1`` to ``cy + 1`` into
    ``seg (GEOMETRY + 2 channels, >= m)``; m.

    ``table, weights``: ``segment_sums.near_tables`` of segments sorted by
    cell (``cell_start`` their offsets, ``n`` cells a side).
    ``shares_p[k]``: segment k starts where segment k - 1 ends (its logarithm
    there is known); ``flux_free[k]``: its E is 0 in every channel (the canvas
    border's), so it has no single layer.
    """
    k = 0
    four = weights.shape[0] == 8
    for row in range(max(cy - 1, 0), min(cy + 2, n)):
        for j in range(cell_start[row * n + first], cell_start[row * n + last]):
            for c in range(GEOMETRY):
                seg[c, k] = table[c, j]
            for c in range(weights.shape[0]):
                seg[GEOMETRY + c, k] = weights[c, j]
            shares_p[k] = k > 0 and seg[0, k] == seg[2, k - 1] and seg[1, k] == seg[3, k - 1]
            flux_free[k] = (weights[0, j] == 0.0 and weights[1, j] == 0.0 and weights[2, j] == 0.0
                            and (not four or weights[3, j] == 0.0))
            k += 1
    return k


@numba.njit(cache=True, inline="always")
def never(x, y, px, py, qx, qy):
    """No pair is in doubt (the float64 loop's ``doubt``)."""
    return False


def samples_loop(layers, double, log_r2_of, doubt, channels=3):
    """The samples-innermost sum over a gathered table, for the precision of the given layer functions.

    Parameters
    ----------
    layers : numba function
        ``(x, y, px, py, qx, qy, tx, ty, h, log_p) -> (S, D, log_q)`` (``fastmath.potentials_from``).
    double : numba function
        ``(x, y, px, py, qx, qy) -> D`` (``fastmath.double_layer``).
    log_r2_of : numba function
        ``(x, y, px, py) -> log |p - x|^2`` (``fastmath.log_r2``).
    doubt : numba function
        ``(x, y, px, py, qx, qy) -> bool``: the pair's values may miss their error bound (``never``: none).
    channels : {3, 4}
        Of the table and ``acc``.  The fourth is written out beside the three, not as a loop over channels:
        the channels' weights are each segment's constants, held in registers across the samples' loop.

    Returns
    -------
    numba function
        ``loop(m, count, seg, shares_p, flux_free, sx, sy, acc, logs, doubtful)``: ``acc (channels, count)`` = the
        field of the ``m`` segments of ``seg`` (``gather_block``'s layout, in the precision of the functions)
        at the ``count`` samples ``sx, sy``; ``logs (2, >= count)`` is scratch; ``doubtful[i]`` (int32) is
        set to 1 where a pair at sample i is in doubt (and left as it is elsewhere).  A segment continuing
        the previous one takes its logarithm at p from it; a flux-free one costs its double layer only.
    """

    if channels not in (3, 4):
        raise ValueError("channels must be 3 or 4")
    four = channels == 4  # a constant of the compiled loop: its branches fold away
    e_row, c_row = GEOMETRY, GEOMETRY + channels

    @numba.njit(inline="always", fastmath=POLY_MATH, error_model="numpy")
    def loop(m, count, seg, shares_p, flux_free, sx, sy, acc, logs, doubtful):
        for c in range(channels):
            for i in range(count):
                acc[c, i] = 0.0
        current, known = 0, False  # logs[current] holds log|p - x|^2 of segment k when known
        for k in range(m):
            px, py, qx, qy = seg[0, k], seg[1, k], seg[2, k], seg[3, k]
            c0, c1, c2 = seg[c_row, k], seg[c_row + 1, k], seg[c_row + 2, k]
            c3 = seg[c_row + 3, k] if four else 0.0
            if flux_free[k]:
                for i in range(count):
                    d = double(sx[i], sy[i], px, py, qx, qy)
                    doubtful[i] |= doubt(sx[i], sy[i], px, py, qx, qy)
                    acc[0, i] -= c0 * d
                    acc[1, i] -= c1 * d
                    acc[2, i] -= c2 * d
                    if four:
                        acc[3, i] -= c3 * d
                known = False
                continue
            tx, ty, h = seg[4, k], seg[5, k], seg[6, k]
            e0, e1, e2 = seg[e_row, k], seg[e_row + 1, k], seg[e_row + 2, k]
            e3 = seg[e_row + 3, k] if four else 0.0
            if shares_p[k] and known:
                current = 1 - current  # the previous segment's log at q is this one's log at p
            else:
                for i in range(count):
                    logs[current, i] = log_r2_of(sx[i], sy[i], px, py)
            log_p, log_q = logs[current], logs[1 - current]
            for i in range(count):
                s, d, log_q[i] = layers(sx[i], sy[i], px, py, qx, qy, tx, ty, h, log_p[i])
                doubtful[i] |= doubt(sx[i], sy[i], px, py, qx, qy)
                acc[0, i] += e0 * s - c0 * d
                acc[1, i] += e1 * s - c1 * d
                acc[2, i] += e2 * s - c2 * d
                if four:
                    acc[3, i] += e3 * s - c3 * d
            known = True

    return loop


#: The float64 loop (``samples_loop`` of ``fastmath``'s layers), of three channels and of four.
by_samples = samples_loop(potentials_from, double_layer, log_r2, never)
by_samples4 = samples_loop(potentials_from, double_layer, log_r2, never, channels=4)
