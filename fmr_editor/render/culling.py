"""Where each layer of a layered picture shows, cell by cell, so that the canvas evaluates and composes only there.

A layer's weight ``m = clamp(a, 0, 1) opacity clamp(M, 0, 1)`` (``engine.composite``) is snapped to 0 or 1
within ``NEGLIGIBLE_WEIGHT``.  Over a cell, a mask's and an alpha's values lie within their far field's
``bounds.value_bounds`` and what their segments and near points may add (``bounds.near_bounds``) of the cell's
centre value, and so does the weight, interval by interval.  Where that interval is surely 0 the layer leaves
the picture as it was; where a layer above surely weighs 1 it replaces what lies below.  There the layer is
hidden: its image, mask and alpha need not be evaluated and its compose pass leaves the cell out; where its own
weight is surely 1, its mask and alpha need not be evaluated either (the pass replaces what lies below).  The
composed pixels are the same as when everything is evaluated.  ``MARGIN`` keeps the decision clear of the
snapping thresholds by more than the shader's float32 rounding of a weight.

Cells are those of the finest lattice among the picture's fields: every lattice of one picture has the
canvas's side, so a coarser cell is a block of fine ones.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..engine import NEGLIGIBLE_WEIGHT, FieldKey, LayerFields, Role
from ..model.layer import MASK_LUMA

#: What a weight's bounds must clear the snapping thresholds by (the shader's float32 weight may differ from
#: the exact one by some 1e-7).
MARGIN = 1e-6

#: ``(centre, spread)`` of a field's values over each of its cells, ``(cells^2, 3)`` each, or ``(cells^2, 1)`` for the
#: scalar field a renderer keeps of a mask's luminance or an alpha's first channel (``CanvasData.value_bounds``).
ValueBounds = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True, eq=False)
class CullPlan:
    """Where each layer shows, on the finest lattice of the picture.

    Attributes
    ----------
    cells : int
        Cells per side of that lattice.
    cell_size : float
        Their side, document pixels.
    shown : dict
        ``(cells, cells)`` bool by layer id: where the layer may show; None where it may show everywhere.
    whole : dict
        ``(cells, cells)`` bool by layer id: where it shows with weight 1 (part of ``shown``).
    """

    cells: int
    cell_size: float
    shown: dict[int, np.ndarray | None]
    whole: dict[int, np.ndarray]

    def needed(self, key: FieldKey, cells: int) -> np.ndarray | None:
        """The cells of a ``cells``-per-side lattice where field ``key`` is read: ``(cells, cells)`` bool; None
        for all of them (or a layer the plan does not hold).  An image is read where its layer shows, a mask
        or an alpha there but where its weight is 1."""
        layer_id, role = key
        if layer_id not in self.shown:
            return None
        read = self.shown[layer_id]
        if role is not Role.IMAGE:
            read = ~self.whole[layer_id] if read is None else read & ~self.whole[layer_id]
        if read is None or read.all():
            return None
        block = self.cells // cells
        return read.reshape(cells, block, cells, block).any(axis=(1, 3))

    def changed(self, other: CullPlan) -> np.ndarray | None:
        """``(cells, cells)`` bool: where some layer shows in one plan and not in ``other``; None: nowhere
        (all: another lattice or other layers)."""
        everywhere = np.ones((self.cells, self.cells), bool)
        if other.cells != self.cells or other.shown.keys() != self.shown.keys():
            return everywhere
        differ = np.zeros((self.cells, self.cells), bool)
        for layer_id, shown in self.shown.items():
            before = other.shown[layer_id]
            if shown is not before:
                differ |= (everywhere if shown is None else shown) != (everywhere if before is None else before)
        return differ if differ.any() else None


def plan(layers: tuple[LayerFields, ...], value_bounds: Callable[[FieldKey], ValueBounds],
         unbounded: frozenset[FieldKey] = frozenset()) -> CullPlan | None:
    """Where each of ``layers`` (a picture's shown layers, bottom first) may show.

    ``value_bounds(key)`` gives the bounds of a mask or alpha field; the fields of ``unbounded`` are taken as
    unknown (a blurred layer's alpha).  None when the fields' lattices do not nest (no culling).
    """
    reps = [rep for layer in layers for _, rep in layer.read]
    if not reps or len({rep.lattice.cells_per_side * rep.lattice.cell_size for rep in reps}) != 1:
        return None
    finest = max((rep.lattice for rep in reps), key=lambda lattice: lattice.cells_per_side)
    cells = finest.cells_per_side
    covered = np.zeros((cells, cells), bool)
    shown: dict[int, np.ndarray] = {}
    whole: dict[int, np.ndarray] = {}
    for index in range(len(layers) - 1, -1, -1):
        layer = layers[index]
        if index == 0 and layer.covers:
            low = high = 1.0
        else:
            low, high = _weight_range(layer, lambda role, layer=layer: _range(layer, role, value_bounds, unbounded,
                                                                            cells))
        shown[layer.id] = ~(covered | (high <= NEGLIGIBLE_WEIGHT - MARGIN))
        one = np.broadcast_to(low >= 1.0 - NEGLIGIBLE_WEIGHT + MARGIN, covered.shape)
        whole[layer.id] = shown[layer.id] & one
        covered = covered | one
    return CullPlan(cells, finest.cell_size, {key: None if value.all() else value for key, value in shown.items()},
                    whole)


def _weight_range(layer: LayerFields, values: Callable[[Role], tuple[np.ndarray, np.ndarray] | None]
                 ) -> tuple[np.ndarray | float, np.ndarray | float]:
    """Lowest and highest weight of ``layer`` (before snapping) from ``values(role)``, the lowest and highest
    values of its mask's luminance or its alpha's first channel (None: unknown)."""
    low = high = layer.opacity
    if layer.mask_enabled:
        mask_low = mask_high = layer.mask_base
        if layer.masked:
            mask = values(Role.MASK)
            mask_low, mask_high = (-np.inf, np.inf) if mask is None else mask
            mask_low, mask_high = mask_low + layer.mask_base, mask_high + layer.mask_base
        if layer.mask_inverted:
            mask_low, mask_high = 1.0 - mask_high, 1.0 - mask_low
        low, high = low * np.clip(mask_low, 0.0, 1.0), high * np.clip(mask_high, 0.0, 1.0)
    if layer.alpha is not None:
        alpha = values(Role.ALPHA)
        alpha_low, alpha_high = (0.0, 1.0) if alpha is None else alpha
        low, high = low * np.clip(alpha_low, 0.0, 1.0), high * np.clip(alpha_high, 0.0, 1.0)
    return low, high


def _range(layer: LayerFields, role: Role, value_bounds: Callable[[FieldKey], ValueBounds],
           unbounded: frozenset[FieldKey], cells: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Lowest and highest value of ``layer``'s mask luminance or alpha on each of ``cells`` per side."""
    key = (layer.id, role)
    if key in unbounded:
        return None
    centre, spread = value_bounds(key)
    if role is Role.MASK and centre.shape[1] == 3:
        centre, spread = centre @ MASK_LUMA, spread @ MASK_LUMA
    else:  # the alpha's first channel, or the field of that or of the mask's luminance alone
        centre, spread = centre[:, 0], spread[:, 0]
    rep = layer.mask if role is Role.MASK else layer.alpha
    own = rep.lattice.cells_per_side
    block = cells // own
    return tuple(np.repeat(np.repeat((centre + sign * spread).reshape(own, own), block, 0), block, 1)
                 for sign in (-1.0, 1.0))
