"""Compiled per-cell multipole moments (P2M); ``expansions.multipole_moments_reference`` is the reference."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(parallel=True, cache=True)
def _cell_moments(occupied, rows, cell_start, centres, size, p, q, flux, jump, out):
    """``out[rows[c]] +=`` the moments of cell ``occupied[c]`` (centre ``centres[c]``)."""
    order = out.shape[2] - 1
    inverse = 1.0 / np.arange(1, order + 2)  # divisions cost: 1/k once
    for c in numba.prange(occupied.shape[0]):
        cell, row = occupied[c], rows[c]
        cx, cy = centres[c, 0], centres[c, 1]
        for j in range(cell_start[cell], cell_start[cell + 1]):
            zp = complex((p[j, 0] - cx) / size, (p[j, 1] - cy) / size)
            zq = complex((q[j, 0] - cx) / size, (q[j, 1] - cy) / size)
            d = complex(q[j, 0] - p[j, 0], q[j, 1] - p[j, 1])
            h = abs(d)
            reach = size * d.conjugate() / h  # size / tangent
            dipole = -1j * d / (h * size)  # normal / r
            power_p, power_q = zp, zq
            previous = complex(h, 0.0)  # int zeta^0 ds
            for ch in range(3):
                out[row, ch, 0] += flux[j, ch] * h
            for k in range(1, order + 1):
                power_p *= zp
                power_q *= zq
                integral = (power_q - power_p) * reach * inverse[k]
                weight = dipole * previous
                for ch in range(3):
                    out[row, ch, k] += -flux[j, ch] * inverse[k - 1] * integral + jump[j, ch] * weight
                previous = integral


def cell_moments(
    cell_start: np.ndarray, centres: np.ndarray, size: float,
    p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray, order: int,
    cells: np.ndarray | None = None,
) -> np.ndarray:
    """Scaled multipole moments of every fine cell (or of ``cells``), ``(len(centres), 3, order + 1)`` complex.

    Parameters
    ----------
    cell_start : numpy.ndarray
        CSR offsets of each cell's segments (segments sorted by cell).
    centres : numpy.ndarray
        ``(m, 2)`` centres of the cells wanted: every cell, or those of ``cells``.
    size : float
        Cell size r.
    p, q, flux, jump : numpy.ndarray
        Sorted segments and their E and C.
    order : int
    cells : numpy.ndarray, optional
        Indices (into ``cell_start``) of the cells wanted; default all.
    """
    out = np.zeros((len(centres), 3, order + 1), complex)
    wanted = np.arange(len(centres)) if cells is None else np.asarray(cells, np.int64)
    occupied = np.flatnonzero(cell_start[wanted + 1] > cell_start[wanted])  # positions in ``wanted``
    if len(occupied):
        sums = np.zeros((len(occupied), 3, order + 1), complex)
        _cell_moments(
            wanted[occupied], np.arange(len(occupied)), cell_start, np.ascontiguousarray(centres[occupied]),
            float(size), p, q, np.ascontiguousarray(flux), np.ascontiguousarray(jump), sums,
        )
        out[occupied] = sums
    return out


def fine_moments_into(cell_start: np.ndarray, cells: np.ndarray, centres: np.ndarray, size: float,
                      p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray, out: np.ndarray) -> None:
    """``cell_moments`` of the occupied ``cells`` (flat) added straight into ``out (cells of the level, 3, P + 1)``
    at their rows (no array of the occupied cells' moments on the side: 190 MB at L9, 524,288 pieces)."""
    cells = np.asarray(cells, np.int64)
    _cell_moments(cells, cells, cell_start, np.ascontiguousarray(centres), float(size), p, q,
                  np.ascontiguousarray(flux), np.ascontiguousarray(jump), out)
