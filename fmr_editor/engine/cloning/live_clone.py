"""A clone layer's fields kept up to date as its clone moves and the picture below it changes."""

from __future__ import annotations

import numpy as np

from ...model.clone import Clone
from ..composite import Composite, Role
from ..representation import Representation, Settings
from ..solve.clone import ClonedRegion, SeamlessClone
from .layer import CopiedCells, clone_layer, clone_points, layer_lattice, ring_cells

#: Factorisations kept for the placements of one clone: a drag back from the canvas edge or across a step of scale
#: and back finds its own (each holds two dense matrices of Gamma's size: 16 MB for 1,000 segments).
KEPT_REGIONS = 3


class LiveClone:
    """A clone layer's image and mask, made anew when the clone moves or the picture below it changes.

    Parameters
    ----------
    clone : Clone
        What the layer shows, as the fields are made for.
    image, mask : Representation, optional
        The fields as saved (``io.load_fmr``): taken as they are, for ``clone``.

    Moving, turning or scaling a clone keeps the factorisation on its
    boundary (``SeamlessClone.placed``; not when the canvas edge cuts the
    region, nor when the scale leaves its step): re-placing it costs the
    picture below at the boundary, one back-substitution and the expansion
    of the layer's segments into cells.  When only the picture below
    changed, the copied segments' cells are kept too (``CopiedCells``).
    """

    def __init__(self, clone: Clone, image: Representation | None = None, mask: Representation | None = None) -> None:
        self.clone, self.image, self.mask = clone, image, mask
        self._seamless: SeamlessClone | None = None
        self._made_for: tuple | None = None  # (source segments, source, (region, canvas)) of _seamless
        self._regions: list[ClonedRegion] = []  # factorisations of recent placements, newest first
        self._copied: CopiedCells | None = None  # of _seamless
        self._points: tuple = ()  # the diffusion points copied into the image

    def follow(self, clone: Clone, source: Representation, below: Composite, settings: Settings,
               layer_id: int) -> dict[Role, np.ndarray] | None:
        """Make the fields for ``clone`` (its source's representation ``source``) over ``below``.

        Returns
        -------
        dict or None
            By ``Role.IMAGE`` and ``Role.MASK``, ``(2^L, 2^L)`` bool: the fine cells
            where the field may differ from the last one (the image: the cells
            of both regions; the mask: where only one of them lies, and the
            rings around both boundaries, since it is 1 inside a region to
            the expansions' accuracy); None for all cells.
        """
        canvas = (below.width, below.height)
        before = self._copied  # the cells of the fields shown now (None: not made here)
        seamless = self._seamless_for(clone, source, canvas)
        if self._copied is None:
            self._copied = CopiedCells.build(seamless, layer_lattice(seamless, below, settings), settings)
        points = clone_points(clone, *canvas)
        fields = clone_layer(seamless, below, settings, layer_id, placed=points, copied=self._copied)
        comparable = before is not None and before.lattice == self._copied.lattice and not (points or self._points)
        self.clone, self.image, self.mask, self._points = clone, fields.image, fields.mask, points
        if not comparable:  # another lattice, or points, which reach beyond the cells
            return None
        now, rings = self._copied, ring_cells(before.gamma, before.lattice) | ring_cells(self._copied.gamma,
                                                                                          before.lattice)
        return {Role.IMAGE: before.cells | now.cells, Role.MASK: (before.cells ^ now.cells) | rings}

    def _seamless_for(self, clone: Clone, source: Representation, canvas: tuple[int, int]) -> SeamlessClone:
        """The clone placed on ``canvas``: the last one if nothing moved, through a kept factorisation if one fits."""
        made = self._made_for
        same = (made is not None and made[0] is source.segments and made[1] is clone.source
                and made[2] == (clone.region, canvas))
        if same and self._seamless is not None and self.clone.similarity == clone.similarity:
            return self._seamless  # the picture below changed: the copied cells stay
        if not same:
            self._regions = []
        seamless = SeamlessClone(source.segments, np.asarray(clone.region), clone.similarity, canvas=canvas,
                                 kept=tuple(self._regions))
        if not seamless.cut and seamless.cloned not in self._regions:  # a cut shape serves its placement only
            self._regions = [seamless.cloned] + self._regions[:KEPT_REGIONS - 1]
        self._seamless, self._made_for, self._copied = seamless, (source.segments, clone.source,
                                                                  (clone.region, canvas)), None
        return seamless
