"""Rasterising a fine cell in sub-cells: far field and near field of the tensor grid in one pass (compiled).

A fine cell of size ``r`` holding many samples pays for every sample against
every segment of its 3x3 block (``grid.near_field_grid``).  Here the cell is
cut into ``split x split`` sub-cells of size ``s = r / split``.  For each
sub-cell of centre ``zs``:

- the cell's local expansion is re-centred on ``zs`` (a Taylor shift of the
  degree-``order`` polynomial: exact, no truncation);
- a block segment at least ``separation * s`` from ``zs`` is folded into that
  expansion (P2L: the Taylor series of its single and double layer about
  ``zs``, closed-form for a straight segment, truncated at ``order``; samples
  are within ``s / sqrt 2`` of ``zs``, so the series' ratio is at most
  ``1 / (sqrt 2 separation)``);
- the other segments are summed exactly at the sub-cell's samples, as in
  ``grid``.

With ``w = (z - zs) / s``, ``v = (z0 - zs) / s`` on a segment from ``p`` to
``q`` (unit tangent ``t``, normal ``n0 = -i t``; docs/design.md section 3)::

    L_0 = 2 pi (E S(zs) - C D(zs))                 (real part only counts)
    L_l = -E s J_l / l - C n0 J_(l+1),   l >= 1
    J_1 = log(vq / vp) / t,   J_m = (vp^(1-m) - vq^(1-m)) / ((m - 1) t)

and the field is ``(1/2pi) Re sum_l L_l w^l`` as for ``fmm.expansions``'s
scaled local expansions.  ``p2l_reference`` is the plain numpy form of the
expansions, ``local_grid.local_field_reference`` of the cells' polynomials.

Only cells with segments in their 3x3 block go through the sub-cells: the
others' samples take their cell's expansion alone, from the compiled
``local_grid.local_field_grid`` (Horner straight into the image, no per-cell
set-up), and with ``split = 1`` every cell does, the exact near sum being
added by ``grid.near_field_grid``.

Measured at 1024 x 1024 on the Hilbert benchmark (bench/bench_paper.py,
2,048 pieces at level 5, 32 samples a cell side): 4 x 4 sub-cells cut the
sample-segment pairs summed exactly from 51.6 M to 5.2 M, for 0.73 M
expansions; the image moved by at most 0.0013/255 from the exact split.
"""

from __future__ import annotations

import numba
import numpy as np

from .blocks import GEOMETRY, by_samples, by_samples4, gather_block
from .fastmath import FAST_MATH, INV_TWO_PI, POLY_MATH, TWO_PI, log_r2, potentials_from
from .grid import grid_arrays, grid_cell_runs, near_field_grid, skip_flags
from .local_grid import NO_FOURTH, by_powers, by_powers4, local_field_grid
from .rows import spread_rows
from .segment_sums import near_tables

#: Default separation, in sub-cell sizes, from a sub-cell's centre beyond which a segment is expanded:
#: the series' ratio is at most 1 / (2 sqrt 2) = 0.35 (0.35^9 = 9e-5 at order 8).
SEPARATION = 2.0


def p2l_reference(p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray, centre: complex, size: float,
                  order: int) -> np.ndarray:
    """Scaled local expansion ``(channels, order + 1)`` about ``centre`` (cell ``size``) of straight segments
    (plain numpy).

    ``(1/2pi) Re sum_l L_l ((z - centre) / size)^l`` approximates their field
    ``sum E S - C D`` near ``centre``; ``L_0`` is real (its field at the centre
    times 2 pi).  The segments must stay away from ``centre``.
    """
    from .potentials import direct_sum_reference

    pz, qz = p[:, 0] + 1j * p[:, 1], q[:, 0] + 1j * q[:, 1]
    h = np.abs(qz - pz)
    t = (qz - pz) / h
    vp, vq = (pz - centre) / size, (qz - centre) / size
    j = [None, np.log(vq / vp) / t]
    for m in range(2, order + 2):
        j.append((vp ** (1 - m) - vq ** (1 - m)) / ((m - 1) * t))
    out = np.zeros((flux.shape[1], order + 1), complex)
    out[:, 0] = TWO_PI * direct_sum_reference(np.array([[centre.real, centre.imag]]), p, q, flux, jump)[0]
    n0 = -1j * t
    for order_l in range(1, order + 1):
        out[:, order_l] = (-flux.T * size * j[order_l] / order_l - jump.T * n0 * j[order_l + 1]).sum(axis=1)
    return out


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def _distance2(x, y, seg, k):
    """Squared distance from (x, y) to segment ``k`` of the gathered table ``seg``."""
    px, py, tx, ty, h = seg[0, k], seg[1, k], seg[4, k], seg[5, k], seg[6, k]
    along = min(max((x - px) * tx + (y - py) * ty, 0.0), h)
    dx, dy = px + along * tx - x, py + along * ty - y
    return dx * dx + dy * dy


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def _p2l_state(count, far, xc, yc, size, state):
    """Per segment of ``far (7 + 2 channels, count)``, what its expansion about (xc, yc) starts from, into
    ``state (12, count)``.

    Rows: ``S`` and ``D`` at the centre, ``J_1`` (re, im) and ``1 / vp``, ``1 / vq`` (re, im); rows 8 to
    11 are ``_p2l_sums``' scratch.  The
    logarithms and the angle are the layers' own (``fastmath.potentials_from``): ``log(vq / vp)`` is
    ``(log|q - zs|^2 - log|p - zs|^2) / 2 + i angle``.  Branch-free, so the loop vectorises.
    """
    for k in range(count):
        px, py, qx, qy, tx, ty = far[0, k], far[1, k], far[2, k], far[3, k], far[4, k], far[5, k]
        log_p = log_r2(xc, yc, px, py)
        single, double, log_q = potentials_from(xc, yc, px, py, qx, qy, tx, ty, far[6, k], log_p)
        ratio, angle = 0.5 * (log_q - log_p), double * TWO_PI
        state[0, k], state[1, k] = single, double
        state[2, k], state[3, k] = ratio * tx + angle * ty, angle * tx - ratio * ty  # log(vq / vp) conj(t)
        vx, vy = px - xc, py - yc
        scale = size / (vx * vx + vy * vy)
        state[4, k], state[5, k] = vx * scale, -vy * scale
        vx, vy = qx - xc, qy - yc
        scale = size / (vx * vx + vy * vy)
        state[6, k], state[7, k] = vx * scale, -vy * scale


@numba.njit(cache=True, fastmath=FAST_MATH, error_model="numpy")
def _p2l_sums(count, far, state, size, order, coeffs):
    """Add the expansions of ``far (7 + 2 channels, count)`` (from ``_p2l_state``) to ``coeffs (channels,
    order + 1)``, 3 or 4 channels.

    ``J_m = (vp^(1-m) - vq^(1-m)) conj(t) / (m - 1)`` for ``m >= 2``; ``L_l`` takes ``-size J_l / l`` times
    E and ``-n0 J_(l+1)`` times C.  Not inlined: its reassociating flags let the sums over segments
    vectorise (it overwrites ``state``'s rows 2, 3 and 8 to 11).  A fourth channel is summed in a loop of its
    own, which keeps the three channels' loop as it is.
    """
    channels = coeffs.shape[0]
    e_row, c_row = GEOMETRY, GEOMETRY + channels
    for c in range(channels):
        total = 0.0
        for k in range(count):
            total += far[e_row + c, k] * state[0, k] - far[c_row + c, k] * state[1, k]
        coeffs[c, 0] += TWO_PI * total
    for k in range(count):
        state[8, k], state[9, k], state[10, k], state[11, k] = state[4, k], state[5, k], state[6, k], state[7, k]
    for m in range(1, order + 2):
        if m > 1:  # J_m into rows 2, 3; vp^(1-m), vq^(1-m) on to the next power
            inv = 1.0 / (m - 1)
            for k in range(count):
                tx, ty = far[4, k], far[5, k]
                pr, pi, qr, qi = state[8, k], state[9, k], state[10, k], state[11, k]
                dr, di = pr - qr, pi - qi
                state[2, k], state[3, k] = (dr * tx + di * ty) * inv, (di * tx - dr * ty) * inv
                ar, ai, br, bi = state[4, k], state[5, k], state[6, k], state[7, k]
                state[8, k], state[9, k] = pr * ar - pi * ai, pr * ai + pi * ar
                state[10, k], state[11, k] = qr * br - qi * bi, qr * bi + qi * br
        er0 = er1 = er2 = ei0 = ei1 = ei2 = cr0 = cr1 = cr2 = ci0 = ci1 = ci2 = 0.0
        for k in range(count):
            tx, ty, jr, ji = far[4, k], far[5, k], state[2, k], state[3, k]
            nr, ni = ty * jr + tx * ji, ty * ji - tx * jr  # n0 J, n0 = -i t
            e0, e1, e2 = far[e_row, k], far[e_row + 1, k], far[e_row + 2, k]
            c0, c1, c2 = far[c_row, k], far[c_row + 1, k], far[c_row + 2, k]
            er0 += e0 * jr
            ei0 += e0 * ji
            er1 += e1 * jr
            ei1 += e1 * ji
            er2 += e2 * jr
            ei2 += e2 * ji
            cr0 += c0 * nr
            ci0 += c0 * ni
            cr1 += c1 * nr
            ci1 += c1 * ni
            cr2 += c2 * nr
            ci2 += c2 * ni
        er3 = ei3 = cr3 = ci3 = 0.0
        if channels == 4:
            for k in range(count):
                tx, ty, jr, ji = far[4, k], far[5, k], state[2, k], state[3, k]
                e3, c3 = far[10, k], far[14, k]
                er3 += e3 * jr
                ei3 += e3 * ji
                cr3 += c3 * (ty * jr + tx * ji)
                ci3 += c3 * (ty * ji - tx * jr)
        if m <= order:
            f = -size / m
            coeffs[0, m] += complex(f * er0, f * ei0)
            coeffs[1, m] += complex(f * er1, f * ei1)
            coeffs[2, m] += complex(f * er2, f * ei2)
            if channels == 4:
                coeffs[3, m] += complex(f * er3, f * ei3)
        if m >= 2:
            coeffs[0, m - 1] -= complex(cr0, ci0)
            coeffs[1, m - 1] -= complex(cr1, ci1)
            coeffs[2, m - 1] -= complex(cr2, ci2)
            if channels == 4:
                coeffs[3, m - 1] -= complex(cr3, ci3)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _shift(parent, order, dx, dy, split, coeffs):
    """``coeffs (channels, order + 1)`` = ``parent``'s polynomial in ``w`` re-expanded in ``w' = split (w - d)``,
    ``d = dx + i dy``."""
    d = complex(dx, dy)
    for c in range(coeffs.shape[0]):
        for l in range(order + 1):
            coeffs[c, l] = parent[c, l]
        if split == 1:  # d = 0: the parent's own polynomial
            continue
        for i in range(order):
            for j in range(order - 1, i - 1, -1):
                coeffs[c, j] += d * coeffs[c, j + 1]
        scale = 1.0
        for l in range(order + 1):
            coeffs[c, l] *= scale
            scale /= split


@numba.njit(cache=True, inline="always")
def _sub_runs(coords, start, stop, origin, inv_sub, split, runs):
    """``runs (split + 1,)``: offsets in ``coords[start:stop]`` of each sub-cell's samples (cell from ``origin``)."""
    runs[0] = start
    i = start
    for part in range(split):
        while i < stop and min(int((coords[i] - origin) * inv_sub), split - 1) <= part:
            i += 1
        runs[part + 1] = i
    runs[split] = stop


def _cells_of(channels):
    """``cells_of`` of ``channels`` (3 or 4), a compiled kernel each (as ``grid._near_grid_of``)."""
    four = channels == 4
    rows = GEOMETRY + 2 * channels

    @numba.njit(cache=True, fastmath=POLY_MATH, error_model="numpy")
    def cells_of(cells, lo, hi, local, fourth, order, xs, ys, x_start, y_start, n, cell_size, split, reach,
                 cell_start, table, weights, out, seg, shares_p, flux_free, sub, sub_shares, sub_ff, far_seg, state,
                 sx, sy, acc, powers, logs, doubtful, coeffs, parent, xruns, yruns):
        """Write the field (far + near) of the samples of ``cells[lo:hi]`` into ``out``; the rest are the thread's
        scratch.

        One call per run of cells: a call passes some thirty arrays (reference counts and all).
        """
        for item in range(lo, hi):
            cy, cx = cells[item] // n, cells[item] % n
            ya0, yb0, xa0, xb0 = y_start[cy], y_start[cy + 1], x_start[cx], x_start[cx + 1]
            if ya0 == yb0 or xa0 == xb0:
                continue
            m = gather_block(cy, max(cx - 1, 0), min(cx + 2, n), n, cell_start, table, weights, seg, shares_p,
                             flux_free)
            for c in range(3):
                for l in range(order + 1):
                    parent[c, l] = local[cy, cx, c, l]
            if four:
                for l in range(order + 1):
                    parent[3, l] = fourth[cy, cx, 0, l]
            size = cell_size / split
            inv_size = 1.0 / size
            _sub_runs(xs, xa0, xb0, cx * cell_size, inv_size, split, xruns)
            _sub_runs(ys, ya0, yb0, cy * cell_size, inv_size, split, yruns)
            for a in range(split):
                ya, yb = yruns[a], yruns[a + 1]
                for b in range(split):
                    xa, xb = xruns[b], xruns[b + 1]
                    width = xb - xa
                    count = (yb - ya) * width
                    if count == 0:
                        continue
                    xc, yc = cx * cell_size + (b + 0.5) * size, cy * cell_size + (a + 0.5) * size
                    _shift(parent, order, (b + 0.5) / split - 0.5, (a + 0.5) / split - 0.5, split, coeffs)
                    near, count_far = 0, 0
                    reach2 = (reach * size) ** 2
                    for k in range(m):
                        if _distance2(xc, yc, seg, k) >= reach2:
                            for c in range(rows):
                                far_seg[c, count_far] = seg[c, k]
                            count_far += 1
                        else:
                            for c in range(rows):
                                sub[c, near] = seg[c, k]
                            sub_shares[near] = near > 0 and shares_p[k] and sub[0, near] == sub[2, near - 1] and \
                                sub[1, near] == sub[3, near - 1]
                            sub_ff[near] = flux_free[k]
                            near += 1
                    if count_far > 0:
                        _p2l_state(count_far, far_seg, xc, yc, size, state)
                        _p2l_sums(count_far, far_seg, state, size, order, coeffs)
                    xi, eta, far = powers[2 + channels], powers[3 + channels], powers[2 : 2 + channels]
                    for i in range(yb - ya):
                        for j in range(width):
                            sx[i * width + j], sy[i * width + j] = xs[xa + j], ys[ya + i]
                            xi[i * width + j] = (xs[xa + j] - xc) * inv_size
                            eta[i * width + j] = (ys[ya + i] - yc) * inv_size
                    if four:
                        by_powers4(coeffs, order, count, xi, eta, INV_TWO_PI, powers)
                    else:
                        by_powers(coeffs, order, count, xi, eta, INV_TWO_PI, powers)
                    if near > 0 and four:
                        by_samples4(near, count, sub, sub_shares, sub_ff, sx, sy, acc, logs, doubtful)
                    elif near > 0:
                        by_samples(near, count, sub, sub_shares, sub_ff, sx, sy, acc, logs, doubtful)
                    if near > 0:
                        for c in range(channels):
                            for i in range(count):
                                far[c, i] += acc[c, i]
                    for i in range(yb - ya):
                        for j in range(width):
                            for c in range(channels):
                                out[ya + i, xa + j, c] = far[c, i * width + j]


    return cells_of


_cells3, _cells4 = _cells_of(3), _cells_of(4)


def _subcell_grid_of(channels):
    """``subcell_grid`` of ``channels``."""
    four = channels == 4
    rows = GEOMETRY + 2 * channels

    @numba.njit(parallel=True, cache=True, error_model="numpy")
    def subcell_grid(local, fourth, order, xs, ys, x_start, y_start, n, cell_size, split, reach, cell_start, table,
                     weights, cells, group_start, capacity, most, out):
        spread = spread_rows(group_start)  # each thread's groups from all over the picture
        for t in numba.prange(len(spread)):
            g = spread[t]
            seg, sub = np.empty((rows, capacity)), np.empty((rows, capacity))
            shares_p, flux_free = np.empty(capacity, np.bool_), np.empty(capacity, np.bool_)
            sub_shares, sub_ff = np.empty(capacity, np.bool_), np.empty(capacity, np.bool_)
            far_seg, state = np.empty((rows, capacity)), np.empty((12, capacity))
            powers = np.empty((4 + channels, most))
            sx, sy = np.empty(most), np.empty(most)
            acc, logs, doubtful = np.empty((channels, most)), np.empty((2, most)), np.zeros(most, np.int32)
            coeffs = np.empty((channels, order + 1), np.complex128)
            parent = np.empty((channels, order + 1), np.complex128)
            xruns, yruns = np.empty(split + 1, np.int64), np.empty(split + 1, np.int64)
            run = (cells, group_start[g], group_start[g + 1], local, fourth, order, xs, ys, x_start, y_start, n,
                   cell_size, split, reach, cell_start, table, weights, out, seg, shares_p, flux_free, sub, sub_shares,
                   sub_ff, far_seg, state, sx, sy, acc, powers, logs, doubtful, coeffs, parent, xruns, yruns)
            if four:
                _cells4(*run)
            else:
                _cells3(*run)

    return subcell_grid


#: The sub-cells' kernel of each count of channels.
_SUBCELL_GRID = {channels: _subcell_grid_of(channels) for channels in (3, 4)}


@numba.njit(cache=True)
def _plan(n, cell_start, x_start, y_start, groups, skip):
    """Cells with samples and block segments, but those ``skip`` names (``(n, n)`` or ``(0, 0)``), in runs of about
    equal cost, the most segments in a block and samples in a cell."""
    cost = np.zeros(n * n)
    total, capacity, most = 0.0, 1, 1
    skipping = skip.shape[0] > 0
    for cy in range(n):
        rows = y_start[cy + 1] - y_start[cy]
        for cx in range(n):
            samples = rows * (x_start[cx + 1] - x_start[cx])
            if samples == 0 or (skipping and skip[cy, cx]):
                continue
            m = 0
            for row in range(max(cy - 1, 0), min(cy + 2, n)):
                m += cell_start[row * n + min(cx + 2, n)] - cell_start[row * n + max(cx - 1, 0)]
            if m == 0:
                continue
            cost[cy * n + cx] = samples * (m / 8.0 + 4.0) + 8.0 * m
            total += cost[cy * n + cx]
            capacity, most = max(capacity, m), max(most, samples)
    cells = np.flatnonzero(cost)
    groups = max(1, min(groups, len(cells)))
    group_start = np.full(groups + 1, len(cells), np.int64)
    group_start[0] = 0
    running, g = 0.0, 1
    for item in range(len(cells)):
        while g < groups and running >= total * g / groups:
            group_start[g] = item
            g += 1
        running += cost[cells[item]]
    return cells, group_start, capacity, most


#: Groups of cells per thread (each thread's spread over the picture: ``rows.spread_rows``).
GROUPS_PER_THREAD = 8


def subcell_field_grid(local: np.ndarray, order: int, xs: np.ndarray, ys: np.ndarray, cell_size: float,
                       cell_start: np.ndarray, p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray,
                       split: int = 1, separation: float = SEPARATION, out: np.ndarray | None = None,
                       tables: tuple[np.ndarray, np.ndarray] | None = None, precision: str = "double",
                       degrees: np.ndarray | None = None, offsets: tuple[np.ndarray, np.ndarray] | None = None,
                       centres: np.ndarray | None = None, skip: np.ndarray | None = None,
                       bounds: np.ndarray | None = None,
                       fourth: tuple[np.ndarray, np.ndarray | None] | None = None) -> np.ndarray:
    """The field of an FMR's segments (far and near) on the tensor grid ``ys x xs``, ``(len(ys), len(xs),
    channels)``: 3 channels, or 4 with ``fourth``.

    Parameters
    ----------
    local : numpy.ndarray
        ``(n, n, 3, > order)`` complex scaled local expansions of the fine cells.
    order : int
        Degree of the polynomials evaluated (and of the segments' expansions).
    xs, ys : numpy.ndarray
        Sorted (non-decreasing) sample coordinates in document pixels.
    cell_size : float
        Fine cell size in pixels.
    cell_start, p, q, flux, jump : numpy.ndarray
        The segments sorted by fine cell, as for ``segment_sums.near_sum`` (with ``fourth``, ``flux`` and
        ``jump`` have a fourth column: the other field's).
    split : int
        Sub-cells per side of a fine cell (1: none).
    separation : float
        Segments at least this many sub-cell sizes from a sub-cell's centre are expanded (``inf``: none).
    out : numpy.ndarray, optional
        C-contiguous float64 ``(len(ys), len(xs), channels)``, overwritten and returned.
    tables : tuple of numpy.ndarray, optional
        ``segment_sums.near_tables(p, q, flux, jump)``, when kept.
    bounds : numpy.ndarray, optional
        ``single.error_bounds`` of the segments, when kept (``grid.near_field_grid``'s).
    precision : {"double", "single"}
        Of the near field of cells not split (``grid.near_field_grid``'s); sub-cells sum theirs in float64.
    degrees, offsets, centres : optional
        The far field's degree by the samples' distance from their cell's centre, those distances when the
        grid is a band of a larger one, and what cells of degree 0 read (``local_grid.local_field_grid``).
    skip : numpy.ndarray, optional
        ``(n, n)`` bool: cells whose samples are not needed (``raster``: a layer hidden there).  They are 0 plus
        a part of their near field or none; the other samples are as without ``skip``.
    fourth : tuple of numpy.ndarray, optional
        ``(local, centres)`` of a field of the same segments (a translucent layer's alpha field), whose first
        channel is evaluated as a fourth (``local_grid.local_field_grid``'s).
    """
    if not 0 <= order < local.shape[-1]:
        raise ValueError(f"order must be between 0 and {local.shape[-1] - 1}")
    if split < 1:
        raise ValueError("split must be at least 1")
    channels = 3 if fourth is None else 4
    if np.shape(flux)[1] != channels:
        raise ValueError(f"flux and jump must have {channels} columns")
    xs, ys, out = grid_arrays(xs, ys, out, channels)
    if out.size == 0:
        return out
    n = local.shape[0]
    cell_start = np.asarray(cell_start, np.int64)
    if split == 1:
        local_field_grid(local, order, xs, ys, cell_size, out=out, skip=skip, degrees=degrees, offsets=offsets,
                         centres=centres, zero_skipped=True, fourth=fourth)
        return near_field_grid(xs, ys, n, cell_size, cell_start, p, q, flux, jump, out=out, tables=tables,
                               precision=precision, skip=skip, bounds=bounds)
    counts = np.pad(np.diff(cell_start).reshape(n, n), 1)
    near = sum(counts[1 + dy : 1 + dy + n, 1 + dx : 1 + dx + n] for dy in (-1, 0, 1) for dx in (-1, 0, 1)) > 0
    local_field_grid(local, order, xs, ys, cell_size, out=out, skip=near if skip is None else near | skip,
                     degrees=degrees, offsets=offsets, centres=centres, zero_skipped=skip is not None, fourth=fourth)
    x_start, y_start = grid_cell_runs(xs, cell_size, n), grid_cell_runs(ys, cell_size, n)
    cells, group_start, capacity, most = _plan(n, cell_start, x_start, y_start,
                                               GROUPS_PER_THREAD * numba.get_num_threads(), skip_flags(skip))
    if len(cells) == 0:
        return out
    table, weights = tables or near_tables(p, q, flux, jump)
    _SUBCELL_GRID[channels](np.asarray(local, np.complex128),
                            np.asarray(NO_FOURTH if fourth is None else fourth[0], np.complex128), int(order), xs, ys,
                            x_start, y_start, n, float(cell_size), int(split), float(separation), cell_start, table,
                            weights, cells, group_start, capacity, most, out)
    return out
