"""A representation as the flat float32/int32 tables the canvas shader reads (numpy only, no GL).

Layouts (``shaders/canvas.frag`` reads them):

- **coefficients**: ``texels(order, harmonic)`` RGBA texels per fine cell, cells row-major.
  Harmonic form (documents without points): ``K_l = L_l / 2pi`` of the local
  expansion, ``u = Re sum_l K_l (xi + i eta)^l``, packed per ``l`` as Re r, g, b
  then Im r, g, b.  Tensor form: ``Representation.polynomials()``'s ``c[i, j]``
  (r, g, b) of ``xi^i eta^j``, packed per ``(i, j)``.  Zero-padded to whole texels.
- **segments**: 3 texels each, in the representation's (cell-sorted) order:
  ``(p - centre, q - centre)``, ``(E, length)``, ``(C, 0)``, with ``centre``
  the centre of the segment's own fine cell, so the shader works in small
  coordinates; plus the CSR offsets ``cell_start`` as int32.
- **near points**: 2 texels each, ``(x, y, 1 / r^2, 0)``, ``(weight, 0)``,
  and their per-cell CSR lists (``start``, ``members``) as int32.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..engine import Representation
from ..engine.expansions import harmonic_to_polynomial

TWO_PI = 2.0 * np.pi


def texels(order: int, harmonic: bool) -> int:
    """RGBA texels per cell of the coefficient table."""
    floats = 6 * (order + 1) if harmonic else 3 * (order + 1) ** 2
    return -(-floats // 4)


@lru_cache(maxsize=8)
def _real_mapping(order: int) -> np.ndarray:
    """``(2 (P + 1), (P + 1)^2)`` real map from (Re L, Im L) to tensor coefficients, as in ``Representation.polynomials``."""
    mapping = harmonic_to_polynomial(order).reshape(order + 1, -1)
    real = np.concatenate([mapping.real, -mapping.imag]) / TWO_PI
    real.flags.writeable = False
    return real


def _padded(values: np.ndarray, per_cell: int) -> np.ndarray:
    """``(m, floats)`` float64 to ``(m * per_cell, 4)`` float32 texels, zero-padded."""
    out = np.zeros((values.shape[0], per_cell * 4), np.float32)
    out[:, : values.shape[1]] = values
    return out.reshape(-1, 4)


def cell_coefficients(rep: Representation, cells: np.ndarray | None = None, harmonic: bool | None = None,
                      polynomials: np.ndarray | None = None) -> np.ndarray:
    """Coefficient texels of ``cells`` (flat indices, default all), ``(len(cells) * texels, 4)`` float32.

    Parameters
    ----------
    rep : Representation
    cells : numpy.ndarray, optional
        Flat fine-cell indices ``row * 2^L + column``.
    harmonic : bool, optional
        The harmonic form; defaults to ``uses_harmonic(rep)``.  Only for representations without points.
    polynomials : numpy.ndarray, optional
        ``rep.polynomials()`` (a copy of it, say, made where ``rep`` is updated): taken instead of
        ``rep``'s expansions, which a live representation changes in place.
    """
    harmonic = uses_harmonic(rep) if harmonic is None else harmonic
    if harmonic and rep.points is not None:
        raise ValueError("the harmonic form has no room for diffusion points")
    order = rep.order
    n = rep.lattice.cells_per_side
    chosen = slice(None) if cells is None else np.asarray(cells, np.int64)
    if polynomials is not None:
        if polynomials.shape != (n, n, 3, order + 1, order + 1):
            raise ValueError(f"polynomials must be {(n, n, 3, order + 1, order + 1)}")
        tensor = polynomials.reshape(n * n, 3, order + 1, order + 1)[chosen]
        if harmonic:
            # c[l, 0] = Re K_l and c[l - 1, 1] = -l Im K_l (DESIGN 4: M[l, l - j, j] = binom(l, j) i^j)
            k = tensor[:, :, :, 0].astype(complex)
            k[:, :, 1:] -= 1j * tensor[:, :, np.arange(order), 1] / np.arange(1, order + 1)
            values = np.concatenate([k.real, k.imag], axis=1).transpose(0, 2, 1)
        else:
            values = tensor.reshape(len(tensor), 3, -1).transpose(0, 2, 1)
        return _padded(values.reshape(len(values), -1), texels(order, harmonic))
    local = rep.local.reshape(n * n, 3, -1)[chosen, :, : order + 1]  # a view until indexed
    if harmonic:
        k = local / TWO_PI  # (m, channel, l)
        k[:, :, 0] = k[:, :, 0].real  # Im K_0 never shows (u = Re ...)
        values = np.concatenate([k.real, k.imag], axis=1).transpose(0, 2, 1)  # (m, l, [re rgb, im rgb])
    else:
        tensor = np.concatenate([local.real, local.imag], axis=-1) @ _real_mapping(order)  # (m, channel, ij)
        if rep.points is not None:
            tensor += rep.points.polynomials(order).reshape(n * n, 3, -1)[chosen]
        values = tensor.transpose(0, 2, 1)  # (m, ij, channel)
    return _padded(values.reshape(len(values), -1), texels(order, harmonic))


def uses_harmonic(rep: Representation) -> bool:
    """Whether the shader takes ``rep``'s far field in harmonic form: when it has no diffusion points."""
    return rep.points is None


@dataclass(frozen=True)
class SegmentTable:
    """Segments as shader texels.

    Attributes
    ----------
    texels : numpy.ndarray
        ``(3 * segments, 4)`` float32.
    cell_start : numpy.ndarray
        ``(4^L + 1,)`` int32 CSR offsets.
    """

    texels: np.ndarray
    cell_start: np.ndarray


def segment_table(rep: Representation, flux: np.ndarray | None = None, jump: np.ndarray | None = None,
                  keep: np.ndarray | None = None) -> SegmentTable:
    """The representation's segments, end points relative to their own cell's centre.

    Parameters
    ----------
    rep : Representation
    flux, jump : numpy.ndarray, optional
        ``(segments, 3)`` values to put in place of the segments' E and C (their changes, say).
    keep : numpy.ndarray, optional
        ``(segments,)`` bool: list only these (the cell lists shrink accordingly).
    """
    seg, lattice = rep.segments, rep.lattice
    n, size = lattice.cells_per_side, lattice.cell_size
    own = np.repeat(np.arange(n * n), np.diff(rep.cell_start))
    flux = seg.flux if flux is None else flux
    jump = seg.jump if jump is None else jump
    p, q = seg.p, seg.q
    cell_start = rep.cell_start
    if keep is not None:
        own, p, q, flux, jump = own[keep], p[keep], q[keep], flux[keep], jump[keep]
        cell_start = np.concatenate([[0], np.cumsum(np.bincount(own, minlength=n * n))])
    centre = np.stack([own % n + 0.5, own // n + 0.5], axis=1) * size
    table = np.zeros((len(own), 3, 4), np.float32)
    table[:, 0, 0:2] = p - centre
    table[:, 0, 2:4] = q - centre
    table[:, 1, 0:3] = flux
    table[:, 1, 3] = np.hypot(*(q - p).T)
    table[:, 2, 0:3] = jump
    return SegmentTable(table.reshape(-1, 4), _int32(cell_start))


@dataclass(frozen=True)
class PointTable:
    """Near points as shader texels.

    Attributes
    ----------
    texels : numpy.ndarray
        ``(2 * points, 4)`` float32.
    start : numpy.ndarray
        ``(4^L + 1,)`` int32 CSR offsets into ``members``.
    members : numpy.ndarray
        ``(entries,)`` int32 point indices.
    """

    texels: np.ndarray
    start: np.ndarray
    members: np.ndarray


def point_table(rep: Representation) -> PointTable:
    """The representation's near points (none without points)."""
    n = rep.lattice.cells_per_side
    if rep.points is None or len(rep.points.near) == 0:
        return PointTable(np.zeros((0, 4), np.float32), np.zeros(n * n + 1, np.int32), np.zeros(0, np.int32))
    near = rep.points.near
    p = near.points
    table = np.zeros((len(near), 2, 4), np.float32)
    table[:, 0, 0:2] = p.positions
    table[:, 0, 2] = 1.0 / p.radii**2
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
