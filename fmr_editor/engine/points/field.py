"""A document's diffusion points on the representation's lattice.

Points wide enough for a fine cell go into a tensor of cell polynomials
(``tensor``, the fast Gauss transform), laid out like
``Representation.polynomials`` so the raster adds the two; smaller ones stay
exact near points (``near``).  ``gauss.gaussian_sum_reference`` is the
plain reference the tests compare against.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ...model import DiffusionPoint
from ..fmm.lattice import Lattice
from ..kernels.grid import far_field_grid
from .gauss import GaussPoints, PointSettings, changed_cells, cutoff_radii, expansion_ratios
from .increments import add_to_tensor
from .near import NearPoints, near_at, near_grid, near_points, polynomials_at
from .tensor import point_polynomials

#: Points refine the lattice down to cells of this size (pixels) at most: points
#: narrower than about 1.3 cells are summed exactly instead.
POINT_CELL_SIZE = 8.0
#: Cells are fitted to this quantile of the radii, so about 90% of the points
#: are wide enough for the polynomials (the rest are summed exactly).
POINT_QUANTILE = 0.1
#: Deepest lattice points alone ask for: the tensor is 243 coefficients a
#: cell at order 8, 127 MB at 256^2 cells.
POINT_MAX_LEVELS = 8


def point_levels(radius: float | None, side: float) -> int:
    """The lattice depth points ask for: cells no wider than ``radius``, nor than ``POINT_CELL_SIZE``.

    ``radius`` is the document's ``lattice_radius`` (None without points);
    points never refine the lattice beyond ``POINT_MAX_LEVELS``.
    """
    if radius is None:
        return 2
    target = max(POINT_CELL_SIZE, float(radius))
    return int(np.clip(np.ceil(np.log2(side / target)), 2, POINT_MAX_LEVELS))


def lattice_radius(sorted_radii: np.ndarray) -> float | None:
    """The radius the lattice is fitted to: the ``POINT_QUANTILE`` quantile (lower) of the sorted radii."""
    if len(sorted_radii) == 0:
        return None
    return float(sorted_radii[int(POINT_QUANTILE * (len(sorted_radii) - 1))])


@dataclass(frozen=True, eq=False)
class PointField:
    """Diffusion points as cell polynomials plus exact near points.

    Attributes
    ----------
    source : tuple of DiffusionPoint
        All the document's points.
    tensor : numpy.ndarray
        ``(2^L, 2^L, 3, P + 1, P + 1)`` coefficients of ``xi^i eta^j``.
    near : NearPoints
        The points too narrow for the polynomials.
    """

    source: tuple[DiffusionPoint, ...]
    tensor: np.ndarray
    near: NearPoints

    @classmethod
    def build(cls, points: tuple[DiffusionPoint, ...], lattice: Lattice, order: int) -> PointField:
        """Expand ``points`` on ``lattice`` with polynomials of degree ``order`` per axis."""
        packed = GaussPoints.from_points(points)
        settings = PointSettings(order=order)
        return cls(tuple(points), point_polynomials(packed, lattice, settings), near_points(packed, lattice, settings))

    @cached_property
    def points(self) -> GaussPoints:
        """All the points, packed (for the reference sums)."""
        return GaussPoints.from_points(self.source)

    def polynomials(self, order: int) -> np.ndarray:
        """The tensor at degree ``order``: zero-padded above its own, truncated (less accurate) below."""
        own = self.tensor.shape[-1] - 1
        if order <= own:
            return self.tensor[..., : order + 1, : order + 1]
        pad = order - own
        return np.pad(self.tensor, [(0, 0)] * 3 + [(0, pad), (0, pad)])

    def add_grid(self, order: int, xs: np.ndarray, ys: np.ndarray, out: np.ndarray,
                 scalar: np.ndarray | None = None, skip: np.ndarray | None = None) -> None:
        """Add the points' field on the grid ``ys x xs`` to ``out (len(ys), len(xs), 3)``: the polynomials at
        degree ``order`` (as ``polynomials(order)``) and the near points' exact sum.  With ``scalar (3,)``, the
        one channel ``scalar . colour`` to ``out (len(ys), len(xs), 1)``, a third of the work (a soft mask's
        luminance, which is all a mask's colour is read for).  ``skip (n, n)``: cells left as they are."""
        far_field_grid(self.tensor, xs, ys, self.near.lattice.cell_size, order=order, out=out, scalar=scalar,
                       skip=skip)
        near_grid(self.near, xs, ys, out=out, scalar=scalar, skip=skip)

    def at(self, targets: np.ndarray, order: int) -> np.ndarray:
        """The points' field at ``targets (m, 2)``, ``(m, 3)``."""
        return (polynomials_at(self.polynomials(order), targets, self.near.lattice.cell_size)
                + near_at(self.near, targets))


def sorted_radii_after(radii: np.ndarray, removed: np.ndarray, added: np.ndarray) -> np.ndarray:
    """The sorted array ``radii`` without one copy of each of ``removed`` and with ``added``."""
    if len(removed):
        counts = np.unique(removed, return_counts=True)
        drop = np.concatenate([np.searchsorted(radii, value) + np.arange(count) for value, count in zip(*counts)])
        radii = np.delete(radii, drop)
    if len(added):
        added = np.sort(added)
        radii = np.insert(radii, np.searchsorted(radii, added), added)
    return radii


class LivePoints:
    """A document's points on a lattice, updated point by point.

    Adding and removing points changes the tensor in the cells they reach
    (``increments.add_to_tensor``), in a copy: a tensor handed out by ``field``
    never changes afterwards.  The copy starts as zeros, whose pages the
    system gives only as they are written, and takes the old tensor's
    ``rows`` alone: a copy of the whole, 127 MB on roses' lattice, cost
    250 ms of page faults on a virtual machine for a dab of three points.
    Near points join the near lists in place;
    a removed one keeps its slot with zero weight (its terms are exact
    zeros) until dead slots outnumber live ones and the lists are compacted.

    Parameters
    ----------
    points : tuple of DiffusionPoint
    lattice : Lattice
    order : int
        Polynomial degree per axis.

    Attributes
    ----------
    rows : tuple of int
        ``[a, b)``: the rows of fine cells out of which the tensor is 0 (the rows the points ever reached).
    """

    def __init__(self, points: tuple[DiffusionPoint, ...], lattice: Lattice, order: int) -> None:
        self.lattice, self.settings = lattice, PointSettings(order=order)
        packed = GaussPoints.from_points(points)
        self.tensor = point_polynomials(packed, lattice, self.settings)
        ratios = expansion_ratios(packed, lattice, self.settings)
        self.rows = _row_span((0, 0), changed_cells(packed, lattice, self.settings)[ratios > 0])
        near = np.flatnonzero(ratios == 0)
        self._near = near_points(packed.take(near), lattice, self.settings)
        self._slots: dict[DiffusionPoint, list[int]] = {}
        for slot, index in enumerate(near):
            self._slots.setdefault(points[index], []).append(slot)
        self._dead = 0
        self.source = tuple(points)

    def update(self, points: tuple[DiffusionPoint, ...], removed: list[DiffusionPoint],
               added: list[DiffusionPoint]) -> np.ndarray:
        """Go over to ``points``, which is the current set without ``removed`` and with ``added``.

        Returns
        -------
        numpy.ndarray
            ``(k, 4)`` rectangles of fine cells that changed (rows ``[a, b)``, columns ``[c, d)``).
        """
        delta = GaussPoints.from_points([*removed, *added])
        delta = GaussPoints(delta.positions, delta.radii,
                            np.concatenate([-delta.weights[: len(removed)], delta.weights[len(removed):]]))
        tensor = np.zeros(self.tensor.shape)
        first, last = self.rows
        tensor[first:last] = self.tensor[first:last]
        rectangles = add_to_tensor(tensor, delta, self.lattice, self.settings)
        self.tensor = tensor
        self.rows = _row_span(self.rows, rectangles)
        near = expansion_ratios(delta, self.lattice, self.settings) == 0
        if near.any():
            rectangles[near] = changed_cells(delta.take(near), self.lattice, self.settings)
            gone = [self._slots[point].pop() for point, is_near in zip(removed, near) if is_near]
            if gone:
                self._near = self._near.without(np.array(gone))
                self._dead += len(gone)
            new = np.flatnonzero(near[len(removed):])
            if len(new):
                for slot, index in enumerate(new, start=len(self._near)):
                    self._slots.setdefault(added[index], []).append(slot)
                fresh = GaussPoints.from_points([added[i] for i in new])
                self._near = self._near.with_points(fresh, cutoff_radii(fresh, self.settings.tolerance))
            if self._dead > len(self._near) // 2:
                self._compact()
        self.source = tuple(points)
        return rectangles

    def _compact(self) -> None:
        """Rebuild the near lists from the live slots only."""
        live = sorted((slot, point) for point, slots in self._slots.items() for slot in slots)
        keep = np.array([slot for slot, _ in live], dtype=np.int64)
        self._near = near_points(self._near.points.take(keep), self.lattice, self.settings)
        self._slots = {}
        for slot, (_, point) in enumerate(live):
            self._slots.setdefault(point, []).append(slot)
        self._dead = 0

    @property
    def nbytes(self) -> int:
        """Bytes of the tensor's pages in use: its ``rows`` (the rest is zeros no page holds yet)."""
        first, last = self.rows
        return (last - first) * self.tensor[:1].nbytes

    def field(self) -> PointField:
        """The current points as a ``PointField`` (sharing the tensor, which later updates replace)."""
        return PointField(self.source, self.tensor, self._near)

    def copy(self) -> LivePoints:
        """An independent ``LivePoints`` in the same state (arrays shared: updates replace them)."""
        twin = copy.copy(self)
        twin._slots = {point: list(slots) for point, slots in self._slots.items()}
        return twin


def _row_span(rows: tuple[int, int], rectangles: np.ndarray) -> tuple[int, int]:
    """``rows`` ``[a, b)`` grown to hold the rows of ``rectangles (k, 4)`` (rows ``[a, b)`` first; empty ones
    ignored)."""
    used = rectangles[rectangles[:, 1] > rectangles[:, 0]]
    if len(used) == 0:
        return rows
    first, last = int(used[:, 0].min()), int(used[:, 1].max())
    return (first, last) if rows[1] <= rows[0] else (min(rows[0], first), max(rows[1], last))


def changed_point_cells(a: LivePoints | None, b: LivePoints | None) -> np.ndarray | bool:
    """Fine cells whose points' polynomials or near points differ between ``a`` and ``b`` (True: all)."""
    if a is None and b is None:
        return False
    if a is None or b is None:
        return True
    cells = False
    if a.tensor is not b.tensor:  # both are 0 out of their rows
        first, last = min(a.rows[0], b.rows[0]), max(a.rows[1], b.rows[1])
        cells = np.zeros(a.tensor.shape[:2], bool)
        cells[first:last] = np.any(a.tensor[first:last] != b.tensor[first:last], axis=(2, 3, 4))
    near_a, near_b = a.field().near, b.field().near
    if near_a is not near_b:  # either's near points may be gone or new: their cells
        n = a.lattice.cells_per_side
        occupied = (np.diff(near_a.cell_start) > 0) | (np.diff(near_b.cell_start) > 0)
        cells = cells | occupied.reshape(n, n)
    return cells


def warm_up_points(lattice: Lattice, order: int) -> None:
    """Do once, now, what the first points edit on ``lattice`` would otherwise pay for.

    That is the truncation table (0.2 s) and loading the compiled kernels of
    both kinds of point (polynomial and near), on a scratch lattice.
    """
    centre = (lattice.side / 2, lattice.side / 2)
    probes = (DiffusionPoint(centre, 2 * lattice.cell_size, (1.0, 1.0, 1.0)),
              DiffusionPoint(centre, 0.25 * lattice.cell_size, (1.0, 1.0, 1.0)))  # polynomial and near
    scratch = LivePoints((), Lattice(2, lattice.side), order)
    scratch.update(probes, [], list(probes))
    scratch.update((), list(probes), [])
