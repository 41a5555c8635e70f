"""A representation as the flat float32/int32 tables the canvas shader reads (numpy only, no GL).

Layouts (``shaders/canvas.frag`` reads them):

- **coefficients**: ``texels(order, harmonic)`` RGBA texels per fine cell, cells
  row-major, one texel (r, g, b, 0) a term.  Harmonic form (documents without
  points): ``K_l = L_l / 2pi`` of the local expansion, ``u = Re sum_l K_l (xi +
  i eta)^l``, per ``l`` a texel of Re K_l then one of Im K_l.  Tensor form:
  ``Representation.polynomials()``'s ``c[i, j]`` of ``xi^i eta^j``, per ``(i, j)``
  (row-major).  The shader fetches each term as it needs it.
- **segments**: per fine cell, the segments of its 3x3 block (each segment is
  listed up to 9 times), 3 texels each: ``(p - centre, q - centre)``,
  ``(E, length)``, ``(C, 0)``, with ``centre`` that cell's centre, so a pixel
  reads one list and works in small coordinates; plus the lists' CSR offsets
  ``cell_start`` as int32.
- **near points**: 2 texels each, ``(x, y, 1 / r^2, 0)``, ``(weight, 0)``,
  and their per-cell CSR lists (``start``, ``members``) as int32.

A translucent layer's image may carry its alpha field in a fourth channel (``alpha``: the alpha field's first
channel, when both have the same segments): its coefficient texels are (r, g, b, alpha), its segments'
``(E, E_alpha)``, ``(C, C_alpha)`` (the shader takes each length from the end points), its near points'
``(weight, 0)`` (an alpha field has no points).

A *scalar* field (``weights``: a mask, read through its luminance; an alpha or a
blur field, through its first channel) keeps one channel, the weighted sum of the
three, four values a texel: the coefficients' terms in order (Re K_l, Im K_l for
each ``l``; or ``c[i, j]``, each row ``i`` padded with zeros to whole texels),
``texels(order, harmonic, True)`` a cell; a segment's 2 texels ``(p - centre,
q - centre)``, ``(E, C, length, 0)``; a near point's one, ``(x, y, 1 / r^2, weight)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..engine import Representation, local_polynomials, with_alpha

TWO_PI = 2.0 * np.pi


def texels(order: int, harmonic: bool, scalar: bool = False) -> int:
    """RGBA texels per cell of the coefficient table: one per term (rgb), or four terms a texel (``scalar``)."""
    if not scalar:
        return 2 * (order + 1) if harmonic else (order + 1) ** 2
    return -(-2 * (order + 1) // 4) if harmonic else (order + 1) * _row_texels(order)


def _row_texels(order: int) -> int:
    """Texels of a row ``c[i, 0..order]`` of a scalar tensor."""
    return -(-(order + 1) // 4)


def _scalars(values: np.ndarray) -> np.ndarray:
    """``(m, terms)`` float64 to ``(m * ceil(terms / 4), 4)`` float32 texels, four terms each (zeros after)."""
    out = np.zeros((len(values), -(-values.shape[1] // 4) * 4), np.float32)
    out[:, : values.shape[1]] = values
    return out.reshape(-1, 4)


def _padded(values: np.ndarray) -> np.ndarray:
    """``(m, terms, 3 or 4)`` float64 to ``(m * terms, 4)`` float32 texels (rgb, 0) or (rgb, alpha)."""
    out = np.zeros(values.shape[:2] + (4,), np.float32)
    out[..., : values.shape[2]] = values
    return out.reshape(-1, 4)


def cell_coefficients(rep: Representation, cells: np.ndarray | None = None, harmonic: bool | None = None,
                      weights: np.ndarray | None = None, alpha: Representation | None = None) -> np.ndarray:
    """Coefficient texels of ``cells`` (flat indices, default all), ``(len(cells) * texels, 4)`` float32.

    Parameters
    ----------
    rep : Representation
    cells : numpy.ndarray, optional
        Flat fine-cell indices ``row * 2^L + column``.
    harmonic : bool, optional
        The harmonic form; defaults to ``uses_harmonic(rep)``.  Only for representations without points.
    weights : numpy.ndarray, optional
        ``(3,)``: the scalar field ``weights . colour`` (the module's layouts).
    alpha : Representation, optional
        The layer's alpha field, on ``rep``'s lattice at its order: its first channel in the fourth.
    """
    harmonic = uses_harmonic(rep) if harmonic is None else harmonic
    if harmonic and rep.points is not None:
        raise ValueError("the harmonic form has no room for diffusion points")
    order = rep.order
    n = rep.lattice.cells_per_side
    chosen = slice(None) if cells is None else np.asarray(cells, np.int64)
    local = rep.local.reshape(n * n, 3, -1)[chosen, :, : order + 1]  # a view until indexed
    if alpha is not None:
        local = np.concatenate([local, alpha.local.reshape(n * n, 3, -1)[chosen, :1, : order + 1]], axis=1)
    channels = local.shape[1]
    if harmonic and weights is not None:
        k = np.einsum("c,mcl->ml", weights, local) / TWO_PI
        pairs = np.stack([k.real, k.imag], axis=2)  # (cell, l, Re/Im)
        pairs[:, 0, 1] = 0.0  # Im K_0 never shows (u = Re ...)
        return _scalars(pairs.reshape(len(local), -1))
    if harmonic:
        out = np.zeros((len(local), order + 1, 2, 4), np.float32)  # (cell, l, Re/Im, rgb + alpha or 0)
        out[:, :, 0, :channels] = local.real.transpose(0, 2, 1) / TWO_PI
        out[:, 1:, 1, :channels] = local.imag[:, :, 1:].transpose(0, 2, 1) / TWO_PI  # Im K_0 never shows
        return out.reshape(-1, 4)
    tensor = local_polynomials(local, order).reshape(len(local), channels, -1)  # (m, channel, ij)
    if rep.points is not None:
        tensor[:, :3] += rep.points.polynomials(order).reshape(n * n, 3, -1)[chosen]
    if weights is not None:
        rows = np.einsum("c,mct->mt", weights, tensor).reshape(len(local), order + 1, order + 1)
        padded = np.zeros((len(local), order + 1, _row_texels(order) * 4))
        padded[:, :, : order + 1] = rows
        return _scalars(padded.reshape(len(local), -1))
    return _padded(tensor.transpose(0, 2, 1))  # (m, ij, channel)


def uses_harmonic(rep: Representation) -> bool:
    """Whether the shader takes ``rep``'s far field in harmonic form: when it has no diffusion points."""
    return rep.points is None


@dataclass(frozen=True)
class SegmentTable:
    """Every fine cell's near segments (its 3x3 block's) as shader texels.

    Attributes
    ----------
    texels : numpy.ndarray
        ``(3 * entries, 4)`` float32: per entry ``(p - centre, q - centre)``, ``(E, length)``, ``(C, 0)``; of a
        scalar field ``(2 * entries, 4)``, ``(p - centre, q - centre)``, ``(E, C, length, 0)``.
    cell_start : numpy.ndarray
        ``(4^L + 1,)`` int32 CSR offsets: cell ``c`` lists entries ``cell_start[c]:cell_start[c + 1]``.
    segments : numpy.ndarray
        ``(entries,)`` the representation's index of each entry's segment.
    weights : numpy.ndarray or None
        A scalar field's channel weights.
    channels : int
        Of a colour table: 3, or 4 with the alpha field's (``(E, E_alpha)``, ``(C, C_alpha)``, no length).
    """

    texels: np.ndarray
    cell_start: np.ndarray
    segments: np.ndarray
    weights: np.ndarray | None = None
    channels: int = 3


#: Entries ``refill`` gathers at a time: its temporaries (a megabyte) come from the heap, where freed blocks are
#: used again, not from fresh pages (``engine.memory.OWN_PAGES``), which cost 2-3 ms a MB on a virtual machine.
REFILL_CHUNK = 65536


def block_lists(cell_start: np.ndarray, cells_per_side: int) -> tuple[np.ndarray, np.ndarray]:
    """Every cell's 3x3 block of segments, as CSR lists.

    Parameters
    ----------
    cell_start : numpy.ndarray
        ``(n^2 + 1,)`` offsets of each cell's own (cell-sorted) segments.
    cells_per_side : int

    Returns
    -------
    block_start : numpy.ndarray
        ``(n^2 + 1,)`` int64 offsets into ``members``.
    members : numpy.ndarray
        Segment indices, each cell's block in turn (rows of the block, each row's cells left to right).
    """
    n = cells_per_side
    cell_start = np.asarray(cell_start, np.int64)
    rows, columns = np.divmod(np.arange(n * n), n)
    # one run per (cell, block row): the row's up to 3 cells are contiguous in cell order
    run_start = np.empty((n * n, 3), np.int64)
    run_count = np.zeros((n * n, 3), np.int64)
    first, last = np.maximum(columns - 1, 0), np.minimum(columns + 2, n)
    for k, dy in enumerate((-1, 0, 1)):
        row = rows + dy
        valid = (row >= 0) & (row < n)
        safe = np.clip(row, 0, n - 1) * n
        run_start[:, k] = cell_start[safe + first]
        run_count[:, k] = np.where(valid, cell_start[safe + last] - cell_start[safe + first], 0)
    counts_flat = run_count.ravel()
    block_start = np.concatenate([[0], np.cumsum(run_count.sum(axis=1))])
    total = int(block_start[-1])
    run_offset = np.repeat(np.cumsum(counts_flat) - counts_flat, counts_flat)
    members = np.repeat(run_start.ravel(), counts_flat) + np.arange(total) - run_offset
    return block_start, members


def segment_table(rep: Representation, flux: np.ndarray | None = None, jump: np.ndarray | None = None,
                  keep: np.ndarray | None = None, weights: np.ndarray | None = None,
                  alpha: Representation | None = None) -> SegmentTable:
    """Each cell's near segments (``rep.near``), with end points relative to that cell's centre.

    A segment is listed in every cell of the 3x3 block around its own (up to
    9 times), so the shader reads one list per pixel, in small coordinates.

    Parameters
    ----------
    rep : Representation
    flux, jump : numpy.ndarray, optional
        ``(segments, 3)`` values to put in place of the segments' E and C (their changes, say).
    keep : numpy.ndarray, optional
        ``(segments,)`` bool: list only these.
    weights : numpy.ndarray, optional
        ``(3,)``: the table of the scalar field ``weights . colour``.
    alpha : Representation, optional
        The layer's alpha field, of the same near segments: E and C get its first channel's in a fourth
        (``flux`` and ``jump``, when given, hold four columns).
    """
    (seg, cell_start), lattice = rep.near, rep.lattice
    n, size = lattice.cells_per_side, lattice.cell_size
    flux = (seg.flux if alpha is None else with_alpha(seg.flux, alpha.near[0].flux)) if flux is None else flux
    jump = (seg.jump if alpha is None else with_alpha(seg.jump, alpha.near[0].jump)) if jump is None else jump
    cell_start = np.asarray(cell_start, np.int64)
    index = np.arange(len(seg.p))
    if keep is not None:
        index = index[keep]
        own = np.repeat(np.arange(n * n), np.diff(cell_start))[keep]
        cell_start = np.concatenate([[0], np.cumsum(np.bincount(own, minlength=n * n))])
    block_start, members = block_lists(cell_start, n)
    members = index[members]
    cell = np.repeat(np.arange(n * n), np.diff(block_start))
    centre = np.stack([cell % n + 0.5, cell // n + 0.5], axis=1) * size
    p, q = seg.p[members], seg.q[members]
    table = np.zeros((len(members), 2 if weights is not None else 3, 4), np.float32)
    table[:, 0, 0:2] = p - centre
    table[:, 0, 2:4] = q - centre
    out = SegmentTable(table.reshape(-1, 4), _int32(block_start), members, weights, flux.shape[1])
    refill(out, flux, jump)
    if out.channels == 3:
        table[:, 1, 2 if weights is not None else 3] = np.hypot(*(q - p).T)
    return out


def refill(table: SegmentTable, flux: np.ndarray, jump: np.ndarray) -> None:
    """Put ``flux`` and ``jump`` ``(segments, table.channels)`` in place of the E and C of a table of segments with
    the same geometry and cells (its entries' segments), in place and ``REFILL_CHUNK`` entries at a time."""
    if table.weights is not None:  # cast and weigh the few, then gather the many
        values = np.stack([flux @ table.weights, jump @ table.weights], axis=1).astype(np.float32)
        texels = table.texels.reshape(-1, 2, 4)
        for start in range(0, len(texels), REFILL_CHUNK):
            texels[start : start + REFILL_CHUNK, 1, 0:2] = values[table.segments[start : start + REFILL_CHUNK]]
        return
    texels = table.texels.reshape(-1, 3, 4)
    flux, jump = np.asarray(flux, np.float32), np.asarray(jump, np.float32)
    channels = table.channels
    for start in range(0, len(texels), REFILL_CHUNK):
        members = table.segments[start : start + REFILL_CHUNK]
        texels[start : start + REFILL_CHUNK, 1, 0:channels] = flux[members]
        texels[start : start + REFILL_CHUNK, 2, 0:channels] = jump[members]


@dataclass(frozen=True)
class PointTable:
    """Near points as shader texels.

    Attributes
    ----------
    texels : numpy.ndarray
        ``(2 * points, 4)`` float32 (``(points, 4)`` for a scalar field).
    start : numpy.ndarray
        ``(4^L + 1,)`` int32 CSR offsets into ``members``.
    members : numpy.ndarray
        ``(entries,)`` int32 point indices.
    """

    texels: np.ndarray
    start: np.ndarray
    members: np.ndarray


def point_table(rep: Representation, weights: np.ndarray | None = None) -> PointTable:
    """The representation's near points (none without points); of the scalar field ``weights . colour``."""
    n = rep.lattice.cells_per_side
    if rep.points is None or len(rep.points.near) == 0:
        return PointTable(np.zeros((0, 4), np.float32), np.zeros(n * n + 1, np.int32), np.zeros(0, np.int32))
    near = rep.points.near
    p = near.points
    table = np.zeros((len(near), 1 if weights is not None else 2, 4), np.float32)
    table[:, 0, 0:2] = p.positions
    table[:, 0, 2] = 1.0 / p.radii**2
    if weights is not None:
        table[:, 0, 3] = p.weights @ weights
    else:
        table[:, 1, 0:3] = p.weights
    return PointTable(table.reshape(-1, 4), _int32(near.cell_start), _int32(near.members))


def _int32(values: np.ndarray) -> np.ndarray:
    values = np.asarray(values)
    if len(values) and values.max(initial=0) >= 2**31:
        raise ValueError("too many entries for the shader's 32-bit indices")
    return np.ascontiguousarray(values, np.int32)


def cell_runs(cells: np.ndarray, max_runs: int = 64) -> list[tuple[int, int]]:
    """Sorted flat cell indices as ``[start, stop)`` runs of consecutive cells.

    More than ``max_runs`` runs are merged into the one span from the first to
    the last (one larger upload beats many small ones).
    """
    cells = np.asarray(cells, np.int64)
    if len(cells) == 0:
        return []
    breaks = np.flatnonzero(np.diff(cells) != 1) + 1
    starts = np.concatenate([[0], breaks])
    stops = np.concatenate([breaks, [len(cells)]])
    if len(starts) > max_runs:
        return [(int(cells[0]), int(cells[-1]) + 1)]
    return [(int(cells[a]), int(cells[b - 1]) + 1) for a, b in zip(starts, stops)]
