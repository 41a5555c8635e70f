"""Bounds on how much a cell's pixels moved, so a view re-evaluates only what shows (numpy only).

The engine reports a cell changed once its far field moved by about 1e-7;
a colour edit moves nearly every cell by that much (the solve is global),
but most by far less than the eye or an 8-bit pixel can see.  These bounds
let the renderer re-evaluate only the cells whose pixels may have moved by
more than a tolerance, while it uploads every reported change.

For a cell, with ``|xi|, |eta| <= 1/2`` inside it:

- far field, harmonic form: ``|Re dK_l z^l| <= |dK_l| 2^(-l/2)``; tensor form:
  ``|dc_ij xi^i eta^j| <= |dc_ij| 2^(-i-j)``;
- near field: a segment of length ``h`` in the 3x3 block changes a pixel by at
  most ``|dE| max|S| + |dC| / 2``, ``|S| <= (h ln+ R + 2m (1 - ln m)) / 2pi``
  with ``R = 2 sqrt(2)`` cells the farthest a pixel of the cell gets from its
  block and ``m = min(h / 2, 1)`` (the logarithm's integrable singularity).

The same sums bound a cell's value about its centre (``value_bounds``, with what
its segments and near points may add, ``near_bounds``): where a mask surely hides
a layer, or surely shows it whole (``culling``).
"""

from __future__ import annotations

import numpy as np

from ..engine import Representation, same_geometry
from ..engine.value_bounds import near_spread, single_layer_bound
from . import packing

#: The near bounds' room for the shader's float32 sums of the segments' and points' terms (each within a few
#: float32 roundings, 6e-8, of its size).
NEAR_ROUNDING = 1.0 + 1e-5


def far_bound(delta: np.ndarray, order: int, harmonic: bool, scalar: bool = False, channels: int = 3) -> np.ndarray:
    """Largest change of any channel of a cell's far field, ``(m,)``, from packed coefficient changes.

    Parameters
    ----------
    delta : numpy.ndarray
        ``(m, floats)`` changes of cells' packed coefficients (``packing.cell_coefficients``, one row a cell).
    order : int
    harmonic : bool
    scalar : bool
        The rows are a scalar field's (``packing``).
    channels : int
        Of colour rows: 3, or 4 with an alpha field's.
    """
    size, weight = _term_sizes(delta, order, harmonic, scalar, channels)
    # float32 sums of at most a few hundred terms: within 1e-5 relative, covered by the last factor
    per_channel = np.tensordot(size, weight.astype(np.float32), axes=([1], [0]))
    return per_channel.max(axis=1, initial=0.0).astype(np.float64) * 1.0001


def value_bounds(rows: np.ndarray, order: int, harmonic: bool, scalar: bool = False,
                 channels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Each cell's far field at its centre and how far any of its pixels may get from that, per channel.

    The spread holds the shader's float32 rounding too: each of Horner's ``2 (order + 1)`` steps rounds by at
    most ``2^-24`` of the terms' sizes, so the shader's value at any pixel of the cell lies within it as well.

    Parameters
    ----------
    rows : numpy.ndarray
        ``(m, floats)`` packed coefficients of cells (``packing.cell_coefficients``, one row a cell).
    order : int
    harmonic : bool
    scalar : bool
        The rows are a scalar field's.
    channels : int
        Of colour rows: 3, or 4 with an alpha field's.

    Returns
    -------
    centre, spread : numpy.ndarray
        ``(m, channels)`` float64, or ``(m, 1)`` for a scalar field.
    """
    rows = np.asarray(rows, np.float32)
    size, weight = _term_sizes(rows, order, harmonic, scalar, channels)
    first = rows[:, :1] if scalar else rows.reshape(len(rows), -1, 4)[:, 0, :channels]  # Re K_0, or c_00
    centre = first.astype(np.float64)
    tail = np.tensordot(size[:, 1:].astype(np.float64), weight[1:], axes=([1], [0]))
    rounding = 4 * (order + 1) * 2.0**-24
    return centre, tail * 1.0001 + (np.abs(centre) + tail) * rounding


def _term_sizes(rows: np.ndarray, order: int, harmonic: bool, scalar: bool = False,
                channels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """``(m, terms, channels)`` float32 sizes of the packed coefficients' terms per channel (3 or 4, or a scalar
    field's 1), and ``(terms,)`` the largest each term's monomial gets over a cell: with ``|xi|, |eta| <= 1/2``,
    ``|z^l| <= 2^(-l/2)`` and ``|xi^i eta^j| <= 2^(-i-j)``."""
    rows = np.asarray(rows, np.float32)
    terms = order + 1
    if harmonic:
        weight = 2.0 ** (-0.5 * np.arange(terms))
        if scalar:  # per l: Re, Im
            pairs = rows[:, : 2 * terms].reshape(-1, terms, 2)
            return np.sqrt((pairs * pairs).sum(axis=2))[:, :, None], weight  # |K_l|
        square = (rows * rows).reshape(-1, terms, 8)  # per l: Re rgb a, Im rgb a
        return np.sqrt(square[:, :, 0:channels] + square[:, :, 4 : 4 + channels]), weight  # |K_l|
    degree = 2.0 ** -np.add.outer(np.arange(terms), np.arange(terms)).ravel().astype(np.float64)
    if scalar:  # each row padded to whole texels
        return np.abs(rows.reshape(len(rows), terms, -1)[:, :, :terms].reshape(len(rows), -1))[:, :, None], degree
    return np.abs(rows.reshape(-1, terms**2, 4)[:, :, :channels]), degree


def cell_value_bounds(rep: Representation, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``value_bounds`` of every cell of ``rep`` (or of its scalar field ``weights . colour``) as the canvas packs
    it, flat cells, and ``near_bounds`` added to the spread: what ``CanvasData.value_bounds`` keeps."""
    n = rep.lattice.cells_per_side
    harmonic = packing.uses_harmonic(rep)
    rows = packing.cell_coefficients(rep, harmonic=harmonic, weights=weights).reshape(n * n, -1)
    centre, spread = value_bounds(rows, rep.order, harmonic, weights is not None)
    return centre, spread + near_bounds(rep, weights)


def near_bounds(rep: Representation, weights: np.ndarray | None = None, alpha: Representation | None = None,
                first: int = 0) -> np.ndarray:
    """How far the segments and near points of each cell may move the shader's values at its pixels, ``(cells^2,
    channels)``, flat cells: ``engine.value_bounds.near_spread`` of the field as the canvas packs it (its scalar
    field ``weights . colour``, its colour, or its colour and ``alpha``'s first channel), of its channels from
    ``first`` on (a translucent layer's alpha alone: 3), with room for the shader's float32 sums of them."""
    matrix = np.eye(3) if weights is None else np.reshape(weights, (3, 1))
    columns = [near_spread(rep, matrix[:, first:])] if first < matrix.shape[1] else []
    if alpha is not None:
        columns.append(near_spread(alpha, np.eye(3)[:, :1]))
    spread = np.concatenate(columns, axis=-1)
    return spread.reshape(-1, spread.shape[-1]) * NEAR_ROUNDING


def segment_changes(before: Representation, after: Representation) -> np.ndarray | None:
    """Bound on each ``near`` segment's change of the near field it adds to any pixel, ``(segments,)`` of ``after``.

    Segments of a cell whose run of segments changed geometry (a curve moved
    through it) get ``inf``: no bound is known there.  None when the
    lattices differ.
    """
    matched = _matched_runs(before, after)
    if matched is None:
        return None
    old_index, new_index, _ = matched
    old, new = before.near[0], after.near[0]
    out = np.full(len(new.p), np.inf)
    if len(new_index) == len(new.p) == len(old.p):  # every segment matched, in place: no gathers
        old_index = new_index = slice(None)
    flux = _largest_channel(np.abs(new.flux[new_index] - old.flux[old_index]))
    jump = _largest_channel(np.abs(new.jump[new_index] - old.jump[old_index]))
    length = np.hypot(*(new.q[new_index] - new.p[new_index]).T)
    out[new_index] = flux * single_layer_bound(length, after.lattice.cell_size) + jump / 2
    return out


def _largest_channel(values: np.ndarray) -> np.ndarray:
    """``values (m, 3)``'s largest channel per row (a reduction over an axis of 3 is slow in numpy)."""
    return np.maximum(np.maximum(values[:, 0], values[:, 1]), values[:, 2])


def _matched_runs(before: Representation, after: Representation):
    """``near`` segments (indices before and after) of the cells whose runs kept their geometry, and the
    ``(2^L, 2^L)`` mask of the cells whose runs did not; None when the lattices differ."""
    (old, old_start), (new, new_start) = before.near, after.near
    if len(old_start) != len(new_start):
        return None
    n = after.lattice.cells_per_side
    if same_geometry(before, after):
        index = np.arange(len(new.p))
        return index, index, np.zeros((n, n), bool)
    counts = np.diff(new_start)
    same_count = counts == np.diff(old_start)
    cells = np.flatnonzero(same_count & (counts > 0))
    runs = counts[cells]
    firsts = np.cumsum(runs) - runs
    within = np.arange(runs.sum()) - np.repeat(firsts, runs)
    old_index = np.repeat(old_start[cells], runs) + within
    new_index = np.repeat(new_start[cells], runs) + within
    equal = (old.p[old_index] == new.p[new_index]).all(axis=1) & (old.q[old_index] == new.q[new_index]).all(axis=1)
    cell_kept = np.minimum.reduceat(equal, firsts) if len(runs) else np.zeros(0, bool)
    changed = ~same_count
    changed[cells[~cell_kept]] = True
    kept = np.repeat(cell_kept, runs)
    return old_index[kept], new_index[kept], changed.reshape(n, n)


def block_sums(per_segment: np.ndarray, rep: Representation) -> np.ndarray:
    """``(2^L, 2^L)`` sums of a per-``near``-segment quantity over each cell's 3x3 block (``rep``'s cell lists)."""
    n = rep.lattice.cells_per_side
    own = np.repeat(np.arange(n * n), np.diff(rep.near[1]))
    per_cell = np.bincount(own, per_segment, minlength=n * n).reshape(n, n)
    return _block(per_cell)


def _block(per_cell: np.ndarray) -> np.ndarray:
    n = len(per_cell)
    padded = np.pad(per_cell, 1)
    return sum(padded[1 + dy : 1 + dy + n, 1 + dx : 1 + dx + n] for dy in (-1, 0, 1) for dx in (-1, 0, 1))


def near_bound(before: Representation, after: Representation, changes: np.ndarray | None = None) -> np.ndarray | None:
    """Largest change of the segments' near field over each cell's pixels, ``(2^L, 2^L)``.

    ``inf`` for the cells whose 3x3 block holds a cell whose segments moved
    (or went); None when the lattices differ.  ``changes``: ``segment_changes``, when known.
    """
    matched = _matched_runs(before, after)
    if matched is None:
        return None
    sums = block_sums(segment_changes(before, after) if changes is None else changes, after)
    return np.where(_block(matched[2].astype(np.float64)) > 0, np.inf, sums)
