"""The downward pass of a change: M2L from the few cells whose multipoles changed.

An edit changes the multipoles of some fine cells and of their ancestors
only.  The FMR is linear in them, so the change of every local expansion is
the downward pass of the change; instead of one matrix product per offset
over a whole level (``lattice.downward_pass``, the reference), each offset
translates just the changed sources to the targets whose interaction list
holds them.  L2L stays a whole-level product: it is cheap.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .expansions import l2l_matrix, m2l_matrix
from .lattice import Lattice, _child_offset, coarser_multipoles, downward_pass, interaction_offsets

#: Share of fine cells changed above which the whole-level downward pass is used instead.
SPARSE_SOURCES = 0.05


@lru_cache(maxsize=None)
def offset_parities() -> tuple[tuple[int, int, np.ndarray], ...]:
    """Every M2L offset ``(dx, dy)`` with the ``(2, 2)`` mask of target parities ``[py, px]`` that use it."""
    masks: dict[tuple[int, int], np.ndarray] = {}
    for py in (0, 1):
        for px in (0, 1):
            for offset in interaction_offsets(px, py):
                masks.setdefault(offset, np.zeros((2, 2), bool))[py, px] = True
    return tuple((dx, dy, mask) for (dx, dy), mask in sorted(masks.items()))


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
    multipoles = coarser_multipoles(delta_fine, order)
    if np.any(delta_fine != 0, axis=(2, 3)).mean() > SPARSE_SOURCES:
        return downward_pass(multipoles, lattice, order)  # most cells changed: whole-level products are faster
    local = None
    for level in range(2, lattice.levels + 1):
        sources = multipoles[level]
        size = sources.shape[0]
        level_local = np.zeros_like(sources)
        if local is not None:
            for py in (0, 1):
                for px in (0, 1):
                    level_local[py::2, px::2] = local @ l2l_matrix(_child_offset(px, py), order)
        rows, columns = np.nonzero(np.any(sources != 0, axis=(2, 3)))
        if len(rows):
            log_size = float(np.log(lattice.level_size(level)))
            moments = sources[rows, columns]
            for dx, dy, mask in offset_parities():
                target_rows, target_columns = rows - dy, columns - dx
                keep = (target_rows >= 0) & (target_rows < size) & (target_columns >= 0) & (target_columns < size)
                keep[keep] = mask[target_rows[keep] % 2, target_columns[keep] % 2]
                if keep.any():
                    # each source reaches one target per offset: no repeated indices
                    level_local[target_rows[keep], target_columns[keep]] += (
                        moments[keep] @ m2l_matrix(complex(dx, dy), order, log_size)
                    )
        local = level_local
    return local
