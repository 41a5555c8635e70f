"""A document's diffusion points on the representation's lattice.

Points wide enough for a fine cell go into a tensor of cell polynomials
(``gauss_tensor``, the fast Gauss transform), laid out like
``Representation.polynomials`` so the raster adds the two; smaller ones stay
exact near points (``gauss_near``).  ``gauss.gaussian_sum_reference`` is the
plain reference the tests compare against.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import DiffusionPoint
from .gauss import GaussPoints, PointSettings
from .gauss_near import NearPoints, near_at, near_grid, near_points, polynomials_at
from .gauss_tensor import point_polynomials
from .lattice import Lattice

#: Points refine the lattice down to cells of this size (pixels) at most: points
#: narrower than about 1.3 cells are summed exactly instead.
POINT_CELL_SIZE = 8.0


def point_levels(points: tuple[DiffusionPoint, ...], side: float, max_levels: int) -> int:
    """The lattice depth points ask for: cells no wider than the median radius, nor than ``POINT_CELL_SIZE``."""
    if not points:
        return 2
    target = max(POINT_CELL_SIZE, float(np.median([point.radius for point in points])))
    levels = int(np.ceil(np.log2(side / target)))
    return int(np.clip(levels, 2, max_levels))


@dataclass(frozen=True, eq=False)
class PointField:
    """Diffusion points as cell polynomials plus exact near points.

    Attributes
    ----------
    points : GaussPoints
        All the document's points, packed.
    tensor : numpy.ndarray
        ``(2^L, 2^L, 3, P + 1, P + 1)`` coefficients of ``xi^i eta^j``.
    near : NearPoints
        The points too narrow for the polynomials.
    """

    points: GaussPoints
    tensor: np.ndarray
    near: NearPoints

    @classmethod
    def build(cls, points: tuple[DiffusionPoint, ...], lattice: Lattice, order: int) -> PointField:
        """Expand ``points`` on ``lattice`` with polynomials of degree ``order`` per axis."""
        packed = GaussPoints.from_points(points)
        settings = PointSettings(order=order)
        return cls(packed, point_polynomials(packed, lattice, settings), near_points(packed, lattice, settings))

    def polynomials(self, order: int) -> np.ndarray:
        """The tensor at degree ``order``: zero-padded above its own, truncated (less accurate) below."""
        own = self.tensor.shape[-1] - 1
        if order <= own:
            return self.tensor[..., : order + 1, : order + 1]
        pad = order - own
        return np.pad(self.tensor, [(0, 0)] * 3 + [(0, pad), (0, pad)])

    def add_near_grid(self, xs: np.ndarray, ys: np.ndarray, out: np.ndarray) -> None:
        """Add the near points' exact sum on the grid ``ys x xs`` to ``out``."""
        near_grid(self.near, xs, ys, out=out)

    def at(self, targets: np.ndarray, order: int) -> np.ndarray:
        """The points' field at ``targets (m, 2)``, ``(m, 3)``."""
        return polynomials_at(self.polynomials(order), targets, self.near.lattice.cell_size) + near_at(self.near, targets)
