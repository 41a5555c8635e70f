"""The downward pass of a change: M2L from the few cells whose multipoles changed.

An edit changes the multipoles of some fine cells and of their ancestors
only.  The FMR is linear in them, so the change of every local expansion is
the downward pass of the change; instead of one matrix product per offset
over a whole level (``lattice.downward_pass``, the reference), each changed
source is translated to the targets whose interaction list holds it (a
compiled loop), and M2M runs over the changed cells' parents only.  L2L stays
a whole-level product: it is cheap.
"""

from __future__ import annotations

from functools import lru_cache

import numba
import numpy as np

from .expansions import l2l_matrix, m2l_matrix, m2m_matrix
from .lattice import Lattice, child_offset, coarser_multipoles, downward_pass, interaction_offsets, times

#: Share of fine cells changed above which the whole-level passes are faster (measured at L = 6, 7).
SPARSE_SOURCES = 0.25


@lru_cache(maxsize=None)
def offset_parities() -> tuple[np.ndarray, np.ndarray]:
    """Every M2L offset ``(dx, dy)``, ``(k, 2)``, with the ``(k, 2, 2)`` masks of target parities ``[py, px]`` using it."""
    masks: dict[tuple[int, int], np.ndarray] = {}
    for py in (0, 1):
        for px in (0, 1):
            for offset in interaction_offsets(px, py):
                masks.setdefault(offset, np.zeros((2, 2), bool))[py, px] = True
    offsets = sorted(masks)
    return np.array(offsets, dtype=np.int64), np.array([masks[o] for o in offsets])


@numba.njit(cache=True)
def _sparse_m2l(rows, columns, moments, offsets, masks, matrices, out):
    size = out.shape[0]
    terms = out.shape[3]
    for s in range(rows.shape[0]):
        for o in range(offsets.shape[0]):
            tr, tc = rows[s] - offsets[o, 1], columns[s] - offsets[o, 0]
            if tr < 0 or tr >= size or tc < 0 or tc >= size or not masks[o, tr % 2, tc % 2]:
                continue
            for channel in range(moments.shape[1]):
                for k in range(terms):
                    a = moments[s, channel, k]
                    if a == 0:
                        continue
                    for l in range(terms):
                        out[tr, tc, channel, l] += a * matrices[o, k, l]


@lru_cache(maxsize=64)
def _m2l_matrices(order: int, log_size: float) -> np.ndarray:
    """``(k, P + 1, P + 1)`` M2L matrices of ``offset_parities()``'s offsets at one level."""
    return np.array([m2l_matrix(complex(dx, dy), order, log_size) for dx, dy in offset_parities()[0]])


def _sparse_parents(child: np.ndarray, rows: np.ndarray, columns: np.ndarray, order: int):
    """Multipoles of the parents of cells ``(rows, columns)`` of level ``child`` (M2M), on a zero level."""
    parent = np.zeros((child.shape[0] // 2,) * 2 + child.shape[2:], complex)
    pr, pc = np.unique(np.stack([rows // 2, columns // 2]), axis=1)
    for py in (0, 1):
        for px in (0, 1):
            parent[pr, pc] += times(child[2 * pr + py, 2 * pc + px], m2m_matrix(child_offset(px, py), order))
    return parent, pr, pc


def delta_local(delta_fine: np.ndarray, lattice: Lattice, order: int) -> np.ndarray:
    """Change of the fine local expansions for a change ``delta_fine`` of the fine multipoles.

    Parameters
    ----------
    delta_fine : numpy.ndarray
        ``(2^L, 2^L, 3, order + 1)`` complex, zero where nothing changed.
    lattice : Lattice
    order : int

    Returns
    -------
    numpy.ndarray
        ``(2^L, 2^L, 3, order + 1)`` complex; equals ``downward_pass`` of
        ``coarser_multipoles(delta_fine)`` up to rounding.
    """
    rows, columns = np.nonzero(np.any(delta_fine != 0, axis=(2, 3)))
    if len(rows) > SPARSE_SOURCES * delta_fine.shape[0] ** 2:
        return downward_pass(coarser_multipoles(delta_fine, order), lattice, order)  # most cells changed
    changed = [None] * (lattice.levels + 1)
    changed[lattice.levels] = delta_fine, rows, columns
    for level in range(lattice.levels, 2, -1):
        changed[level - 1] = _sparse_parents(*changed[level], order)
    offsets, masks = offset_parities()
    local = None
    for level in range(2, lattice.levels + 1):
        sources, rows, columns = changed[level]
        level_local = np.zeros_like(sources)
        if local is not None:
            for py in (0, 1):
                for px in (0, 1):
                    level_local[py::2, px::2] = times(local, l2l_matrix(child_offset(px, py), order))
        if len(rows):
            matrices = _m2l_matrices(order, float(np.log(lattice.level_size(level))))
            _sparse_m2l(rows, columns, np.ascontiguousarray(sources[rows, columns]), offsets, masks, matrices,
                        level_local)
        local = level_local
    return local
