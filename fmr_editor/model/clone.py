"""A clone layer's recipe: a region of a source image, placed into the picture by a similarity (docs/design.md sec. 6).

A clone layer holds no curves of its own: it holds what was copied (the
source layer's items on the source's canvas, and the region in source
pixels) and where it goes (``Similarity``).  The engine makes its image and
its mask from these and from the picture below it, so the clone blends in
anew whenever the layers below change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import shapely

from .refusals import EditRefused

if TYPE_CHECKING:
    from .document import Document

#: Most vertices a clone region may have.
MAX_REGION = 20_000


def region_on_canvas(region, width: float | None = None, height: float | None = None) -> np.ndarray:
    """The part of ``region`` on a ``width x height`` canvas: ``(k, 2)`` vertices of a simple polygon of
    positive area (``region`` itself, as an array, when it lies wholly on the canvas or no canvas is given).

    Raises
    ------
    EditRefused
        For fewer than three finite vertices, a polygon that crosses itself
        or has no area, one wholly outside the canvas, or one the canvas edge
        splits in two.
    """
    points = np.asarray(region, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 3 or not np.isfinite(points).all():
        raise EditRefused("a region needs at least three finite (x, y) corners")
    polygon = shapely.Polygon(points)
    if not polygon.is_valid or polygon.area <= 0:
        raise EditRefused("a region must be a simple polygon of positive area: it crosses itself or has no area")
    if width is None or height is None:
        return points
    frame = shapely.box(0.0, 0.0, width, height)
    if polygon.within(frame):
        return points
    part = shapely.intersection(polygon, frame)
    if part.is_empty or part.area <= 0:
        raise EditRefused("the region lies wholly outside the canvas")
    if part.geom_type != "Polygon":
        raise EditRefused("the canvas edge splits the region in two; move it further in or out")
    return np.asarray(part.exterior.coords)[:-1]


@dataclass(frozen=True)
class Similarity:
    """``x -> scale R(degrees) M x + offset`` (``M`` mirrors x when ``mirror``), in document pixels."""

    scale: float = 1.0
    degrees: float = 0.0
    offset: tuple[float, float] = (0.0, 0.0)
    mirror: bool = False

    def __post_init__(self) -> None:
        offset = tuple(float(v) for v in self.offset)
        if not (math.isfinite(self.scale) and self.scale > 0 and math.isfinite(self.degrees) and len(offset) == 2
                and all(map(math.isfinite, offset))):
            raise EditRefused("a similarity needs a positive scale and finite angle and offset")
        object.__setattr__(self, "scale", float(self.scale))
        object.__setattr__(self, "degrees", float(self.degrees))
        object.__setattr__(self, "offset", offset)
        object.__setattr__(self, "mirror", bool(self.mirror))

    @property
    def matrix(self) -> np.ndarray:
        c, s = math.cos(math.radians(self.degrees)), math.sin(math.radians(self.degrees))
        flip = np.diag([-1.0, 1.0]) if self.mirror else np.eye(2)
        return self.scale * np.array([[c, -s], [s, c]]) @ flip

    def apply(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points, dtype=np.float64) @ self.matrix.T + np.asarray(self.offset)

    def inverse(self, points: np.ndarray) -> np.ndarray:
        return (np.asarray(points, dtype=np.float64) - np.asarray(self.offset)) @ np.linalg.inv(self.matrix).T

    def moved(self, dx: float, dy: float) -> Similarity:
        return replace(self, offset=(self.offset[0] + dx, self.offset[1] + dy))

    def about(self, centre, scale: float = 1.0, degrees: float = 0.0) -> Similarity:
        """This similarity followed by scaling by ``scale`` and turning by ``degrees`` about ``centre``."""
        turn = Similarity(scale, degrees)
        centre = np.asarray(centre, dtype=np.float64)
        shift = centre - turn.apply(centre[None])[0]
        return Similarity(self.scale * scale, self.degrees + degrees,
                          tuple(turn.apply(np.asarray(self.offset)[None])[0] + shift), self.mirror)


@dataclass(frozen=True)
class Clone:
    """What a clone layer shows: ``region`` of ``source`` placed by ``similarity``, blended seamlessly.

    Parameters
    ----------
    source : Document
        One plain layer on the source's canvas: the copied layer's curves
        and points (all of them: the field inside the region depends on
        everything).
    region : tuple of (float, float)
        A simple polygon in source pixels.
    similarity : Similarity
        From source pixels to the document's.
    """

    source: Document
    region: tuple[tuple[float, float], ...]
    similarity: Similarity = Similarity()

    def __post_init__(self) -> None:
        from .document import Document

        if not isinstance(self.source, Document) or not self.source.is_flat:
            raise TypeError("a clone's source must be a document of one plain layer")
        region = np.asarray(self.region, dtype=np.float64)
        if region.ndim != 2 or region.shape[1] != 2 or not 3 <= len(region) <= MAX_REGION:
            raise ValueError(f"a clone region must be a polygon of 3 to {MAX_REGION} (x, y) vertices")
        if not np.isfinite(region).all():
            raise ValueError("a clone region's vertices must be finite")
        if not isinstance(self.similarity, Similarity):
            raise TypeError("a clone's similarity must be a Similarity")
        object.__setattr__(self, "region", tuple(map(tuple, region.tolist())))

    @property
    def placed_region(self) -> np.ndarray:
        """The region in document pixels, ``(k, 2)``."""
        return self.similarity.apply(np.asarray(self.region))

    def moved(self, dx: float, dy: float) -> Clone:
        """The same clone ``(dx, dy)`` further (the source and region kept, by identity)."""
        return replace(self, similarity=self.similarity.moved(dx, dy))
