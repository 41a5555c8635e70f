"""A representation kept up to date as its document changes.

The FMR is linear in its sources, so an edit is applied as a change:

- **points** come and go in the cells they reach (``point_field.LivePoints``);
- **curve colours** (same geometry): the boundary system's matrix is the
  same, so its factorisation is reused and only the change of the solution
  is solved for, from the change of the right-hand side;
- **curve geometry**: the system differs from the factorised one in the
  few segments that were replaced, so it is solved through that
  factorisation (``updated_solve``: a Schur complement over the replaced
  segments) with one defect-correction step from the previous solution;
  only when many segments were replaced is it factorised again.  Flattened
  curves are cached, so only edited curves are flattened again.  A
  *preview* (``exact=False``, for drags) skips the solve: the moved
  segments keep their old densities (``carried_unknowns``), the
  representation is marked ``approximate`` and ``refine`` makes it exact.

Either curve edit ends with the change of the fine cells' multipoles,
carried up the quadtree and down through the interaction lists from the
changed cells only (``delta.delta_local``).  A change that moves the
lattice (the canvas, or the density of curves) rebuilds; points never move
it once it is built.  Every update reports the fine cells whose pixels may
have changed, so a view can upload just those.

Arrays handed out in ``representation`` are never changed afterwards (each
update makes new ones), so a representation taken once stays a consistent
snapshot while later updates run on another thread, and the states of
recent steps can be kept and returned to at once (``kept_states``: undo and
redo).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..model import DiffusionCurve, DiffusionPoint, Document
from ..model.changes import ChangeSet, recoloured_curves
from .fmm.lattice import (
    Lattice,
    cell_order,
    changed_runs,
    coarser_multipoles,
    dilated,
    downward_pass,
    fine_multipoles,
    sort_into_cells,
)
from .fmm.sparse_downward import delta_local
from .geometry.curve_cache import CurveSegments
from .geometry.discretise import boundary_segments, curve_colors
from .geometry.segments import Segments
from .kept_states import KeptStates, State
from .points.field import LivePoints, lattice_radius, point_levels, sorted_radii_after
from .representation import SOLVE_SEGMENTS_PER_CELL, Representation, Settings, choose_levels
from .solve.solver import BoundarySolver
from .solve.system_solvers import SystemSolvers
from .solve.updated import UpdatedSolver, carried_unknowns

Progress = Callable[[str, float], None]

#: A fine cell whose multipoles changed by less than this share of the solve's
#: own accuracy (relative to the largest multipole) keeps the change pending:
#: it is added with a later one.  Such changes are mostly the solve's noise.
NEGLIGIBLE = 0.1
#: Relative accuracy a preview's densities are taken to have (only for what counts as negligible).
PREVIEW_ACCURACY = 1e-3
#: A cell is reported changed once its local expansion moved by more than this
#: since it was last reported, so a view that uploads what is reported stays
#: within it of the truth.
UNSEEN = 1e-7


@dataclass(frozen=True)
class Update:
    """What one ``LiveRepresentation.update`` did.

    Attributes
    ----------
    kind : str
        ``"none"``, ``"points"``, ``"colours"``, ``"geometry"`` (curves, and
        points if they changed too), ``"restored"`` (a kept state, see
        ``LiveRepresentation``) or ``"rebuild"``.
    changed : numpy.ndarray
        ``(2^L, 2^L)`` bool: fine cells whose pixels may differ.
    seconds : float
    exact : bool
        False for a preview whose shading is approximate (``refine`` follows).
    """

    kind: str
    changed: np.ndarray
    seconds: float
    exact: bool = True


class LiveRepresentation:
    """A document's FMR, updated edit by edit.

    Parameters
    ----------
    document : Document
    settings : Settings
    progress : callable, optional
        Called as ``progress(stage, fraction)`` during (re)builds.
    saved : Representation, optional
        ``document``'s representation as saved (``io.load_fmr``): taken as it
        is, so that opening a file repeats no solve; the boundary system is
        factorised only when a colour edit first needs it.  Ignored (a build)
        if it does not belong to ``document`` with ``settings``.

    memory : int
        Bytes the states of recent steps may take (``kept_states``).

    Attributes
    ----------
    document : Document
        The document the representation is of.
    representation : Representation
        The current FMR, a snapshot: later updates replace its arrays, never change them.
    approximate : bool
        True after a preview of a geometry edit, until ``refine`` (or an exact update).
    """

    def __init__(self, document: Document, settings: Settings = Settings(), progress: Progress | None = None,
                 saved: Representation | None = None, memory: int = 500 * 2**20) -> None:
        self.settings = settings
        self.approximate = False
        self._curve_cache = CurveSegments(settings.tolerance, settings.max_length)
        self._solvers = SystemSolvers(self._new_solver)
        self._kept = KeptStates(memory)
        if saved is None or not self._resume(document, saved):
            self._rebuild(document, progress)
        self._kept.keep(self._state())

    @property
    def solver(self) -> BoundarySolver | UpdatedSolver:
        """The current geometry's solver: the factorisation, or an update of it; made when first needed."""
        return self._solvers.current

    # -- building ----------------------------------------------------------------------------
    def _forget_curves(self, keep: tuple[DiffusionCurve, ...]) -> None:
        """Drop the kept segments of curves in neither ``keep`` nor the current document."""
        self._curve_cache.forget(keep + self.document.curves)

    def _curve_segments(self, document: Document) -> Segments:
        return self._curve_cache.segments(document)

    def _levels(self, curves: Segments) -> int:
        """The lattice depth for ``curves``: what they ask for, or what the points asked for when built.

        Points are fitted to the lattice only when it is built: an edit of
        points never moves it (the narrow ones are summed exactly on any
        lattice), so the first dab costs what later ones do.
        """
        if self.settings.levels:
            return self.settings.levels
        return max(choose_levels(curves, self._side), self._point_levels)

    def _rebuild(self, document: Document, progress: Progress | None) -> None:
        report = progress or (lambda stage, fraction: None)
        timings = {}
        clock = time.perf_counter()

        def lap(stage: str, fraction: float) -> None:
            nonlocal clock
            now = time.perf_counter()
            timings[stage] = now - clock
            clock = now
            report(stage, fraction)

        settings = self.settings
        self._discretise(document)
        lap("discretise", 0.1)
        boundary = self._boundary
        solver = self._new_solver(boundary, lambda fraction: report("solve", 0.1 + 0.5 * fraction))
        self._solvers.reset(solver, boundary)
        self.approximate = False
        rhs = solver.right_hand_side(boundary.jump, boundary.mean)
        self._unknowns = solver.solve(rhs, lambda fraction: report("solve", 0.6 + 0.1 * fraction))
        lap("solve", 0.7)
        self._sort_solution()
        self._fine = self._fine_moments()
        multipoles = coarser_multipoles(self._fine, settings.propagation_order)
        lap("upward", 0.8)
        self._local = downward_pass(multipoles, self.lattice, settings.propagation_order)
        self._unreported = np.zeros(self._local.shape[:2])
        lap("downward", 0.95 if document.points else 1.0)
        self._kept.clear()
        self._points = LivePoints(document.points, self.lattice, settings.order) if document.points else None
        if self._points is not None:
            lap("points", 1.0)
        self.timings = timings
        self._forget_curves(document.curves)

    def _discretise(self, document: Document) -> None:
        self.document = document
        self._side = float(max(document.width, document.height))
        self._curves = self._curve_segments(document)
        self._radii = np.sort([point.radius for point in document.points])
        self._point_levels = point_levels(lattice_radius(self._radii), self._side)
        self.lattice = Lattice(self._levels(self._curves), self._side)
        self._boundary = boundary_segments(self._curves, document, self.lattice.cell_size, self.settings.border_spacing)

    def _resume(self, document: Document, saved: Representation) -> bool:
        """Take the solution and expansions of ``saved`` (of ``document``); False if they do not fit it."""
        start = time.perf_counter()
        self._discretise(document)
        if saved.lattice != self.lattice or len(saved.segments) != len(self._boundary):
            return False
        order, _ = cell_order(self._boundary, self.lattice)
        ordered = self._boundary.take(order)
        curve = ~ordered.on_border
        if not (all(np.array_equal(getattr(ordered, name), getattr(saved.segments, name))
                    for name in ("p", "q", "on_border", "mean"))
                and np.array_equal(ordered.jump[curve], saved.segments.jump[curve])):
            return False
        self._unknowns = np.empty_like(ordered.flux)
        self._unknowns[order] = saved.segments.unknowns()
        self._solvers.reset(None, None)
        self._solvers.move_to(self._boundary)
        self._sort_solution()
        self._fine = self._fine_moments()
        self._local = np.array(saved.local, dtype=complex)
        self._unreported = np.zeros(self._local.shape[:2])
        self._points = LivePoints(document.points, self.lattice, self.settings.order) if document.points else None
        self.timings = {"resume": time.perf_counter() - start}
        self._forget_curves(document.curves)
        return True

    def _new_solver(self, boundary: Segments, progress: Callable[[float], None] | None = None) -> BoundarySolver:
        solve_lattice = Lattice(choose_levels(self._curves, self._side, SOLVE_SEGMENTS_PER_CELL), self._side)
        return BoundarySolver(boundary, solve_lattice, progress)

    def _sort_solution(self) -> None:
        solved = self._boundary.with_unknowns(self._unknowns)
        self._segments, self._cell_start = sort_into_cells(solved, self.lattice)

    def _fine_moments(self) -> np.ndarray:
        return fine_multipoles(self._segments, self._cell_start, self.lattice, self.settings.propagation_order)

    @property
    def representation(self) -> Representation:
        document = self.document
        return Representation(
            document.width, document.height, self.lattice, self._segments, self._cell_start, self._local,
            self.settings.order, self.timings, self._points.field() if self._points is not None else None,
        )

    def warm_up(self) -> None:
        """Do once, now, the work the first edit of each kind would otherwise pay for.

        That is the points' truncation table (0.2 s) and loading their
        compiled kernels: an editor calls this while the user looks at a
        freshly opened document, so the first dab costs what later ones do.
        """
        lattice = self.lattice
        centre = (lattice.side / 2, lattice.side / 2)
        probes = (DiffusionPoint(centre, 2 * lattice.cell_size, (1.0, 1.0, 1.0)),
                  DiffusionPoint(centre, 0.25 * lattice.cell_size, (1.0, 1.0, 1.0)))  # polynomial and near
        scratch = LivePoints((), Lattice(2, lattice.side), self.settings.order)
        scratch.update(probes, [], list(probes))
        scratch.update((), list(probes), [])

    # -- updating ----------------------------------------------------------------------------
    def update(self, document: Document, progress: Progress | None = None, exact: bool = True) -> Update:
        """Bring the representation to ``document``, doing as little work as the change allows.

        Parameters
        ----------
        document : Document
        progress : callable, optional
            As for the constructor (rebuilds only).
        exact : bool
            False for a preview (a drag): a geometry edit then carries the old
            densities over instead of solving (``approximate`` until ``refine``).

        Returns
        -------
        Update
        """
        start = time.perf_counter()
        before = self.document
        changes = ChangeSet.between(before, document)
        n = self.lattice.cells_per_side
        changed = np.zeros((n, n), bool)
        kept = self._kept.find(document) if exact and not changes.empty else None
        if kept is not None and kept.lattice == self.lattice:
            self._restore(kept, changed)
            self._forget_curves(before.curves)
            return Update("restored", changed, time.perf_counter() - start)
        if changes.empty:
            self.document = document
            kind = self._refine(changed) if exact and self.approximate else "none"
            if not self.approximate:
                self._kept.keep(self._state())  # an equal document, another object: undo may come back to it
            return Update(kind, changed, time.perf_counter() - start, not self.approximate)
        removed = [before.points[i] for i in changes.removed_points]
        added = [document.points[i] for i in changes.added_points]
        recoloured = recoloured_curves(before, document, changes) if changes.curves_changed else None
        if recoloured is not None:
            curves = _with_colors(self._curves, document, recoloured)
        else:
            curves = self._curve_segments(document) if changes.curves_changed else self._curves
        if changes.canvas_changed or self._levels(curves) != self.lattice.levels:
            self._rebuild(document, progress)
            self._kept.keep(self._state())
            n = self.lattice.cells_per_side
            return Update("rebuild", np.ones((n, n), bool), time.perf_counter() - start)
        kind = "points"
        if changes.curves_changed:
            kind = self._update_curves(document, curves, changed, recoloured, exact)
        if exact and self.approximate:
            self._refine(changed)
        if removed or added:
            self._update_points(document, removed, added, changed)
        self._radii = sorted_radii_after(self._radii, np.array([p.radius for p in removed]),
                                         np.array([p.radius for p in added]))
        self.document = document
        self._forget_curves(before.curves)
        if not self.approximate:
            self._kept.keep(self._state())
        return Update(kind, changed, time.perf_counter() - start, not self.approximate)

    def refine(self) -> Update:
        """Make an approximate representation (a preview of a geometry edit) exact; nothing if it is."""
        start = time.perf_counter()
        n = self.lattice.cells_per_side
        changed = np.zeros((n, n), bool)
        kind = self._refine(changed) if self.approximate else "none"
        return Update(kind, changed, time.perf_counter() - start)

    def _refine(self, changed: np.ndarray) -> str:
        self._unknowns = self._solvers.solve_geometry(self._unknowns)
        self.approximate = False
        self._propagate(changed, self.solver.accuracy())
        self._kept.keep(self._state())
        return "geometry"

    def _update_curves(self, document: Document, curves: Segments, changed: np.ndarray,
                       recoloured: tuple[int, ...] | None, exact: bool) -> str:
        old = self._boundary
        if recoloured is not None:
            new, same_geometry = _with_colors(old, document, recoloured), True
        else:
            new = boundary_segments(curves, document, self.lattice.cell_size, self.settings.border_spacing)
            same_geometry = len(new) == len(old) and all(
                np.array_equal(getattr(new, name), getattr(old, name)) for name in ("p", "q", "on_border"))
        self._boundary, self._curves = new, curves
        if same_geometry:  # the solver of this geometry serves (colours are not part of it)
            self._unknowns = self._unknowns + self._solvers.run(lambda solver: solver.solve(
                solver.right_hand_side(new.jump - old.jump, new.mean - old.mean), iterate=False))
            self._propagate(changed, self.solver.accuracy(iterate=False))
            return "colours"
        self._solvers.move_to(new)
        carried = carried_unknowns(old, self._unknowns, new)
        if exact:
            self._unknowns = self._solvers.solve_geometry(carried)
            self._propagate(changed, self.solver.accuracy())
        else:
            self._unknowns, self.approximate = carried, True
            self._propagate(changed, PREVIEW_ACCURACY, local=True)
        return "geometry"

    def _propagate(self, changed: np.ndarray, accuracy: float, local: bool = False) -> None:
        """Carry the change of the fine multipoles of the new unknowns through the tree; mark what moved.

        ``local``: only segments that moved or were replaced changed (a preview
        keeps every other density), so only their cells' multipoles are made again.
        """
        before, before_start = self._segments, self._cell_start
        self._sort_solution()
        if local:
            n = self.lattice.cells_per_side
            cells = changed_runs(before, before_start, self._segments, self._cell_start)
            fresh = self._fine.copy()
            fresh.reshape(n * n, *fresh.shape[2:])[cells] = fine_multipoles(
                self._segments, self._cell_start, self.lattice, self.settings.propagation_order, cells)
        else:
            fresh = self._fine_moments()
        delta = fresh - self._fine
        scale = max(_largest_part(fresh), 1e-300)
        moved = _largest_part(delta, axis=(2, 3)) > NEGLIGIBLE * accuracy * scale
        delta[~moved] = 0.0
        self._fine = self._fine + delta
        local_change = delta_local(delta, self.lattice, self.settings.propagation_order)
        self._local = self._local + local_change
        self._report(changed, _largest_part(local_change, axis=(2, 3)), dilated(moved))

    def _report(self, changed: np.ndarray, local_change: np.ndarray, moved: np.ndarray) -> None:
        """Mark the cells whose unreported change of the local expansions passed ``UNSEEN``, or ``moved``."""
        self._unreported += local_change
        changed |= (self._unreported > UNSEEN) | moved
        self._unreported[changed] = 0.0

    def _update_points(self, document: Document, removed: list, added: list, changed: np.ndarray) -> None:
        if not document.points:
            self._points = None
            changed[:] = True  # cheap to say, rare: the last points went
            return
        if self._points is None:
            self._points = LivePoints((), self.lattice, self.settings.order)
        for a, b, c, d in self._points.update(document.points, removed, added):
            changed[a:b, c:d] = True

    # -- kept states (undo, redo) -------------------------------------------------------------
    def _state(self) -> State:
        points = self._points.copy() if self._points is not None else None
        return State(self.document, self.lattice, self._curves, self._radii, self._boundary, self._unknowns,
                     self._segments, self._cell_start, self._fine, self._local, points)

    def _restore(self, state: State, changed: np.ndarray) -> None:
        """Return to ``state`` (of this lattice), marking the cells whose pixels differ."""
        moved = np.any(state.fine != self._fine, axis=(2, 3)) | _point_cells(self._points, state.points)
        self._report(changed, _largest_part(state.local - self._local, axis=(2, 3)), dilated(moved))
        self.document, self._curves, self._radii = state.document, state.curves, state.radii
        self._boundary, self._unknowns, self._segments = state.boundary, state.unknowns, state.segments
        self._cell_start, self._fine, self._local = state.cell_start, state.fine, state.local
        self._points = state.points.copy() if state.points is not None else None
        self._solvers.move_to(state.boundary)
        self.approximate = False
        self._kept.keep(state)


def _largest_part(values: np.ndarray, axis=None) -> np.ndarray | float:
    """Largest absolute real or imaginary part of complex ``values`` (over ``axis``): a cheap size.

    From the largest and smallest parts, so that no array of absolute values is made.
    """
    parts = values.view(np.float64)
    largest = np.maximum(parts.max(axis=axis, initial=0.0), -parts.min(axis=axis, initial=0.0))
    return largest if axis is not None else float(largest)


def _point_cells(a: LivePoints | None, b: LivePoints | None) -> np.ndarray | bool:
    """Cells whose points' polynomials or near points differ between ``a`` and ``b``."""
    if a is None and b is None:
        return False
    if a is None or b is None:
        return True
    cells = np.any(a.tensor != b.tensor, axis=(2, 3, 4)) if a.tensor is not b.tensor else False
    near_a, near_b = a.field().near, b.field().near
    if near_a is not near_b:  # either's near points may be gone or new: their cells
        n = a.lattice.cells_per_side
        occupied = (np.diff(near_a.cell_start) > 0) | (np.diff(near_b.cell_start) > 0)
        cells = cells | occupied.reshape(n, n)
    return cells


def _with_colors(segments: Segments, document: Document, curves: tuple[int, ...]) -> Segments:
    """``segments`` with the colours of those from the curves ``curves`` (ids) taken afresh from ``document``."""
    jump, mean = segments.jump.copy(), segments.mean.copy()
    for curve_id in curves:
        mine = segments.origin[:, 0] == curve_id
        jump[mine], mean[mine] = curve_colors(segments.take(mine), document.curve(curve_id))
    return replace(segments, jump=jump, mean=mean)


def build(document: Document, settings: Settings = Settings(), progress: Progress | None = None) -> Representation:
    """Discretise, solve and propagate ``document`` into its FMR.

    Parameters
    ----------
    document : Document
    settings : Settings
    progress : callable, optional
        Called as ``progress(stage, fraction)`` as the build advances.

    Returns
    -------
    Representation
    """
    return LiveRepresentation(document, settings, progress).representation
