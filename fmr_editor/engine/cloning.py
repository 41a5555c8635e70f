"""A seamless clone as a layer of a composite: its image and its mask as representations, no solve of either.

``clone_layer`` places a region of a source image into the picture below it
(``solve.clone.SeamlessClone``, with the target's colours read from that
picture at the region's boundary) and hands back the ``LayerFields`` to put
on top: the image is the clone layer's segments (the copied source segments
and the boundary with its solved ``E``, and the source's diffusion points
that reach the region), the mask the indicator of the region
(its boundary with ``C = 1`` and ``E = 0``, a sharp mask).  Both are expanded
into cells like any solved image (``explicit_representation``); composed, the
picture is the target outside the region and ``g + h`` inside.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import shapely

from ..model import DiffusionPoint
from ..model.clone import Clone, Similarity, region_on_canvas
from .composite import Composite, LayerFields
from .fmm.lattice import Lattice, fine_multipoles, sort_into_cells
from .fmm.sparse_downward import delta_local
from .geometry.discretise import cut_at_cells
from .geometry.segments import Segments
from .points.field import PointField
from .points.gauss import GaussPoints, gaussian_sum_reference
from .raster import evaluate_points
from .representation import Representation, Settings, choose_levels
from .solve.clone import SeamlessClone


def explicit_representation(width: int, height: int, segments: Segments, settings: Settings = Settings(),
                            deepest: int | None = None, points: tuple[DiffusionPoint, ...] = ()) -> Representation:
    """The FMR of segments whose ``C`` and ``E`` are known (no solve), on a ``width x height`` canvas.

    The segments must lie on the canvas: the lattice covers it, at most
    ``deepest`` levels deep (a clone's segments crowd into its region, where
    a finer lattice would cost more in the downward pass than it saves).
    ``points`` are added to the field as in any representation.
    """
    side = float(max(width, height))
    levels = settings.levels or choose_levels(segments, side)
    lattice = Lattice(min(levels, deepest or levels), side)
    order = settings.propagation_order
    sorted_segments, cell_start = sort_into_cells(cut_at_cells(segments, lattice.cell_size), lattice)
    local = delta_local(fine_multipoles(sorted_segments, cell_start, lattice, order), lattice, order)  # from the
    # occupied cells only: a clone's segments, and its mask's boundary even more, leave most cells empty
    field = PointField.build(tuple(points), lattice, settings.order) if points else None
    return Representation(width, height, lattice, sorted_segments, cell_start, local, settings.order, {}, field)


def _reaching(points: tuple[DiffusionPoint, ...], similarity: Similarity,
              region: np.ndarray) -> tuple[DiffusionPoint, ...]:
    """``points`` placed by ``similarity`` (radii scaled) whose blobs reach the placed ``region`` (to ``exp(-16)``)."""
    if not points:
        return ()
    packed = GaussPoints.from_points(points)
    positions, radii = similarity.apply(packed.positions), packed.radii * similarity.scale
    near = shapely.distance(shapely.Polygon(region), shapely.points(positions)) <= 4.0 * radii
    return tuple(replace(point, position=tuple(position), radius=float(radius), id=None)
                 for point, position, radius, keep in zip(points, positions, radii, near) if keep)


def placed_points(points: tuple[DiffusionPoint, ...], clone: SeamlessClone) -> tuple[DiffusionPoint, ...]:
    """The source ``points`` placed by the clone's similarity whose blobs reach its region."""
    return _reaching(points, clone.similarity, clone.region)


def clone_points(clone: Clone, width: int, height: int) -> tuple[DiffusionPoint, ...]:
    """The diffusion points of ``clone``'s layer on a ``width x height`` canvas: its source's points placed,
    those reaching its region on the canvas."""
    return _reaching(clone.source.points, clone.similarity, region_on_canvas(clone.placed_region, width, height))


def clone_layer(clone: SeamlessClone, below: Composite, settings: Settings = Settings(), layer_id: int = 0,
                points: tuple[DiffusionPoint, ...] = (), placed: tuple[DiffusionPoint, ...] | None = None,
                ) -> LayerFields:
    """The layer that puts ``clone`` seamlessly over ``below`` (its region cut to ``below``'s canvas).

    ``points`` are the source's diffusion points: those reaching the region are
    copied into the layer (placed, their radii scaled), their sum at the
    boundary taken off what the segments there must make.  ``placed`` gives
    the copied points instead (``clone_points``).
    """
    placed = placed_points(points, clone) if placed is None else placed
    target = evaluate_points(below, clone.midpoints)
    if placed:
        packed = GaussPoints.from_points(placed)
        target = target - gaussian_sum_reference(clone.midpoints, packed.positions, packed.radii, packed.weights)
    deepest = max((layer.image.lattice.levels for layer in below.layers), default=None)
    image = explicit_representation(below.width, below.height, clone.segments(target), settings, deepest, placed)
    n = len(clone.gamma_p)
    white = np.ones((n, 3))
    edge = Segments(clone.gamma_p, clone.gamma_q, white, 0.5 * white, np.zeros(n, bool), np.zeros((n, 3)))
    mask = explicit_representation(below.width, below.height, edge, settings, deepest)
    return LayerFields(image, mask, mask_base=0.0, id=layer_id)


class LiveClone:
    """A clone layer's image and mask, made anew when the clone moves or the picture below it changes.

    Parameters
    ----------
    clone : Clone
        What the layer shows, as the fields are made for.
    image, mask : Representation, optional
        The fields as saved (``io.load_fmr``): taken as they are, for ``clone``.

    Moving a clone keeps its ``SeamlessClone`` (the factorisation on its
    boundary): re-placing it costs the picture below at the boundary, one
    back-substitution and the expansion of the layer's segments into cells.
    """

    def __init__(self, clone: Clone, image: Representation | None = None, mask: Representation | None = None) -> None:
        self.clone, self.image, self.mask = clone, image, mask
        self._seamless: SeamlessClone | None = None
        self._made_from: tuple | None = None  # (source segments, clone, canvas) of _seamless

    def follow(self, clone: Clone, source: Representation, below: Composite, settings: Settings,
               layer_id: int) -> None:
        """Make the fields for ``clone`` (its source's representation ``source``) over ``below``."""
        seamless = self._seamless_for(clone, source, (below.width, below.height))
        placed = clone_points(clone, below.width, below.height)
        fields = clone_layer(seamless, below, settings, layer_id, placed=placed)
        self.clone, self.image, self.mask = clone, fields.image, fields.mask

    def _seamless_for(self, clone: Clone, source: Representation, canvas: tuple[int, int]) -> SeamlessClone:
        if self._made_from is not None:
            was_source, was, was_canvas = self._made_from
            same_shape = (was_source is source.segments and was.source is clone.source and was.region == clone.region
                          and was_canvas == canvas
                          and replace(was.similarity, offset=clone.similarity.offset) == clone.similarity)
            if same_shape:
                dx, dy = np.subtract(clone.similarity.offset, was.similarity.offset)
                try:
                    self._seamless = self._seamless.placed(dx, dy)
                    self._made_from = (source.segments, clone, canvas)
                    return self._seamless
                except ValueError:  # the canvas edge cuts the region: its shape changed
                    pass
        self._seamless = SeamlessClone(source.segments, np.asarray(clone.region), clone.similarity, canvas=canvas)
        self._made_from = (source.segments, clone, canvas)
        return self._seamless
