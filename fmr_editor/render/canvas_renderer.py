"""The shader-rendered canvas: a representation on the GPU, evaluated per window pixel.

``CanvasRenderer`` keeps a representation in texture buffers (``packing``
says how) and evaluates it in ``shaders/canvas.frag`` into a cached image of
the window's size; ``draw`` copies that image to the caller's framebuffer and
re-evaluates only what is out of date:

- nothing, when neither the data nor the view changed (a redraw is one blit);
- the cells ``update`` reported changed, as one quad per cell;
- after a pan by whole window pixels, the cached image is moved and only the
  uncovered strips are evaluated;
- the whole window otherwise (zoom, resize, new representation).

The renderer is Qt-free: the caller makes its OpenGL (>= 4.1 core) context
current around every call and passes the framebuffer to draw into.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from OpenGL import GL

from ..engine import Representation
from . import bounds, packing
from .gl import BufferTexture, Framebuffer, Program, VertexArray
from .view import View

#: The repository's shader folder.
SHADER_DIR = Path(__file__).resolve().parents[2] / "shaders"
#: Default ``CanvasRenderer.tolerance``: a twentieth of an 8-bit step.
TOLERANCE = 0.05 / 255
#: A pan within this many window pixels of a whole number of pixels moves the cached image.
SHIFT_TOLERANCE = 1e-6
#: Above this share of the window's pixels in changed cells, the whole window is evaluated instead.
FULL_SHARE = 0.5

_UNITS = {"u_coeffs": 0, "u_segment_start": 1, "u_segments": 2, "u_point_start": 3, "u_point_members": 4,
          "u_points": 5, "u_cell_list": 6}


def shader_source(name: str, defines: dict[str, object] | None = None) -> str:
    """The GLSL source ``shaders/<name>`` with ``#define`` lines inserted after its ``#version`` line."""
    text = (SHADER_DIR / name).read_text()
    version, _, rest = text.partition("\n")
    lines = [f"#define {key} {value}" for key, value in (defines or {}).items()]
    return "\n".join([version, *lines, "#line 2", rest])


@dataclass(frozen=True)
class Layout:
    """What the shader program and the buffers' shapes depend on."""

    cells: int
    cell_size: float
    order: int
    harmonic: bool
    width: int
    height: int

    @classmethod
    def of(cls, rep: Representation) -> Layout:
        return cls(rep.lattice.cells_per_side, rep.lattice.cell_size, rep.order, packing.uses_harmonic(rep),
                   rep.width, rep.height)

    @property
    def texels(self) -> int:
        return packing.texels(self.order, self.harmonic)


class CanvasRenderer:
    """Draws a representation's FMR image through a fragment shader, any pan and zoom.

    Parameters
    ----------
    cache_format : int
        Format of the cached image: ``GL_RGBA8`` (default; what a window
        shows) or ``GL_RGBA32F`` (unclamped floats, for checking accuracy).
    checker : float
        Side of the checkerboard squares outside the canvas, in window pixels.
    tolerance : float
        ``update`` re-evaluates a changed cell once its pixels may have moved
        by more than this (colour units) since they were last evaluated.

    Attributes
    ----------
    last_evaluation : str
        What the latest ``draw`` evaluated: ``"none"``, ``"cells"``, ``"shift"``
        (a pan; with any changed cells) or ``"full"``.
    """

    def __init__(self, cache_format: int = GL.GL_RGBA8, checker: float = 8.0, tolerance: float = TOLERANCE) -> None:
        self.checker = float(checker)
        self.tolerance = float(tolerance)
        self._buffers = {
            "u_coeffs": BufferTexture(GL.GL_RGBA32F),
            "u_segment_start": BufferTexture(GL.GL_R32I),
            "u_segments": BufferTexture(GL.GL_RGBA32F),
            "u_point_start": BufferTexture(GL.GL_R32I),
            "u_point_members": BufferTexture(GL.GL_R32I),
            "u_points": BufferTexture(GL.GL_RGBA32F),
            "u_cell_list": BufferTexture(GL.GL_R32I),
        }
        self._vao = VertexArray()
        self._cache = Framebuffer(cache_format)
        self._spare = Framebuffer(cache_format)
        self._programs: dict[tuple[int, bool], Program] = {}
        self._rep: Representation | None = None
        self._layout: Layout | None = None
        self._dirty: np.ndarray | None = None  # cells to evaluate again; None: no cached image
        self._mirror = np.zeros((0, 0), np.float32)  # the coefficients as uploaded, a row per cell
        self._unseen = np.zeros((0, 0))  # bound on each cell's change since its pixels were evaluated
        self._cached_view: View | None = None
        self.last_evaluation = "none"

    # -- data ---------------------------------------------------------------------------------
    @property
    def representation(self) -> Representation | None:
        return self._rep

    def upload(self, rep: Representation, polynomials: np.ndarray | None = None) -> None:
        """Upload all of ``rep``; the next ``draw`` evaluates the whole window.

        Parameters
        ----------
        rep : Representation
        polynomials : numpy.ndarray, optional
            ``rep.polynomials()``, to be read instead of ``rep``'s expansions
            (which a ``LiveRepresentation`` on another thread changes in place).
        """
        self._layout = Layout.of(rep)
        n = self._layout.cells
        self._mirror = packing.cell_coefficients(rep, polynomials=polynomials).reshape(n * n, -1)
        self._buffers["u_coeffs"].set_data(self._mirror)
        self._unseen = np.zeros((n, n))
        self._upload_segments(rep)
        self._upload_points(rep)
        self._rep = rep
        self._dirty = None
        self._cached_view = None

    def update(self, rep: Representation, changed: np.ndarray, polynomials: np.ndarray | None = None) -> None:
        """Go over to ``rep``, whose pixels differ from the uploaded one's only in the ``changed`` cells.

        Only those cells' coefficients are uploaded; segments and near points
        are uploaded whole when they are other arrays.  A representation on
        another lattice (or of another order, or gaining or losing points) is
        uploaded whole.  Of the changed cells, the next ``draw`` re-evaluates
        those whose pixels may have moved by more than ``tolerance`` since they
        were last evaluated (``bounds``); the others keep their pixels.

        Parameters
        ----------
        rep : Representation
        changed : numpy.ndarray
            ``(2^L, 2^L)`` bool, as ``engine.Update.changed``.
        polynomials : numpy.ndarray, optional
            As for ``upload``.
        """
        if self._rep is None or Layout.of(rep) != self._layout:
            self.upload(rep, polynomials)
            return
        changed = np.asarray(changed, bool)
        n = self._layout.cells
        if changed.shape != (n, n):
            raise ValueError(f"changed must be ({n}, {n})")
        cells = np.flatnonzero(changed)
        fresh = packing.cell_coefficients(rep, cells, polynomials=polynomials).reshape(len(cells), -1)
        moved = bounds.far_bound(fresh - self._mirror[cells], self._layout.order, self._layout.harmonic)
        self._mirror[cells] = fresh
        texels = self._layout.texels
        for start, stop in packing.cell_runs(cells):
            self._buffers["u_coeffs"].set_subdata(start * texels, self._mirror[start:stop])
        old = self._rep
        near = bounds.near_bound(old, rep)
        if rep.segments is not old.segments or rep.cell_start is not old.cell_start:
            self._upload_segments(rep)
        if _near(rep) is not _near(old):
            self._upload_points(rep)
            near = None
        moved += np.inf if near is None else near.ravel()[cells]
        self._rep = rep
        unseen = self._unseen.ravel()
        unseen[cells] += moved
        show = cells[unseen[cells] > self.tolerance]
        unseen[show] = 0.0
        if self._dirty is not None:
            self._dirty.ravel()[show] = True

    def _upload_segments(self, rep: Representation) -> None:
        table = packing.segment_table(rep)
        self._buffers["u_segments"].set_data(table.texels)
        self._buffers["u_segment_start"].set_data(table.cell_start)

    def _upload_points(self, rep: Representation) -> None:
        table = packing.point_table(rep)
        self._buffers["u_points"].set_data(table.texels)
        self._buffers["u_point_start"].set_data(table.start)
        self._buffers["u_point_members"].set_data(table.members)

    def invalidate(self) -> None:
        """Forget the cached image: the next ``draw`` evaluates the whole window."""
        self._cached_view = None
        self._dirty = None

    # -- drawing ------------------------------------------------------------------------------
    def _program(self) -> Program:
        key = (self._layout.order, self._layout.harmonic)
        if key not in self._programs:
            defines = {"ORDER": key[0], "HARMONIC": int(key[1]), "COEFF_TEXELS": self._layout.texels}
            self._programs[key] = Program(shader_source("canvas.vert"), shader_source("canvas.frag", defines),
                                          label="canvas shader")
        return self._programs[key]

    def draw(self, view: View, target: int = 0) -> None:
        """Bring the cached image up to date for ``view`` and copy it into framebuffer ``target``.

        Parameters
        ----------
        view : View
            Pan and zoom; its size is the target's size in pixels.
        target : int
            Framebuffer object to draw into (0: the context's default one).
        """
        self._evaluate(view)
        self._cache.blit_to(target)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, target)

    def evaluate(self, view: View) -> str:
        """Bring the cached image up to date for ``view`` without drawing it anywhere; what was evaluated."""
        self._evaluate(view)
        return self.last_evaluation

    def _evaluate(self, view: View) -> None:
        if self._rep is None:
            self._cache.resize(view.width, view.height)
            self._cache.bind()
            GL.glClearColor(0.7, 0.7, 0.7, 1.0)
            GL.glClear(GL.GL_COLOR_BUFFER_BIT)
            self._cached_view, self.last_evaluation = None, "full"
            return
        cached = self._cached_view
        shift = _integer_shift(cached, view)
        if cached is None or (cached != view and shift is None) or self._cache.width != view.width \
                or self._cache.height != view.height:
            self._cache.resize(view.width, view.height)
            self._cache.bind()
            self._pass(view)
            self.last_evaluation = "full"
            self._unseen[:] = 0.0
        else:
            self.last_evaluation = "none"
            if shift is not None and shift != (0, 0):
                self._shift(view, *shift)
                self.last_evaluation = "shift"
            if self._dirty is not None and self._dirty.any():
                self._evaluate_cells(view)
                if self.last_evaluation == "none":
                    self.last_evaluation = "cells"
        self._cached_view = view
        self._dirty = np.zeros((self._layout.cells,) * 2, bool)

    def _evaluate_cells(self, view: View) -> None:
        """Re-evaluate the pixels of the dirty cells that the window shows."""
        n, size = self._layout.cells, self._layout.cell_size * view.scale
        rows, columns = np.nonzero(self._dirty)
        visible = ((columns + 1) * size + view.offset_x >= -1) & (columns * size + view.offset_x <= view.width + 1) \
            & ((rows + 1) * size + view.offset_y >= -1) & (rows * size + view.offset_y <= view.height + 1)
        cells = (rows * n + columns)[visible].astype(np.int32)
        if len(cells) == 0:
            return
        self._cache.bind()
        if len(cells) * (size + 2) ** 2 > FULL_SHARE * view.width * view.height:
            self._pass(view)
            self.last_evaluation = "full"
            self._unseen[:] = 0.0
            return
        self._buffers["u_cell_list"].set_data(cells)
        self._pass(view, instances=len(cells))

    def _shift(self, view: View, dx: int, dy: int) -> None:
        """Move the cached image by ``(dx, dy)`` window pixels and evaluate the strips it uncovers."""
        self._spare.resize(view.width, view.height)
        self._cache.blit_to(self._spare.handle, dx, -dy)  # GL rows go up
        self._cache, self._spare = self._spare, self._cache
        self._cache.bind()
        w, h = view.width, view.height
        strips = []  # (x, y, width, height) in GL pixels
        if dx > 0:
            strips.append((0, 0, min(dx, w), h))
        elif dx < 0:
            strips.append((max(w + dx, 0), 0, min(-dx, w), h))
        if dy > 0:  # uncovered window rows at the top: GL rows at the top end
            strips.append((0, max(h - dy, 0), w, min(dy, h)))
        elif dy < 0:
            strips.append((0, 0, w, min(-dy, h)))
        GL.glEnable(GL.GL_SCISSOR_TEST)
        try:
            for x, y, sw, sh in strips:
                GL.glScissor(x, y, sw, sh)
                self._pass(view)
        finally:
            GL.glDisable(GL.GL_SCISSOR_TEST)

    def _pass(self, view: View, instances: int = 0) -> None:
        """Run the shader over the window (``instances == 0``) or over the listed cells, into the bound framebuffer."""
        program = self._program()
        program.use()
        for name, unit in _UNITS.items():
            self._buffers[name].bind(unit)
        layout = self._layout
        program.set(**_UNITS)
        program.set(
            u_origin=(-view.offset_x / view.scale, -view.offset_y / view.scale), u_step=1.0 / view.scale,
            u_window_height=view.height, u_canvas=(layout.width, layout.height), u_cells=layout.cells,
            u_cell_size=layout.cell_size, u_checker=self.checker, u_instanced=int(instances > 0),
            u_cell_origin=(view.offset_x, view.offset_y), u_cell_window=layout.cell_size * view.scale,
            u_window=(view.width, view.height),
        )
        GL.glDisable(GL.GL_BLEND)
        GL.glDisable(GL.GL_DEPTH_TEST)
        self._vao.bind()
        if instances:
            GL.glDrawArraysInstanced(GL.GL_TRIANGLE_STRIP, 0, 4, instances)
        else:
            GL.glDrawArrays(GL.GL_TRIANGLE_STRIP, 0, 4)
        GL.glBindVertexArray(0)
        GL.glUseProgram(0)

    def read(self) -> np.ndarray:
        """The cached image ``(height, width, 4)``, top row first: uint8, or float32 for a float cache."""
        return self._cache.read()

    def release(self) -> None:
        """Free the GL objects (with the context current); the renderer is unusable afterwards."""
        for item in [*self._buffers.values(), *self._programs.values(), self._vao, self._cache, self._spare]:
            item.delete()
        self._programs.clear()
        self._rep = None


def _near(rep: Representation):
    return None if rep.points is None else rep.points.near


def _integer_shift(before: View | None, after: View) -> tuple[int, int] | None:
    """``(dx, dy)`` when ``after`` is ``before`` panned by whole window pixels, else None."""
    if before is None or (before.scale, before.width, before.height) != (after.scale, after.width, after.height):
        return None
    dx, dy = after.offset_x - before.offset_x, after.offset_y - before.offset_y
    if abs(dx - round(dx)) > SHIFT_TOLERANCE or abs(dy - round(dy)) > SHIFT_TOLERANCE:
        return None
    return int(dx), int(dy)
