"""A layered picture on the GPU: one ``CanvasRenderer`` per layer image and mask, composed per window pixel.

Each field (a layer's image, a mask) keeps its own cached window image and
re-evaluates only its changed cells, so an edit to one layer costs what it
costs in a one-layer document.  A translucent layer's alpha field, made of its
image's segments, is drawn in the image's fourth channel (``LayerFields.carries_alpha``,
``packing``): the segments' integrals, the costly part, are shared, and the
layer costs 1.15-1.2x an opaque one, not twice.  Drawing brings every shown
field's image up to date and, when any of them or the layers' settings changed, composes them
bottom up into a float image, ``m S(V) + (1 - m) below`` (``m`` with the alpha
field's clamped value in it, for a translucent layer), as
``engine.composite.compose`` on the CPU: all layers in one pass
(``shaders/layers.frag``, a program for each arrangement of layers, what a layer
does not read or apply compiled out), or a few where they read more textures
than a pass may; over the whole window after a change of the layers' settings,
else over the rectangle whose fields changed; a redraw with nothing changed
copies that image.  A layer is evaluated and composed only on the cells where
it may show (``culling``: not where its mask surely hides it or a layer above
surely covers it).  A picture of one plain layer is drawn by its field's
renderer alone, exactly as before layers.
"""

from __future__ import annotations

from collections import Counter
from contextlib import nullcontext
from dataclasses import replace

import numpy as np
from OpenGL import GL

from ..engine import NEGLIGIBLE_WEIGHT, SCALAR_WEIGHTS, Composite, FieldKey, LayerFields, Representation, Role
from ..engine.blur import largest_blur
from . import culling
from .blur_filter import BlurFilter, BlurPlan, FramebufferPool, read_first_channel
from .cached_image import CachedImage, show_scaled, union
from .canvas_renderer import TOLERANCE, CanvasRenderer
from .gl import BufferTexture, Program, VertexArray, in_plain_state, over, plain_state, shader_source, through_below
from .view import View, beyond, cells_rect, integer_shift, row_runs, uncovered, visible_grid

#: The fields of a blurred layer that are evaluated beyond the window, reflected at the canvas border.
REFLECTED = (Role.IMAGE, Role.ALPHA, Role.BLUR)

#: ``changed`` of a field to upload whole (a new lattice, or changes merged across lattices).
WHOLE = None
#: The texture unit of the cell list of the checkerboard's and the tint's passes (``shaders/compose.frag``), after
#: their mask; the layers' passes (``shaders/layers.frag``) read theirs from unit 0, their images after it.
CELL_LIST_UNIT = 2
#: Layers one pass composes at most (a run's code gives two bits a layer).
PASS_LAYERS = 8


def picture_of(rep: Representation | Composite) -> Composite:
    """``rep`` as a picture: a representation is a one-layer picture (layer id 0)."""
    if isinstance(rep, Composite):
        return rep
    return Composite(rep.width, rep.height, (LayerFields(rep),))


def merge_changes(before: dict[FieldKey, np.ndarray | None],
                  after: dict[FieldKey, np.ndarray | None]) -> dict[FieldKey, np.ndarray | None]:
    """Changes of two updates in a row, by field (``WHOLE`` where the cell grids differ)."""
    merged = dict(before)
    for key, changed in after.items():
        old = merged.get(key, False)
        if old is False:
            merged[key] = None if changed is None else changed.copy()
        elif old is None or changed is None or old.shape != changed.shape:
            merged[key] = WHOLE
        else:
            merged[key] = old | changed
    return merged


class PictureRenderer:
    """Draws a ``Composite`` (or one representation) through the canvas shader, any pan and zoom.

    Parameters are ``CanvasRenderer``'s, for every field's renderer.

    Attributes
    ----------
    renderers : dict
        ``CanvasRenderer`` by ``FieldKey``.
    composed : int
        How many draws composed the layers (a redraw of an unchanged picture does not).
    blurred : int
        How many times a field was blurred (``render.blur_filter``) since the renderer was made.
    blurred_tiles : int
        How many of the window's tiles (``blur_filter.TILE`` pixels a side) those runs blurred, in all.
    mask_overlay : int or None
        The id of a layer whose mask is tinted over the picture (red where it
        hides the layer), while the user edits it; None for none.
    """

    def __init__(self, cache_format: int = GL.GL_RGBA32F, checker: float = 8.0, tolerance: float = TOLERANCE) -> None:
        self._options = (cache_format, checker, tolerance)
        self.renderers: dict[FieldKey, CanvasRenderer] = {}
        self._picture: Composite | None = None
        self._composed = CachedImage(GL.GL_RGBA32F)
        self._composed_view: View | None = None  # what the composed image shows; None: compose it all again
        self._pending = False  # fields may have something to evaluate (an update since the last draw)
        self._programs: dict[tuple, Program] = {}  # compose programs by what they read
        self._units: int | None = None  # the texture units a pass's fragments may read
        self._alphas: dict[FieldKey, Representation] = {}  # alpha fields drawn in their image's fourth channel
        self._vao: VertexArray | None = None
        self._cell_list: BufferTexture | None = None  # the cells a compose pass draws
        self._plan: culling.CullPlan | None = None  # where each layer shows, as last composed
        self._planned: tuple[tuple, culling.CullPlan | None] | None = None  # the latest plan and what it was made of
        self._last_key: FieldKey | None = None
        self._background: CanvasRenderer | None = None  # draws the plain background when there is no picture
        self._overlay: int | None = None
        self._overlay_fields = False
        self.composed = 0
        self._filters: dict[FieldKey, BlurFilter] = {}  # blurred fields' filters
        self._plans: dict[int, tuple[View, BlurPlan]] = {}  # by blurred layer id: the view it was made for
        self._blur_gl: tuple[tuple[Program, ...], VertexArray, BufferTexture, FramebufferPool] | None = None
        self._edited: set[FieldKey] = set()  # fields whose data changed since they were last blurred
        self.blurred = 0
        self.blurred_tiles = 0

    @property
    def mask_overlay(self) -> int | None:
        return self._overlay

    @mask_overlay.setter
    def mask_overlay(self, layer_id: int | None) -> None:
        self._overlay = layer_id
        self._overlay_fields = True  # the tinted layer's fields (hidden or not) are uploaded at the next draw
        self._composed_view = None
        self._pending = True

    # -- data ---------------------------------------------------------------------------------
    @property
    def picture(self) -> Composite | None:
        return self._picture

    def upload(self, picture: Representation | Composite) -> None:
        """Upload every field of ``picture``; the next ``draw`` evaluates them all."""
        picture = picture_of(picture)
        self.update(picture, {key: WHOLE for key in _fields(picture, self._overlay)})

    def update(self, picture: Representation | Composite,
               changed: dict[FieldKey, np.ndarray | None] | np.ndarray) -> None:
        """Go over to ``picture``, whose fields differ from the uploaded ones only as ``changed`` says.

        A field missing from ``changed`` is unchanged; ``WHOLE`` (None) uploads it whole, as does a field
        not uploaded before.  Fields no layer reads any more are released.  For a representation,
        ``changed`` may be its ``Update.changed``.
        """
        if isinstance(changed, np.ndarray):
            changed = {(0, Role.IMAGE): changed}
        picture = picture_of(picture)
        self._alphas = {(layer.id, Role.IMAGE): layer.alpha for layer in picture.layers if layer.carries_alpha}
        fields = {key: rep for key, rep in _fields(picture, self._overlay).items()
                  if not (key[1] is Role.ALPHA and (key[0], Role.IMAGE) in self._alphas)}
        for key in [key for key in self.renderers if key not in fields]:
            self.renderers.pop(key).release()
        for key, rep in fields.items():
            renderer = self.renderers.get(key)
            alpha, alpha_key = self._alphas.get(key), (key[0], Role.ALPHA)
            change = changed.get(key, False)  # False: unchanged
            if alpha is not None and alpha_key in changed:  # its alpha's change as well
                change = merge_changes({} if change is False else {key: change}, {key: changed[alpha_key]})[key]
            if renderer is None:
                renderer = self.renderers[key] = CanvasRenderer(*self._options, weights=SCALAR_WEIGHTS.get(key[1]))
                renderer.upload(rep, alpha)
            elif change is WHOLE or (renderer.alpha is None) != (alpha is None):
                renderer.upload(rep, alpha)
            elif change is not False and change.any():  # an update that changed no cell keeps the shown one
                renderer.update(rep, change, alpha)
            else:
                continue
            self._last_key = key
            self._edited.add(key)
        blurred = {layer.id for layer in picture.layers if layer.blur is not None}
        for key, renderer in self.renderers.items():
            renderer.reflect = key[0] in blurred and key[1] in REFLECTED
        if self._picture is None or _settings(self._picture) != _settings(picture):
            self._composed_view = None  # layers' opacity, masks, transforms or order: compose everything again
        self._picture = picture
        self._pending = True

    def forget(self) -> None:
        """Drop the picture: ``draw`` shows a plain background until the next ``upload``."""
        for renderer in self.renderers.values():
            renderer.release()
        self.renderers.clear()
        self._picture = None
        self._composed_view = None

    def invalidate(self) -> None:
        """Forget every cached image: the next ``draw`` evaluates the whole window."""
        for renderer in self.renderers.values():
            renderer.invalidate()
        self._composed_view = None
        self._pending = True

    # -- what the tests and the window read ----------------------------------------------------
    @property
    def evaluations(self) -> Counter:
        """What the fields' renderers evaluated, summed (see ``CanvasRenderer.evaluations``)."""
        return sum((renderer.evaluations for renderer in self.renderers.values()), Counter())

    @property
    def last_update(self) -> dict[str, int]:
        """``CanvasRenderer.last_update`` of the field updated last."""
        renderer = self.renderers.get(self._last_key)
        return renderer.last_update if renderer is not None else {}

    @property
    def last_evaluation(self) -> str:
        """``CanvasRenderer.last_evaluation`` of the field updated last."""
        renderer = self.renderers.get(self._last_key)
        return renderer.last_evaluation if renderer is not None else "none"

    def _single(self) -> CanvasRenderer | None:
        """The renderer that draws the picture by itself (all of it: no cell left out): one plain layer shown;
        else None."""
        shown = self._picture.shown if self._picture is not None else ()
        if (len(shown) == 1 and shown[0].covers and shown[0].transform.is_identity and shown[0].blur is None
                and self._overlay is None):
            single = self.renderers[shown[0].id, Role.IMAGE]
            single.needed = None
            return single
        return None

    # -- drawing ------------------------------------------------------------------------------
    def draw(self, view: View, target: int = 0, preview: bool = False) -> None:
        """Bring the fields' images up to date for ``view``, compose them and copy the result into ``target``.

        ``preview`` as ``CanvasRenderer.draw``: while zooming, the last composed image is shown scaled.
        """
        if self._overlay_fields and self._picture is not None:
            self.update(self._picture, {})
        self._overlay_fields = False
        single = self._single() if self._picture is not None else None
        if single is not None or self._picture is None:
            (single or self._blank()).draw(view, target, preview)
            return
        self._draw_layers(view, target, preview)

    @in_plain_state
    def _draw_layers(self, view: View, target: int, preview: bool) -> None:
        if preview and self._composed_view is not None and self._composed_view != view:
            show_scaled(self._composed.shown(), self._composed_view, view, target)
        else:
            self._evaluate(view)
            self._composed.shown().blit_to(target)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, target)

    def _blank(self) -> CanvasRenderer:
        """A renderer without a representation (it draws the plain background)."""
        if self._background is None:
            self._background = CanvasRenderer(*self._options)
        return self._background

    def evaluate(self, view: View) -> str:
        """Bring the image for ``view`` up to date without drawing it anywhere; what the fields evaluated."""
        if self._picture is None:
            return self._blank().evaluate(view)
        single = self._single()
        if single is not None:
            return single.evaluate(view)
        with plain_state():
            return self._evaluate(view)

    def _evaluate(self, view: View) -> str:
        if not self._pending and self._composed_view == view:  # a redraw: the composed image is current
            return "none"
        # With every layer hidden the picture is clear (the checkerboard); drawing the bottom layer at opacity 0
        # composes that.
        shown = self._picture.shown or (replace(self._picture.layers[0], opacity=0.0),)
        tinted = next((layer for layer in self._picture.layers if layer.id == self._overlay), None)
        blurred = {layer.id: layer for layer in shown if layer.blur is not None}
        keys = {(layer.id, role) for layer in shown for role in self._textures(layer)}  # a carried alpha: none
        if tinted is not None:
            keys |= {(tinted.id, Role.IMAGE)} | ({(tinted.id, Role.MASK)} if tinted.mask is not None else set())
        keys = {key for key in keys if not (key[0] in blurred and key[1] in REFLECTED)}
        for key in [key for key in self._filters if key[0] not in blurred]:
            self._filters.pop(key).delete()
        if not self._filters and self._blur_gl is not None:
            self._blur_gl[3].delete()  # the blur's working images, while nothing is blurred
        self._plans = {key: plan for key, plan in self._plans.items() if key in blurred}
        plan = self._cull(shown, tinted, blurred)
        for key, renderer in self.renderers.items():
            exempt = plan is None or key not in keys or (tinted is not None and key == (tinted.id, Role.MASK))
            renderer.needed = None if exempt else plan.needed(key, renderer.representation.lattice.cells_per_side)
        evaluated = {self.renderers[key].evaluate(view) for key in keys}
        changed = None
        if plan is not self._plan and self._composed_view == view:  # where a layer shows or no longer does
            if plan is None or self._plan is None:
                self._composed_view = None
            else:
                differ = plan.changed(self._plan)
                if differ is not None:
                    changed = cells_rect(view, np.flatnonzero(differ), plan.cells, plan.cell_size)
        self._plan = plan
        for layer in blurred.values():
            region = self._blur(layer, view)
            if region is not None:
                changed = union(changed, region)
                evaluated.add("blur")
        for renderer in self.renderers.values():  # every field's, so that none carries old changes over
            changed = union(changed, renderer.take_changed())
        if self._composed_view != view:
            self._compose(view, shown, tinted)
        elif changed is not None:
            self._compose(view, shown, tinted, changed)
        self._pending = False
        return "none" if evaluated <= {"none"} else "fields"

    def _cull(self, shown: tuple[LayerFields, ...], tinted: LayerFields | None,
              blurred: dict[int, LayerFields]) -> culling.CullPlan | None:
        """Where each shown layer may show (the last plan while nothing it depends on changed)."""
        made_of = (shown, tinted.id if tinted is not None else None, tuple(blurred))
        if self._planned is None or self._planned[0] != made_of:
            unbounded = frozenset((layer_id, Role.ALPHA) for layer_id in blurred)  # a blurred alpha
            plan = culling.plan(shown, self._value_bounds, unbounded)
            self._planned = (made_of, plan)
        return self._planned[1]

    def _value_bounds(self, key: FieldKey) -> culling.ValueBounds:
        """``CanvasRenderer.value_bounds`` of field ``key`` (an alpha in its image's fourth channel: that one)."""
        if key[1] is Role.ALPHA and (key[0], Role.IMAGE) in self._alphas:
            return self.renderers[key[0], Role.IMAGE].value_bounds(3)
        return self.renderers[key].value_bounds()

    def _blur(self, layer: LayerFields, view: View) -> tuple[int, int, int, int] | None:
        """Bring ``layer``'s blurred image (and alpha) up to date for ``view``: the GL pixels of the window
        that changed (None: none).  Only what changed is blurred again: where the blur field changed, about
        where the picture changed as far as the blur reaches, and after a pan by whole pixels (and whole
        pixels of the deepest octave) with nothing edited, the strips it uncovers."""
        sigma = self.renderers[layer.id, Role.BLUR]
        keys = {(layer.id, role) for role in REFLECTED}
        edited, self._edited = bool(keys & self._edited), self._edited - keys
        made_for, old = self._plans.get(layer.id, (None, None))
        sigma.evaluate(view)
        whole = (0, 0, view.width, view.height)
        regions = [sigma.take_changed()]
        plan = old
        if regions[0] is not None or made_for != view:
            plan = BlurPlan.of(read_first_channel(sigma.image), view.scale, largest_blur(layer.blur) * view.scale)
            self._plans[layer.id] = (view, plan)
        shift = integer_shift(made_for, view) if old is not None and not edited else None
        moved = shift is not None and shift != (0, 0) and plan.same_ladder(old) and plan.aligned(*shift)
        if moved:
            regions = uncovered(view, *shift)
        elif old is None or made_for != view or not plan.same_ladder(old):
            regions = [whole]
        padded = plan.padded(view)
        fields = [(role, self.renderers[layer.id, role]) for role, _ in layer.read if role is not Role.MASK]
        reach = plan.extra
        for _, renderer in fields:
            renderer.reach = max(plan.extra, plan.below) / view.scale
            renderer.evaluate(padded)
            rect = renderer.take_changed()
            if rect is not None and not moved:  # padded GL pixels: the window's, grown by what the blur reaches
                x0, y0, x1, y1 = rect
                regions.append((x0 - plan.extra - reach, y0 - plan.below - reach,
                                x1 - plan.extra + reach, y1 - plan.below + reach))
        regions = [clipped(rect, view) for rect in regions if rect is not None]
        if not regions:
            return None
        if self._blur_gl is None:
            self._blur_gl = (BlurFilter.programs(), VertexArray(), BufferTexture(GL.GL_RGBA32F), FramebufferPool())
        part = plan.within(regions)
        for role, renderer in fields:
            kept = self._filters.get((layer.id, role))
            if kept is None:
                kept = self._filters[layer.id, role] = BlurFilter(*self._blur_gl)
                part = plan  # a new filter's output is blurred whole
            elif moved:
                kept.shift(*shift)
            kept.run(renderer.image, part, sigma.image, view.scale)
            self.blurred += 1
            self.blurred_tiles += part.tiles
        if part is plan:
            return whole
        changed = None
        for rect in regions:
            changed = union(changed, rect)
        return changed

    def _compose(self, view: View, shown: tuple[LayerFields, ...], tinted: LayerFields | None,
                 rect: tuple[int, int, int, int] | None = None) -> None:
        """Compose the layers into the composed image: all of it, or the GL pixels ``rect`` of it.

        The layers go in one pass (``shaders/layers.frag``), or in a few where they read more textures than one
        pass may; with a plan, as runs of the plan's visible cells, each run saying which layers may show there,
        and the checkerboard beyond the lattice."""
        if self._vao is None:
            self._vao = VertexArray()
            self._cell_list = BufferTexture(GL.GL_R32I)
        self._composed.bind(view.width, view.height)
        self._scissor(rect)
        plan = self._plan
        self._vao.bind()
        if plan is not None:  # the layers' passes draw the lattice's cells
            self._use(False, False, view)
            for x0, y0, x1, y1 in beyond(view, plan.cells * plan.cell_size):  # a pixel into what they draw
                if rect is not None:
                    x0, y0, x1, y1 = max(x0, rect[0]), max(y0, rect[1]), min(x1, rect[2]), min(y1, rect[3])
                if x1 > x0 and y1 > y0:
                    self._scissor((x0, y0, x1, y1))
                    GL.glDrawArrays(GL.GL_TRIANGLE_STRIP, 0, 4)
            self._scissor(rect)
        units = 0
        for index, group in enumerate(self._groups(shown)):
            with through_below() if index else nullcontext():
                units = max(units, self._layers_pass(group, view, first=index == 0))
        if tinted is not None:
            with over():
                units = max(units, self._tint_pass(tinted, view))
        GL.glBindVertexArray(0)
        GL.glUseProgram(0)
        for unit in range(units):
            GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
            GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
            GL.glBindTexture(GL.GL_TEXTURE_BUFFER, 0)
        GL.glActiveTexture(GL.GL_TEXTURE0)
        GL.glDisable(GL.GL_SCISSOR_TEST)
        self._composed.touch(rect or (0, 0, view.width, view.height))
        self._composed_view = view
        self.composed += 1

    @staticmethod
    def _scissor(rect: tuple[int, int, int, int] | None) -> None:
        """Draw into the GL pixels ``rect`` alone from now on (None: all of the target)."""
        if rect is None:
            GL.glDisable(GL.GL_SCISSOR_TEST)
            return
        x0, y0, x1, y1 = rect
        GL.glEnable(GL.GL_SCISSOR_TEST)
        GL.glScissor(x0, y0, max(x1 - x0, 0), max(y1 - y0, 0))

    def _groups(self, shown: tuple[LayerFields, ...]) -> list[tuple[LayerFields, ...]]:
        """``shown`` in runs of layers of one pass each: at most ``PASS_LAYERS``, and textures the units hold."""
        if self._units is None:
            self._units = int(GL.glGetIntegerv(GL.GL_MAX_TEXTURE_IMAGE_UNITS))
        groups: list[list[LayerFields]] = []
        used = 0
        for layer in shown:
            reads = len(self._textures(layer))
            if not groups or len(groups[-1]) == PASS_LAYERS or used + reads > self._units:
                groups.append([])
                used = 0
            groups[-1].append(layer)
            used += reads
        return [tuple(group) for group in groups]

    def _program(self, key: tuple, make) -> Program:
        """The compose program of ``key``, made by ``make()`` (its vertex and fragment sources) the first time."""
        if key not in self._programs:
            self._programs[key] = Program(*make(), label="compose shader")
        return self._programs[key]

    def _view_uniforms(self, program: Program, view: View) -> None:
        program.set(u_origin=(-view.offset_x / view.scale, -view.offset_y / view.scale), u_step=1.0 / view.scale,
                    u_window_height=view.height, u_canvas=(self._picture.width, self._picture.height),
                    u_checker=self._options[1], u_cell_origin=(view.offset_x, view.offset_y),
                    u_window=(view.width, view.height), u_instanced=0)

    def _use(self, tint: bool, masked: bool, view: View) -> Program:
        """Make the program of the checkerboard's pass or (``tint``) of a mask's tint current, its view and units
        set."""
        program = self._program(("tint", tint, masked), lambda: (
            shader_source("canvas.vert"), shader_source("compose.frag", {"TINT": int(tint), "MASKED": int(masked)})))
        program.use()
        program.set(u_mask=1, u_cell_list=CELL_LIST_UNIT)
        self._view_uniforms(program, view)
        return program

    def _layers_pass(self, group: tuple[LayerFields, ...], view: View, first: bool) -> int:
        """Compose ``group`` (over the checkerboard when ``first``, else through ``through_below``) where its layers
        may show; the texture units it used."""
        reads = tuple((layer.masked, TRANSLUCENT[layer.alpha is not None, (layer.id, Role.IMAGE) in self._alphas],
                       not layer.transform.is_identity) for layer in group)
        program = self._program(("layers", first, reads), lambda: _layers_sources(first, reads))
        program.use()
        unit = 1  # unit 0: the cell list
        for k, layer in enumerate(group):
            for role in self._textures(layer):  # its image, mask and alpha: u_image0, u_mask0, u_alpha0 of layer 0
                blurred = self._filters.get((layer.id, role)) if layer.blur is not None else None
                GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
                GL.glBindTexture(GL.GL_TEXTURE_2D, blurred.output.texture if blurred
                                 else self.renderers[layer.id, role].image_texture)
                program.set(**{f"u_{role.value}{k}": unit})
                unit += 1
        enabled = [layer.mask_enabled for layer in group]
        program.set(u_mask_base=[layer.mask_base if on else 1.0 for layer, on in zip(group, enabled)],
                    u_inverted=[int(on and layer.mask_inverted) for layer, on in zip(group, enabled)],
                    u_opacity=[layer.opacity for layer in group],
                    u_matrix=[layer.transform.matrix for layer in group],
                    u_offset=[layer.transform.offset for layer in group], u_negligible=NEGLIGIBLE_WEIGHT,
                    u_cell_list=0)
        self._view_uniforms(program, view)
        plan = self._plan
        if plan is None:
            program.set(u_code=sum(1 << 2 * k for k in range(len(group))))
            GL.glDrawArrays(GL.GL_TRIANGLE_STRIP, 0, 4)
            return unit
        visible = visible_grid(view, plan.cells, plan.cell_size)
        codes = np.zeros((plan.cells, plan.cells), np.int32)
        for k, layer in enumerate(group):
            where = visible if plan.shown[layer.id] is None else plan.shown[layer.id] & visible
            codes |= where.astype(np.int32) << 2 * k
            codes |= (where & plan.whole[layer.id]).astype(np.int32) << 2 * k + 1
        listed = row_runs(visible if first else codes != 0, codes)  # the first pass draws the checkerboard, too
        if len(listed):
            self._cell_list.set_data(listed)
            self._cell_list.bind(0)
            program.set(u_instanced=1, u_cells=plan.cells, u_cell_window=plan.cell_size * view.scale)
            GL.glDrawArraysInstanced(GL.GL_TRIANGLE_STRIP, 0, 4, len(listed))
        return unit

    def _textures(self, layer: LayerFields) -> list[Role]:
        """The fields whose images composing ``layer`` reads: its image, mask and alpha (not one its image
        carries)."""
        return [role for role, _ in layer.read if not (role is Role.ALPHA and (layer.id, Role.IMAGE) in self._alphas)]

    def _tint_pass(self, layer: LayerFields, view: View) -> int:
        """The tint of ``layer``'s mask, enabled or not, over the composed image (bound); the units it used."""
        if layer.mask is not None:
            GL.glActiveTexture(GL.GL_TEXTURE0 + 1)
            GL.glBindTexture(GL.GL_TEXTURE_2D, self.renderers[layer.id, Role.MASK].image_texture)
        program = self._use(True, layer.mask is not None, view)
        program.set(u_mask_base=layer.mask_base, u_inverted=int(layer.mask_inverted))
        GL.glDrawArrays(GL.GL_TRIANGLE_STRIP, 0, 4)
        return 2

    def read(self) -> np.ndarray:
        """The drawn image ``(height, width, 4)`` float32, top row first (a one-layer picture: its field's)."""
        single = self._single()
        return single.read() if single is not None else self._composed.read()

    def release(self) -> None:
        """Free the GL objects (with the context current); the renderer is unusable afterwards."""
        self.forget()
        for item in (*self._programs.values(), self._vao, self._cell_list, self._composed):
            if item is not None:
                item.delete()
        if self._background is not None:
            self._background.release()
        for kept in self._filters.values():
            kept.delete()
        if self._blur_gl is not None:
            programs, *items = self._blur_gl
            for item in (*programs, *items):
                item.delete()
        self._programs.clear()
        self._vao = self._cell_list = self._background = self._blur_gl = None
        self._filters.clear()


#: ``layers.frag``'s ``translucent`` argument by (an alpha field, in the image's fourth channel): none, the alpha
#: field's image, the image's fourth channel.
TRANSLUCENT = {(False, False): 0, (True, False): 1, (True, True): 2}


def _layers_sources(first: bool, reads: tuple[tuple[bool, int, bool], ...]) -> tuple[str, str]:
    """The sources of ``layers.frag``'s program for layers that read a mask or not, their alpha from its own image,
    the layer's or none (``TRANSLUCENT``) and transform their colour or not, ``(masked, translucent, transformed)``
    each, over the checkerboard when ``first``."""
    samplers, calls = [], []
    for k, (masked, translucent, transformed) in enumerate(reads):
        samplers.append(f"uniform sampler2D u_image{k};")
        samplers += [f"uniform sampler2D u_mask{k};"] if masked else []
        samplers += [f"uniform sampler2D u_alpha{k};"] if translucent == 1 else []
        mask = f"u_mask{k}" if masked else f"u_image{k}"
        alpha = f"u_alpha{k}" if translucent == 1 else f"u_image{k}"
        flags = f"{str(masked).lower()}, {translucent}, {str(transformed).lower()}"
        calls.append(f"blend({k}, u_image{k}, {mask}, {alpha}, {flags}, texel);")
    defines = {"LAYERS": len(reads), "FIRST": int(first), "SAMPLERS": " ".join(samplers),
               "BLEND_LAYERS": " ".join(calls)}
    return shader_source("canvas.vert", {"RUN_CODES": 1}), shader_source("layers.frag", defines)


def clipped(rect: tuple[int, int, int, int], view: View) -> tuple[int, int, int, int]:
    """``rect`` (GL pixels) within the window."""
    return (max(rect[0], 0), max(rect[1], 0), min(rect[2], view.width), min(rect[3], view.height))


def _settings(picture: Composite) -> tuple:
    """How ``picture``'s layers are composed (everything but their representations)."""
    return tuple((layer.id, layer.visible, layer.opacity, layer.transform, layer.mask_base, layer.mask_inverted,
                  layer.mask_enabled, layer.mask is None, layer.blur is None) for layer in picture.layers)


def _fields(picture: Composite, overlay: int | None) -> dict[FieldKey, Representation]:
    """The fields of the visible layers, of the tinted one and the bottom layer's image (the checkerboard when
    all are hidden): each costs GPU memory of a window image or two, so a hidden layer's are released (showing
    it again uploads them)."""
    fields = {(picture.layers[0].id, Role.IMAGE): picture.layers[0].image}
    for layer in picture.layers:
        if not layer.visible and layer.id != overlay:
            continue
        fields[layer.id, Role.IMAGE] = layer.image
        if layer.mask is not None:
            fields[layer.id, Role.MASK] = layer.mask
        if layer.alpha is not None:
            fields[layer.id, Role.ALPHA] = layer.alpha
        if layer.blur is not None:
            fields[layer.id, Role.BLUR] = layer.blur
    return fields
