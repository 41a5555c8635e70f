"""Seamless clones as layers of a composite: their image and mask as representations, no solve of either.

``clone_layer`` places a region of a source image into the picture below it
(``solve.clone.SeamlessClone``, with the target's colours read from that
picture at the region's boundary) and hands back the ``LayerFields`` to put
on top: the image is the clone layer's segments (the copied source segments
and the boundary with its solved ``E``, and the source's diffusion points
that reach the region), the mask the indicator of the region (its boundary
with ``C = 1`` and ``E = 0``, a sharp mask).  Composed, the picture is the
target outside the region and ``g + h`` inside (``layer``).  ``LiveClone``
keeps one up to date as the clone moves and the picture below changes
(``live_clone``).
"""

from .layer import CopiedCells, clone_layer, clone_points, placed_points, region_cells
from .live_clone import LiveClone

__all__ = ["CopiedCells", "LiveClone", "clone_layer", "clone_points", "placed_points", "region_cells"]
