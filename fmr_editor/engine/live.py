"""A representation kept up to date as its document changes.

The FMR is linear in its sources, so an edit is applied as a change:

- **points** come and go in the cells they reach (``points.field.LivePoints``);
- **curve colours** (same geometry): the factorisation of the boundary system
  is reused, and only the change of the solution is solved for;
- **curve geometry**: the system differs from the factorised one in the few
  segments that were replaced, so it is solved through that factorisation
  (``solve.updated``) with one defect-correction step, or factorised again when
  many were replaced.  A *preview* (``exact=False``, for drags) skips the solve:
  the densities of the last exact state carried over and solved again near the
  moved segments only (``solve.preview``), the representation is marked
  ``approximate`` and ``refine`` makes it exact.

Either curve edit ends with the change of the fine multipoles carried through
the tree from the changed cells only (``cells``).  A change that moves the
lattice (the canvas, or the density of curves) rebuilds; points never move it.
Every update reports the fine cells whose pixels may have changed, so a view
uploads just those.  Arrays once handed out are never changed (updates make
new ones): a representation stays a consistent snapshot while later updates
run on another thread, and recent states are kept for undo (``kept_states``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..model import DiffusionCurve, Document
from ..model.changes import ChangeSet, recoloured_curves
from .cells import Cells, largest_part, propagated, saved_unknowns
from .fmm.lattice import Lattice, dilated
from .geometry.curve_cache import CurveSegments
from .geometry.discretise import BoundaryCuts, with_curve_colors
from .geometry.segments import Segments
from .kept_states import DEFAULT_MEMORY, KeptStates, State
from .memory import affordable_levels, check_build_memory
from .points.field import (
    LivePoints,
    changed_point_cells,
    lattice_radius,
    point_levels,
    sorted_radii_after,
    warm_up_points,
)
from .representation import SOLVE_SEGMENTS_PER_CELL, Representation, Settings, choose_levels
from .solve.preview import GLOBAL_STEP_SEGMENTS, Previews
from .solve.solver import BoundarySolver
from .solve.system_solvers import SharedFactorisations, SystemSolvers
from .solve.updated import UpdatedSolver, carried_unknowns

Progress = Callable[[str, float], None]

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
    stale : bool
        True for a preview that shows the last exact picture instead: its
        estimated error passed what the screen may show (``solve.preview``).
    """

    kind: str
    changed: np.ndarray
    seconds: float
    exact: bool = True
    stale: bool = False


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
    shared : SharedFactorisations, optional
        Where factorisations of other representations are found by their geometry (a layer's image and
        alpha field share theirs); None: this one's own only.

    Attributes
    ----------
    document : Document
        The document the representation is of.
    representation : Representation
        The current FMR, a snapshot: later updates replace its arrays, never change them.
    approximate : bool
        True after a preview of a geometry edit, until ``refine`` (or an exact update).
    stale : bool
        True while approximate and the representation is the last exact one (``Update.stale``).
    factorisations : int
        Boundary systems factorised so far (the work a geometry edit should not repeat: it is solved
        through the kept factorisation, ``solve.updated``); one found in ``shared`` does not count.
    origin : str
        Where its first state came from: ``"built"`` (solved), ``"resumed"`` (``saved`` taken as it is)
        or ``"twin"`` (another representation's, ``twin``).
    timings : dict
        Seconds each stage of the first state took (a diagnostic).
    """

    def __init__(self, document: Document, settings: Settings = Settings(), progress: Progress | None = None,
                 saved: Representation | None = None, memory: int = DEFAULT_MEMORY,
                 shared: SharedFactorisations | None = None) -> None:
        self.settings = settings
        self._shared = shared
        self.approximate = False
        self.factorisations = 0
        self.origin = "built"
        self.document = document
        self.lattice: Lattice | None = None
        self.timings: dict[str, float] = {}
        self._side = float(max(document.width, document.height))
        self._curve_cache = CurveSegments(settings.tolerance, settings.max_length)
        self._cuts = BoundaryCuts()
        self._solvers = SystemSolvers(self._new_solver)
        self._kept = KeptStates(memory)
        self._curves: Segments | None = None  # the document's clipped curve segments (no border, not cut)
        self._boundary: Segments | None = None  # curves and border cut at cells: the boundary system's segments
        self._unknowns: np.ndarray | None = None  # its solution (E on curves, C on the border), as _boundary
        self._cells: Cells | None = None
        self._unreported: np.ndarray | None = None  # change of each cell's local expansion not yet reported
        self._points: LivePoints | None = None
        self._radii = np.zeros(0)  # the points' radii, sorted
        self._point_levels = 2  # the lattice depth the points asked for when it was built
        self._handed_out: tuple | None = None  # (state, Representation): see representation
        self._previews: tuple[Previews, Cells] | None = None  # of the last exact state and its cells
        self._shows_exact = False  # a preview not trusted: the cells are the last exact state's
        if saved is None or not self._resume(document, saved):
            self._rebuild(document, progress)
        self._keep(self._state())

    @property
    def stale(self) -> bool:
        return self.approximate and self._shows_exact

    @property
    def memory(self) -> int:
        """Bytes the states of recent steps may take (``kept_states``)."""
        return self._kept.memory

    @memory.setter
    def memory(self, memory: int) -> None:
        self._kept.memory = int(memory)

    @property
    def solver(self) -> BoundarySolver | UpdatedSolver:
        """The current geometry's solver: the factorisation, or an update of it; made when first needed."""
        return self._solvers.current

    # -- building ----------------------------------------------------------------------------
    def _forget_curves(self, keep: tuple[DiffusionCurve, ...]) -> None:
        """Drop the kept segments of curves in neither ``keep`` nor the current document."""
        self._curve_cache.forget(keep + self.document.curves)

    @property
    def _terms(self) -> int:
        """Expansion terms a cell holds (what its memory estimate counts)."""
        return self.settings.propagation_order + 1

    def _levels(self, curves: Segments) -> int:
        """The lattice depth for ``curves``: what they ask for, or what the points asked for when built.

        Points are fitted to the lattice only when it is built: an edit of
        points never moves it (the narrow ones are summed exactly on any
        lattice), so the first dab costs what later ones do.
        """
        if self.settings.levels:
            return self.settings.levels
        return affordable_levels(max(choose_levels(curves, self._side), self._point_levels), self._terms)

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
        self._unknowns = solver.solve_colours(boundary.jump, boundary.mean,
                                              lambda fraction: report("solve", 0.6 + 0.1 * fraction))
        lap("solve", 0.7)
        stages = {"upward": 0.8, "downward": 0.95 if document.points else 1.0}
        self._cells = Cells.build(boundary.with_unknowns(self._unknowns), self.lattice, settings.propagation_order,
                                  lambda stage: lap(stage, stages[stage]), pixel_order=settings.order)
        self._unreported = np.zeros(self._cells.local.shape[:2])
        self._kept.clear()
        self._points = LivePoints(document.points, self.lattice, settings.order) if document.points else None
        if self._points is not None:
            lap("points", 1.0)
        self.timings = timings
        self._forget_curves(document.curves)

    def _discretise(self, document: Document) -> None:
        self.document = document
        self._side = float(max(document.width, document.height))
        self._curves = self._curve_cache.segments(document)
        self._radii = np.sort([point.radius for point in document.points])
        self._point_levels = point_levels(lattice_radius(self._radii), self._side)
        self.lattice = Lattice(self._levels(self._curves), self._side)
        self._boundary = self._cuts(self._curves, document, self.lattice.cell_size, self.settings.border_spacing)
        check_build_memory(len(self._boundary), self.lattice.levels, self._terms)

    def _resume(self, document: Document, saved: Representation) -> bool:
        """Take the solution and expansions of ``saved`` (of ``document``); False if they do not fit it."""
        start = time.perf_counter()
        self._discretise(document)
        unknowns = saved_unknowns(self._boundary, self.lattice, saved) if saved.lattice == self.lattice else None
        if unknowns is None:
            return False
        self._unknowns = unknowns
        self._solvers.reset(None, None)
        self._solvers.move_to(self._boundary)
        self._cells = Cells.resume(self._boundary.with_unknowns(self._unknowns), self.lattice,
                                   self.settings.propagation_order, saved.local, pixel_order=self.settings.order)
        self._unreported = np.zeros(self._cells.local.shape[:2])
        self._points = LivePoints(document.points, self.lattice, self.settings.order) if document.points else None
        self.timings = {"resume": time.perf_counter() - start}
        self.origin = "resumed"
        self._forget_curves(document.curves)
        return True

    def twin(self, document: Document) -> LiveRepresentation:
        """A representation of ``document``, which holds this one's very curves and points on its canvas: this
        one's solution and expansions as they are, no solve (a clone's source copied from a layer, a duplicate).

        The two are independent from now on; the twin factorises its system
        only when an edit first needs it.  This one must be exact.
        """
        twin = object.__new__(LiveRepresentation)
        twin.__dict__.update(self.__dict__)
        twin.document, twin.timings, twin.factorisations, twin.origin = document, {}, 0, "twin"
        twin._curve_cache, twin._cuts = self._curve_cache.copy(), BoundaryCuts()
        twin._solvers = SystemSolvers(twin._new_solver)
        twin._solvers.move_to(self._boundary)
        twin._kept = KeptStates(self.memory)
        twin._unreported = np.zeros_like(self._unreported)
        twin._points = self._points.copy() if self._points is not None else None
        twin._kept.keep(twin._state())
        return twin

    def _new_solver(self, boundary: Segments, progress: Callable[[float], None] | None = None) -> BoundarySolver:
        solve_lattice = Lattice(choose_levels(self._curves, self._side, SOLVE_SEGMENTS_PER_CELL), self._side)
        shared = self._shared
        key = shared.key(boundary, solve_lattice.levels, solve_lattice.side) if shared is not None else b""
        solver = shared.get(key) if shared is not None else None
        if solver is None:
            self.factorisations += 1
            solver = BoundarySolver(boundary, solve_lattice, progress)
            if shared is not None:
                shared.keep(key, solver)
        return solver

    @property
    def representation(self) -> Representation:
        points = self._points
        state = (self.document, self._cells, self.timings, points) + ((points.source, points.tensor)
                                                                      if points is not None else (None, None))
        if self._handed_out is None or any(a is not b for a, b in zip(self._handed_out[0], state)):
            document = self.document
            self._handed_out = state, Representation(
                document.width, document.height, self.lattice, self._cells.segments, self._cells.cell_start,
                self._cells.local, self.settings.order, self.timings,
                points.field() if points is not None else None, self._cells.centres,
            )
        return self._handed_out[1]  # the same object while nothing changed: what it keeps (near_tables) is kept

    def warm_up(self) -> None:
        """Do once, now, the work the first edit of each kind would otherwise pay for.

        That is the points' truncation table (0.2 s) and loading their
        compiled kernels: an editor calls this while the user looks at a
        freshly opened document, so the first dab costs what later ones do.
        """
        warm_up_points(self.lattice, self.settings.order)

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
                self._keep(self._state())  # an equal document, another object: undo may come back to it
            return Update(kind, changed, time.perf_counter() - start, not self.approximate, self.stale)
        removed = [before.points[i] for i in changes.removed_points]
        added = [document.points[i] for i in changes.added_points]
        recoloured = recoloured_curves(before, document, changes) if changes.curves_changed else None
        if recoloured is not None:
            curves = with_curve_colors(self._curves, document, recoloured)
        else:
            curves = self._curve_cache.segments(document) if changes.curves_changed else self._curves
        if changes.canvas_changed or self._levels(curves) != self.lattice.levels:
            self._rebuild(document, progress)
            self._keep(self._state())
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
            self._keep(self._state())
        return Update(kind, changed, time.perf_counter() - start, not self.approximate, self.stale)

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
        self._keep(self._state())
        return "geometry"

    def _update_curves(self, document: Document, curves: Segments, changed: np.ndarray,
                       recoloured: tuple[int, ...] | None, exact: bool) -> str:
        old = self._boundary
        if recoloured is not None:
            new, same_geometry = with_curve_colors(old, document, recoloured), True
        else:
            new = self._cuts(curves, document, self.lattice.cell_size, self.settings.border_spacing)
            same_geometry = len(new) == len(old) and all(
                np.array_equal(getattr(new, name), getattr(old, name)) for name in ("p", "q", "on_border"))
        self._boundary, self._curves = new, curves
        if same_geometry:  # the solver of this geometry serves (colours are not part of it)
            self._unknowns = self._unknowns + self._solvers.run(lambda solver: solver.solve(
                solver.right_hand_side(new.jump - old.jump, new.mean - old.mean), iterate=False))
            self._propagate(changed, self.solver.accuracy(iterate=False))
            return "colours"
        if not exact and not self.approximate:  # every preview starts from the last exact state: no drift
            self._previews = self._previews_of(old), self._cells
        self._solvers.move_to(new)
        if exact:
            self._unknowns = self._solvers.solve_geometry(carried_unknowns(old, self._unknowns, new))
            self._propagate(changed, self.solver.accuracy())
        else:
            previews, exact_cells = self._previews
            preview = previews.preview(new)
            self._unknowns, self.approximate, self._shows_exact = preview.unknowns, True, not preview.trusted
            if preview.trusted:  # a preview changes its densities on purpose: none is negligible
                self._propagate(changed, 0.0, local=not preview.global_step)
            else:
                self._show(exact_cells, changed)
        return "geometry"

    def _previews_of(self, boundary: Segments) -> Previews:
        """Previews of geometries near the current, exact one (``boundary``): what a drag shows."""
        cells, lattice = self._cells, self.lattice
        solver = self._solvers.run(lambda solver: solver) if len(boundary) <= GLOBAL_STEP_SEGMENTS else None
        return Previews(boundary, self._unknowns, lambda points: cells.field_at(points, lattice),
                        None if solver is None else lambda rhs: solver.solve(rhs, iterate=False))

    def _propagate(self, changed: np.ndarray, accuracy: float, local: bool = False) -> None:
        """Carry the change of the fine multipoles of the new unknowns through the tree; mark what moved.

        ``local``: only segments that moved or were replaced changed (a preview
        keeps every other density), so only their cells' multipoles are made again.
        """
        self._cells, local_change, moved = propagated(
            self._cells, self._boundary.with_unknowns(self._unknowns), self.lattice,
            self.settings.propagation_order, accuracy, only_moved=local)
        self._report(changed, local_change, dilated(moved))

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
    def _keep(self, state: State) -> None:
        """Keep ``state``, exact, for undo; a drag's previews (and the cells they hold) are over."""
        self._previews = None
        self._kept.keep(state)

    def _state(self) -> State:
        points = self._points.copy() if self._points is not None else None
        return State(self.document, self.lattice, self._curves, self._radii, self._boundary, self._unknowns,
                     self._cells, points)

    def _show(self, cells: Cells, changed: np.ndarray, points_moved: np.ndarray | bool = False) -> None:
        """Take ``cells`` (of this lattice) as the current ones, marking the cells whose pixels differ."""
        moved = cells.moved_from(self._cells) | points_moved
        self._report(changed, largest_part(cells.local - self._cells.local, axis=(2, 3)), dilated(moved))
        self._cells = cells

    def _restore(self, state: State, changed: np.ndarray) -> None:
        """Return to ``state`` (of this lattice), marking the cells whose pixels differ."""
        self._show(state.cells, changed, changed_point_cells(self._points, state.points))
        self.document, self._curves, self._radii = state.document, state.curves, state.radii
        self._boundary, self._unknowns = state.boundary, state.unknowns
        self._points = state.points.copy() if state.points is not None else None
        self._solvers.move_to(state.boundary)
        self.approximate = False
        self._keep(state)
