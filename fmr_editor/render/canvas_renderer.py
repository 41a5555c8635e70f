"""The shader-rendered canvas: a representation on the GPU, evaluated per window pixel.

``CanvasRenderer`` keeps a representation in texture buffers (``packing``
says how) and evaluates it in ``shaders/canvas.frag`` into a cached image of
the window's size; ``draw`` copies that image to the caller's framebuffer and
re-evaluates only what is out of date:

- nothing, when neither the data nor the view changed (a redraw is one copy);
- after a pan by whole window pixels, the cached image is moved and only the
  uncovered strips are evaluated;
- the whole window after a zoom, a resize or a new representation.

``update`` uploads the changed cells' coefficients and brings the cached
image up to date with the least work its bounds (``bounds``) allow: a cell
whose pixels moved by less than ``tolerance`` keeps them (the change is
remembered); with the float image (the default) and unchanged geometry, the
others get the *change* of their colour added (far-field change plus only the
segments whose E or C moved noticeably: a colour edit moves a few); any other
cell is evaluated again in full.

The renderer is Qt-free: the caller makes its OpenGL (>= 4.1 core) context
current around every call and passes the framebuffer to draw into.
"""

from __future__ import annotations

from collections import Counter
from contextlib import nullcontext

import numpy as np
from OpenGL import GL

from ..engine import Representation
from . import bounds, packing
from .cached_image import BACKGROUND, CachedImage, show_scaled
from .canvas_data import UNITS, CanvasData, ShaderLayout
from .gl import Framebuffer, Program, VertexArray, additive, in_plain_state, shader_source
from .view import View, cells_rect, integer_shift, row_runs, uncovered, visible_cells

#: Default ``CanvasRenderer.tolerance``: a twentieth of an 8-bit step.
TOLERANCE = 0.05 / 255
#: A delta pass leaves out the segments whose change is below this share of the tolerance.
SEGMENT_SHARE = 1 / 64
#: What a delta pass may add to a cell's error (float32 rounding, generously): after some hundred passes
#: without a full evaluation, the tolerance is reached and the cell is evaluated again, so errors never pile up.
DELTA_ROUNDING = 2e-6


class CanvasRenderer:
    """Draws a representation's FMR image through a fragment shader, any pan and zoom.

    Parameters
    ----------
    cache_format : int
        Format of the cached image: ``GL_RGBA32F`` (default: unclamped
        floats, which changes can be added to) or ``GL_RGBA8`` (a quarter of
        the memory; every changed cell is evaluated in full).
    checker : float
        Side of the checkerboard squares outside the canvas, in window pixels.
    tolerance : float
        A changed cell keeps its pixels while they may have moved by at most
        this (colour units) since they were last evaluated.
    weights : numpy.ndarray, optional
        ``(3,)``: draw only the scalar field ``weights . colour``, into all
        three channels (what reads a mask's luminance or an alpha's first
        channel reads it there): a third of the tables and of the work.

    Attributes
    ----------
    last_evaluation : str
        What the latest ``draw`` evaluated: ``"none"``, ``"cells"``, ``"shift"``
        (a pan; with any changed cells), ``"full"`` or ``"preview"`` (nothing:
        the cached image was scaled).
    evaluations : collections.Counter
        How many draws evaluated each of those since the renderer was made:
        compare counts before and after an action (``last_evaluation`` belongs
        to whichever draw came last, which a window may repeat at any time).
    last_update : dict
        Counts of the latest ``update``'s cells: ``"changed"`` (reported),
        ``"delta"`` (their change added), ``"evaluate"`` (to be evaluated in
        full by the next ``draw``) and ``"segments"`` (in the delta pass).
    needed : numpy.ndarray or None
        ``(2^L, 2^L)`` bool: the cells whose pixels an evaluation must bring
        up to date; the others' may be left ``stale`` until they are needed
        (a layer hidden there, ``culling``).  None: every cell's.
    """

    def __init__(self, cache_format: int = GL.GL_RGBA32F, checker: float = 8.0, tolerance: float = TOLERANCE,
                 weights: np.ndarray | None = None) -> None:
        self.checker = float(checker)
        self.tolerance = float(tolerance)
        self._data = CanvasData(weights)
        self._vao = VertexArray()
        self._cache = CachedImage(cache_format)
        self._programs: dict[tuple, Program] = {}
        self._rep: Representation | None = None  # what the image shows; None: a plain background
        self._layout: ShaderLayout | None = None
        self._dirty: np.ndarray | None = None  # cells to evaluate again at the next draw
        self._unseen = np.zeros((0, 0))  # bound on each cell's change missing from the cached image
        self._cached_view: View | None = None  # what the cached image shows; None: nothing
        self.last_evaluation = "none"
        self.evaluations: Counter[str] = Counter()
        self.last_update = {"changed": 0, "delta": 0, "evaluate": 0, "segments": 0}
        self._reflect = False
        self.reach = 0.0
        self._redrawn = np.zeros(0, int)  # the cells whose pixels the latest update changes
        self._stale = np.zeros((0, 0), bool)  # cells whose cached pixels are not current (left while not needed)
        self._partial = False  # the image holds only the needed cells of its last full evaluation, not what lies
        # outside the lattice
        self.needed: np.ndarray | None = None

    @property
    def reflect(self) -> bool:
        """True: beyond the canvas the image holds the picture reflected at its border, not the checkerboard
        (a field to be blurred; ``reach`` document pixels of it about the canvas are in the window, so a
        change that near the border is evaluated in full, reflections and all)."""
        return self._reflect

    @reflect.setter
    def reflect(self, reflect: bool) -> None:
        if reflect != self._reflect:
            self._reflect = reflect
            self._cached_view = None

    # -- data ---------------------------------------------------------------------------------
    @property
    def representation(self) -> Representation | None:
        return self._rep

    @property
    def image_texture(self) -> int:
        """The GL texture of the cached float image (what ``evaluate`` brings up to date)."""
        return self._cache.image.texture

    @property
    def image(self) -> Framebuffer:
        """The cached float image's framebuffer."""
        return self._cache.image

    @property
    def stale(self) -> np.ndarray:
        """``(2^L, 2^L)`` bool: the cells whose pixels in the cached image are not current (not ``needed`` when
        they were to be evaluated)."""
        return self._stale.copy()

    def value_bounds(self, first: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """``CanvasData.value_bounds`` of the uploaded representation, of its channels from ``first`` on."""
        return self._data.value_bounds(first)

    def take_changed(self) -> tuple[int, int, int, int] | None:
        """GL pixels ``(x0, y0, x1, y1)`` of the cached image changed since the last call; None: none."""
        return self._cache.take_changed()

    @property
    def alpha(self) -> Representation | None:
        """The alpha field drawn in the image's fourth channel (``upload``), or None."""
        return self._data.alpha

    def upload(self, rep: Representation, alpha: Representation | None = None) -> None:
        """Upload all of ``rep``; the next ``draw`` evaluates the whole window.  ``alpha``: a translucent layer's
        alpha field, of ``rep``'s segments, lattice and order, drawn in the image's fourth channel."""
        self._data.upload(rep, alpha)
        self._layout = self._data.layout
        n = self._layout.cells
        self._rep = rep
        self._unseen = np.zeros((n, n))
        self._dirty = np.zeros((n, n), bool)
        self._stale = np.zeros((n, n), bool)
        self._cached_view = None

    @in_plain_state
    def update(self, rep: Representation, changed: np.ndarray, alpha: Representation | None = None) -> None:
        """Go over to ``rep`` (and ``alpha``, as ``upload``'s), whose pixels differ from the uploaded one's only in
        the ``changed`` cells.

        Uploads those cells' coefficients (segments and near points whole, when
        they are other arrays) and brings the cached image up to date as the
        module says: adds the change to some cells at once, leaves others to
        the next ``draw``.  A representation on another lattice (or of another
        order, or gaining or losing points) is uploaded whole.

        Parameters
        ----------
        rep : Representation
        changed : numpy.ndarray
            ``(2^L, 2^L)`` bool, as ``engine.Update.changed``.
        """
        if self._rep is None or ShaderLayout.of(rep, self._layout.scalar, alpha is not None) != self._layout:
            self.upload(rep, alpha)
            return
        changed = np.asarray(changed, bool)
        n = self._layout.cells
        if changed.shape != (n, n):
            raise ValueError(f"changed must be ({n}, {n})")
        cells = np.flatnonzero(changed)
        old, old_alpha = self._rep, self._data.alpha
        same_geometry = bounds.same_geometry(old, rep)
        segment_moves = bounds.segment_changes(old, rep)
        if alpha is not None and alpha is not old_alpha and segment_moves is not None:  # (the same: no moves)
            alpha_moves = bounds.segment_changes(old_alpha, alpha)
            segment_moves = None if alpha_moves is None else np.maximum(segment_moves, alpha_moves)
        near = bounds.near_bound(old, rep, segment_moves)  # inf beside segments that moved
        moved, near_points_changed = self._data.update(rep, cells, same_geometry, alpha)
        self._rep = rep
        if near is not None and not near_points_changed:  # the bounds cover every change
            moved += near.ravel()[cells]
        else:
            moved[:] = np.inf
        exact = same_geometry and not near_points_changed  # the change can also be added to the image
        self.last_update = self._catch_up(cells, moved, exact, (old, old_alpha), segment_moves)
        if self._reflect and self.reach > 0 and self._near_border(self._redrawn).any():
            self._cached_view = None  # their reflections beyond the border change too

    def _catch_up(self, cells: np.ndarray, moved: np.ndarray, exact: bool,
                  old: tuple[Representation, Representation | None], segment_moves: np.ndarray | None
                  ) -> dict[str, int]:
        """Bring the cached image up to date with an update: add some cells' change, mark others dirty.

        ``moved`` bounds the change of each of ``cells``' pixels, ``segment_moves``
        each segment's (``bounds.segment_changes``); with ``exact`` the change can
        be added to the image (a float image, and the same geometry).  ``old``: the representation and alpha
        field before.  Returns the counts of ``last_update``.
        """
        rep = self._rep
        unseen = self._unseen.ravel()
        before = unseen[cells]
        total = before + moved
        show = total > self.tolerance
        unseen[cells[~show]] = total[~show]
        shown = cells[show]
        self._redrawn = shown
        counts = {"changed": len(cells), "delta": 0, "evaluate": 0, "segments": 0}
        if self._cached_view is not None and len(shown):
            if exact and self._cache.additive:
                keep = segment_moves > SEGMENT_SHARE * self.tolerance
                left_out = bounds.block_sums(np.where(keep, 0.0, segment_moves), rep).ravel()[shown]
                after = before[show] + left_out + DELTA_ROUNDING
                add = after <= self.tolerance
                unseen[shown[add]] = after[add]
                self._add_change(shown[add], old, rep, keep)
                counts.update(delta=int(add.sum()), segments=int(keep.sum()))
                shown = shown[~add]
            unseen[shown] = 0.0
            self._dirty.ravel()[shown] = True
            counts["evaluate"] = len(shown)
        return counts

    def _near_border(self, cells: np.ndarray) -> np.ndarray:
        """Which of ``cells`` (flat indices) lie within ``reach`` of the canvas border."""
        layout, reach = self._layout, self.reach
        size = layout.cell_size
        columns, rows = cells % layout.cells, cells // layout.cells
        return ((columns * size < reach) | ((columns + 1) * size > layout.width - reach)
                | (rows * size < reach) | ((rows + 1) * size > layout.height - reach))

    def _add_change(self, cells: np.ndarray, old: tuple[Representation, Representation | None], new: Representation,
                    keep: np.ndarray) -> None:
        """Add the change of ``cells``' colour (their far field's, the ``keep`` segments') to the image; ``old``
        the representation and alpha field before."""
        if len(cells) == 0:
            return
        (before, _), (after, _) = old[0].near, new.near
        flux, jump = after.flux - before.flux, after.jump - before.jump
        alpha = self._data.alpha
        if alpha is not None:
            (before, _), (after, _) = old[1].near, alpha.near
            flux = packing.with_alpha(flux, after.flux - before.flux)
            jump = packing.with_alpha(jump, after.jump - before.jump)
        self._data.upload_change(cells, packing.segment_table(new, flux, jump, keep, self._data.weights))
        self._cache.bind()
        self._pass(self._cached_view, cells, delta=True)

    def forget(self) -> None:
        """Drop the representation: ``draw`` shows a plain background until the next ``upload``."""
        self._rep = None
        self._cached_view = None

    def invalidate(self) -> None:
        """Forget the cached image: the next ``draw`` evaluates the whole window."""
        self._cached_view = None

    # -- drawing ------------------------------------------------------------------------------
    def _program(self) -> Program:
        """The program for the uploaded representation: its layout, and whether it has near segments at all (a
        field of diffusion points alone has none, ``Representation.near``: their loop, even empty, costs llvmpipe
        5 ms a million pixels)."""
        segments = len(self._rep.near[0].p) > 0
        key = (self._layout.order, self._layout.harmonic, self._layout.scalar, self._layout.alpha, segments)
        if key not in self._programs:
            defines = {"ORDER": key[0], "HARMONIC": int(key[1]), "COEFF_TEXELS": self._layout.texels,
                       "SCALAR": int(key[2]), "ALPHA": int(key[3]), "SEGMENTS": int(segments)}
            self._programs[key] = Program(shader_source("canvas.vert"), shader_source("canvas.frag", defines),
                                          label="canvas shader")
        return self._programs[key]

    @in_plain_state
    def draw(self, view: View, target: int = 0, preview: bool = False) -> None:
        """Bring the cached image up to date for ``view`` and copy it into framebuffer ``target``.

        Parameters
        ----------
        view : View
            Pan and zoom; its size is the target's size in pixels.
        target : int
            Framebuffer object to draw into (0: the context's default one).
        preview : bool
            When ``view`` would need the whole window evaluated (a zoom), show
            the cached image scaled to it instead (fast, not sharp) and keep the
            cache as it is; a later ``draw`` without ``preview`` evaluates.
        """
        if preview and self._rep is not None and self._cached_view is not None and self._needs_full(view):
            show_scaled(self._cache.shown(), self._cached_view, view, target)
            self.last_evaluation = "preview"
            self.evaluations["preview"] += 1
        else:
            self._evaluate(view)
            self._cache.shown().blit_to(target)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, target)

    def _touch(self, view: View, cells: np.ndarray | None = None) -> None:
        """Note that the cache changed: everywhere, or over the window rectangles of ``cells``."""
        layout = self._layout
        self._cache.touch((0, 0, view.width, view.height) if cells is None
                          else cells_rect(view, cells, layout.cells, layout.cell_size))

    def _needs_full(self, view: View) -> bool:
        cached = self._cached_view
        return cached is None or (cached != view and integer_shift(cached, view) is None) \
            or self._cache.size != (view.width, view.height)

    @in_plain_state
    def evaluate(self, view: View) -> str:
        """Bring the cached image up to date for ``view`` without drawing it anywhere; what was evaluated."""
        self._evaluate(view)
        return self.last_evaluation

    def _evaluate(self, view: View) -> None:
        if self._rep is None:
            self._cache.bind(view.width, view.height)
            GL.glClearColor(*BACKGROUND)
            GL.glClear(GL.GL_COLOR_BUFFER_BIT)
            self._cached_view, self.last_evaluation = None, "full"
            self._touch(view)
            self.evaluations["blank"] += 1
            return
        shift = integer_shift(self._cached_view, view)
        needed = self.needed if self.needed is not None and self.needed.shape == self._dirty.shape else None
        if self._needs_full(view) or (needed is None and self._partial):
            self._full(view, needed)
        else:
            self.last_evaluation = "none"
            if shift is not None and shift != (0, 0):
                self._shift(view, *shift)
                self.last_evaluation = "shift"
            todo = self._dirty | self._stale
            if needed is not None:
                self._stale |= self._dirty & ~needed
                todo &= needed
            if todo.any():
                self._evaluate_cells(view, todo)
                if self.last_evaluation == "none":
                    self.last_evaluation = "cells"
        self._cached_view = view
        self._dirty[:] = False
        self.evaluations[self.last_evaluation] += 1

    def _full(self, view: View, needed: np.ndarray | None = None) -> None:
        """Evaluate the whole window, or only the ``needed`` cells it shows (the rest left stale)."""
        self._cache.bind(view.width, view.height)
        self.last_evaluation = "full"
        cells = None if needed is None else visible_cells(view, needed, self._layout.cell_size)
        self._partial = cells is not None
        if cells is None:
            self._pass(view)
            self._unseen[:] = 0.0
            self._stale[:] = False
            return
        self._touch(view)  # a new view: all of it is new
        self._stale[:] = True
        if len(cells):
            self._evaluated(view, cells)

    def _evaluate_cells(self, view: View, todo: np.ndarray) -> None:
        """Re-evaluate the pixels of the ``todo`` cells that the window shows (as runs along rows: about what a
        pass over the same pixels of the window costs, however many)."""
        cells = visible_cells(view, todo, self._layout.cell_size)
        if len(cells):
            self._cache.bind()
            self._evaluated(view, cells)

    def _evaluated(self, view: View, cells: np.ndarray) -> None:
        """Evaluate ``cells`` (flat indices, some) into the bound image: their pixels are current."""
        self._pass(view, cells)
        self._stale.ravel()[cells] = False
        self._unseen.ravel()[cells] = 0.0

    def _shift(self, view: View, dx: int, dy: int) -> None:
        """Move the cached image by ``(dx, dy)`` window pixels and evaluate the strips it uncovers."""
        self._cache.shift(view.width, view.height, dx, dy)
        GL.glEnable(GL.GL_SCISSOR_TEST)
        try:
            for x0, y0, x1, y1 in uncovered(view, dx, dy):
                GL.glScissor(x0, y0, x1 - x0, y1 - y0)
                self._pass(view)
        finally:
            GL.glDisable(GL.GL_SCISSOR_TEST)

    def _pass(self, view: View, cells: np.ndarray | None = None, delta: bool = False) -> None:
        """Run the shader over the window or over the listed cells (flat indices), into the bound framebuffer.

        The cells are drawn as runs along their rows.  ``delta``: the change tables stand in for the data.
        """
        self._touch(view, cells)
        listed = None
        if cells is not None:
            grid = np.zeros(self._layout.cells**2, bool)
            grid[cells] = True
            listed = row_runs(grid.reshape(self._layout.cells, -1))
        program = self._program()
        program.use()
        self._data.bind(listed, delta)
        layout = self._layout
        program.set(**UNITS)
        program.set(
            u_origin=(-view.offset_x / view.scale, -view.offset_y / view.scale), u_step=1.0 / view.scale,
            u_window_height=view.height, u_canvas=(layout.width, layout.height), u_cells=layout.cells,
            u_cell_size=layout.cell_size, u_checker=self.checker, u_instanced=int(cells is not None),
            u_cell_origin=(view.offset_x, view.offset_y), u_cell_window=layout.cell_size * view.scale,
            u_window=(view.width, view.height), u_delta=int(delta),
            u_reflect=int(self._reflect),
        )
        self._vao.bind()
        with additive() if delta else nullcontext():
            if listed is not None:
                GL.glDrawArraysInstanced(GL.GL_TRIANGLE_STRIP, 0, 4, len(listed))
            else:
                GL.glDrawArrays(GL.GL_TRIANGLE_STRIP, 0, 4)
        GL.glBindVertexArray(0)
        GL.glUseProgram(0)

    def read(self) -> np.ndarray:
        """The cached image ``(height, width, 4)``, top row first: float32 (unclamped), or uint8 for ``GL_RGBA8``."""
        return self._cache.read()

    def release(self) -> None:
        """Free the GL objects (with the context current); the renderer is unusable afterwards."""
        self._data.release()
        for item in [*self._programs.values(), self._vao, self._cache]:
            item.delete()
        self._programs.clear()
        self._rep = None
