"""A blurred layer on the canvas: ``engine.blur.blurred_within`` on the GPU (``shaders/blur.frag``).

The layer's blur field, evaluated over the window and read back, gives the
``BlurPlan``: the ladder of deviations, the margin of picture the blur needs
around the window, and which 8-pixel tiles of the window need each level
(from the least and greatest deviation in each; the shader finds each
pixel's bracket of the ladder and its place in it from the field, as the CPU
does).  ``BlurFilter`` then blurs one field's image, evaluated over the
window and that margin (reflected at the canvas border), as the CPU does:
the image halved into octaves, each level filtered in two passes on its
octave over the tiles that need it (rectangles drawn instanced,
``shaders/rects.vert``), each bracket's pixels mixed from its two levels.
An edit blurs again only the tiles it reaches (``BlurPlan.within``).
Everything is in GL's pixel order, rows from the bottom.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from OpenGL import GL

from ..engine.blur import LARGEST, MAX_RADIUS, coarse_deviation, kernel_radius, levels, octave, padding, pixel_kernel
from .gl import BufferTexture, Framebuffer, Program, VertexArray, shader_source
from .view import View

#: Window pixels of a side of the tiles by which passes are limited to where a level is needed.
TILE = 8


#: A tile's range of deviations is widened by this share before its brackets are found, so that the shader,
#: finding each pixel's bracket in single precision, never finds one outside it.
ROUNDING = 1e-6


@dataclass(frozen=True)
class BlurPlan:
    """How a window is blurred, from its blur field.

    Attributes
    ----------
    ladder : list of float
        ``engine.blur.levels`` of the field's largest deviation (window pixels).
    largest : float
        That deviation: each pixel's is clamped to it.
    extra, below : int
        The margin of picture needed (``engine.blur.padding``): columns on both sides and rows above, rows below.
    size : tuple of int
        The window's ``(width, height)``.
    lowest, highest : numpy.ndarray
        ``(tile rows, tile columns)``, GL rows: the least and greatest bracket ``k`` (``ladder[k-1] < s <=
        ladder[k]``; 0 where sharp) of the pixels of each tile.
    """

    ladder: list[float]
    largest: float
    extra: int
    below: int
    size: tuple[int, int]
    lowest: np.ndarray
    highest: np.ndarray

    @classmethod
    def of(cls, field: np.ndarray, scale: float, largest: float) -> BlurPlan:
        """The plan for the blur field's values ``field (height, width)`` (document pixels, GL rows) seen at
        ``scale`` window pixels a document pixel, up to its ``largest`` value (``engine.blur.largest_blur``,
        window pixels; at most ``LARGEST``)."""
        height, width = field.shape
        largest = min(largest, LARGEST)
        rows, columns = -(-height // TILE), -(-width // TILE)
        tiled = np.pad(field, ((0, rows * TILE - height), (0, columns * TILE - width)), mode="edge")
        tiled = tiled.reshape(rows, TILE, columns, TILE)
        least = np.clip(tiled.min(axis=(1, 3)).astype(np.float64) * scale, 0.0, largest)
        most = np.clip(tiled.max(axis=(1, 3)).astype(np.float64) * scale, 0.0, largest)
        ladder = levels(largest)
        lowest = np.searchsorted(ladder, least * (1.0 - ROUNDING), side="left")
        highest = np.minimum(np.searchsorted(ladder, most * (1.0 + ROUNDING), side="left"), len(ladder) - 1)
        extra, below = padding(largest, height)
        return cls(ladder, largest, extra, below, (width, height), lowest, highest)

    def within(self, rects: list[tuple[int, int, int, int]]) -> BlurPlan:
        """This plan for the window's GL pixels in ``rects`` ``(x0, y0, x1, y1)`` only (whole tiles about them)."""
        rows, columns = self.lowest.shape
        keep = np.zeros((rows, columns), bool)
        for x0, y0, x1, y1 in rects:
            keep[max(y0 // TILE, 0) : -(-y1 // TILE), max(x0 // TILE, 0) : -(-x1 // TILE)] = True
        return replace(self, lowest=np.where(keep, self.lowest, len(self.ladder)),
                       highest=np.where(keep, self.highest, -1))

    def same_ladder(self, other: BlurPlan) -> bool:
        """True when ``other`` has this plan's ladder and margins (so what it blurred stays right elsewhere)."""
        return (self.ladder, self.largest, self.extra, self.below, self.size) == \
            (other.ladder, other.largest, other.extra, other.below, other.size)

    @property
    def tiles(self) -> int:
        """How many tiles the plan blurs."""
        return int((self.lowest <= self.highest).sum())

    def aligned(self, dx: int, dy: int) -> bool:
        """True when a pan by ``(dx, dy)`` pixels moves the deepest octave's pixels by whole pixels too (so
        that what was blurred, moved, is what blurring afresh gives)."""
        unit = 2 ** octave(self.ladder[-1])
        return dx % unit == 0 and dy % unit == 0

    def padded(self, view: View) -> View:
        """``view`` grown by the margin: what a blurred field is evaluated over."""
        return View(view.scale, view.offset_x + self.extra, view.offset_y + self.extra,
                    view.width + 2 * self.extra, view.height + self.extra + self.below)

    def blend_rects(self, k: int) -> np.ndarray:
        """Window rectangles ``(n, 4)`` holding every pixel of bracket ``k``."""
        width, height = self.size
        rects = column_runs((self.lowest <= k) & (self.highest >= k)) * TILE
        return np.minimum(rects, [width, height, width, height])

    def level_rects(self, k: int, size: tuple[int, int], radius: int) -> tuple[np.ndarray, np.ndarray]:
        """Rectangles of level ``k``'s image (``size``, on its octave) that the brackets ``k`` and ``k + 1``
        read, ``(n, 4)``: for its second (vertical) filter pass, and grown by ``radius`` rows for its first."""
        width, height = self.size
        d = octave(self.ladder[k])
        window = np.minimum(column_runs((self.lowest <= k + 1) & (self.highest >= k)) * TILE,
                            [width, height, width, height])
        fine = window + [self.extra, self.below, self.extra, self.below]  # pixels of the padded picture
        h = 2**d
        first = np.floor((fine[:, :2] + 0.5) / h - 0.5).astype(int)
        last = np.floor((fine[:, 2:] - 0.5) / h - 0.5).astype(int) + 2  # the bilinear's upper neighbours too
        vertical = np.concatenate([first, last], axis=1)
        horizontal = vertical + [0, -radius, 0, radius]
        bounds = [size[0], size[1], size[0], size[1]]
        return np.clip(vertical, 0, bounds), np.clip(horizontal, 0, bounds)


def schedule(plan: BlurPlan, size: tuple[int, int]) -> tuple[list[tuple], np.ndarray]:
    """The passes that blur a padded picture of ``size`` by ``plan``, as ``engine.blur.blurred_within`` goes
    over the ladder, and all their rectangles in one array ``(n, 4)`` float32.

    A step is ``("octave", d, rects)`` (halve octave ``d - 1``), ``("level", k, d, deviation, rects across,
    rects down)`` (filter level ``k`` on octave ``d``), ``("blend", k, rects)`` (bracket ``k``'s pixels from
    levels ``k - 1`` and ``k``) or ``("drop", k)`` (level ``k`` no longer needed); ``rects`` are ``(first,
    count)`` in the array.
    """
    steps: list[tuple] = []
    chunks: list[np.ndarray] = []
    first = 0

    def rects(array: np.ndarray) -> tuple[int, int]:
        nonlocal first
        chunks.append(np.asarray(array, np.float32).reshape(-1, 4))
        first += len(array)
        return first - len(array), len(array)

    sizes, made = [size], {0}
    for k in range(len(plan.ladder)):
        blend = plan.blend_rects(k)
        if len(blend) == 0:
            if k - 1 in made - {0}:
                steps.append(("drop", k - 1))
                made.discard(k - 1)
            continue
        for needed in sorted({max(k - 1, 0), k} - made):
            d = octave(plan.ladder[needed])
            while len(sizes) <= d:
                sizes.append((sizes[-1][0] // 2, sizes[-1][1] // 2))
                steps.append(("octave", len(sizes) - 1, rects(np.array([[0, 0, *sizes[-1]]]))))
            sigma = coarse_deviation(plan.ladder[needed], d)
            down, across = plan.level_rects(needed, sizes[d], kernel_radius(sigma))
            steps.append(("level", needed, d, sigma, rects(across), rects(down)))
            made.add(needed)
        steps.append(("blend", k, rects(blend)))
        if k > 0:
            steps.append(("drop", k - 1))
            made.discard(k - 1)
    return steps, np.concatenate(chunks) if chunks else np.zeros((0, 4), np.float32)


def column_runs(needed: np.ndarray) -> np.ndarray:
    """The ``True`` tiles of ``needed (rows, columns)`` as rectangles ``(x0, y0, x1, y1)`` in tiles, one per
    run of them down a column."""
    rows, columns = needed.shape
    framed = np.zeros((columns, rows + 2), bool)
    framed[:, 1:-1] = needed.T
    change = np.diff(framed.astype(np.int8), axis=1)
    column, start = np.nonzero(change == 1)
    _, stop = np.nonzero(change == -1)
    return np.stack([column, start, column + 1, stop], axis=1)


class BlurFilter:
    """One field's window image blurred by its layer's ``BlurPlan``; ``output`` holds the result.

    Parameters
    ----------
    programs : tuple of Program
        ``rects.vert`` with ``blur.frag``'s three modes (``BlurFilter.programs``), shared by every filter of a
        context.
    vao : VertexArray
    rects : BufferTexture
        ``GL_RGBA32F``, for the rectangles of each pass (shared too).
    pool : FramebufferPool
        The float images a run works in (shared: filters run one after the other).
    """

    def __init__(self, programs: tuple[Program, Program, Program], vao: VertexArray, rects: BufferTexture,
                 pool: FramebufferPool) -> None:
        self._programs, self._vao, self._rects, self._pool = programs, vao, rects, pool
        self.output = Framebuffer(GL.GL_RGBA32F)

    @staticmethod
    def programs() -> tuple[Program, Program, Program]:
        """The halving, filtering and blending programs."""
        return tuple(Program(shader_source("rects.vert"), shader_source("blur.frag", {"MODE": mode,
                                                                                      "MAX_RADIUS": MAX_RADIUS}),
                             label=f"blur shader ({name})") for mode, name in enumerate(("halve", "filter", "blend")))

    def run(self, source: Framebuffer, plan: BlurPlan, field: Framebuffer, scale: float) -> None:
        """Blur ``source`` (the field over ``plan.padded``'s view) into ``output`` (the window's size) by the
        blur ``field`` (the window's, document pixels) seen at ``scale``."""
        steps, rects = schedule(plan, (source.width, source.height))
        halve, filtering, blend = self._programs
        for program in self._programs:
            program.use()
            program.set(u_source=0, u_lower=1, u_upper=2, u_sigma=3, u_rects=4, u_extra=(plan.extra, plan.below),
                        u_scale=scale, u_largest=plan.largest)
        self._vao.bind()
        self._rects.set_data(rects)  # once: changing it between passes would make the driver wait for them
        self._rects.bind(4)
        self.output.resize(*plan.size)
        octaves, made = [source], {0: (source, 0)}
        try:
            for step in steps:
                kind, k = step[0], step[1]
                if kind == "octave":
                    finer = octaves[-1]
                    octaves.append(self._pool.take((finer.width // 2, finer.height // 2)))
                    self._pass(halve, octaves[-1], finer, step[2])
                elif kind == "level":
                    d, sigma, across_rects, rects_down = step[2:]
                    image = octaves[d]
                    size = (image.width, image.height)
                    across, level = self._pool.take(size), self._pool.take(size)
                    weights = {"u_radius": kernel_radius(sigma), "u_weights": pixel_kernel(sigma)}
                    self._pass(filtering, across, image, across_rects, u_axis=0, **weights)
                    self._pass(filtering, level, across, rects_down, u_axis=1, **weights)
                    self._pool.give_back(across)
                    made[k] = (level, d)
                elif kind == "blend":
                    (lower, lower_octave), (upper, upper_octave) = made[max(k - 1, 0)], made[k]
                    for unit, texture in ((1, lower.texture), (2, upper.texture), (3, field.texture)):
                        GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
                        GL.glBindTexture(GL.GL_TEXTURE_2D, texture)
                    low, high = plan.ladder[k - 1] if k else -1.0, plan.ladder[k]  # bracket 0: the picture
                    self._pass(blend, self.output, None, step[2], u_low=low, u_high=high,
                               u_lower_octave=lower_octave, u_upper_octave=upper_octave)
                elif k in made:  # "drop": no longer needed
                    level = made.pop(k)[0]
                    if level is not source:
                        self._pool.give_back(level)
        finally:
            for level, _ in made.values():
                if level is not source:
                    self._pool.give_back(level)
            for image in octaves[1:]:
                self._pool.give_back(image)
            for unit in (3, 2, 1, 0):
                GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
                GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
            GL.glBindVertexArray(0)
            GL.glUseProgram(0)

    @staticmethod
    def _pass(program: Program, target: Framebuffer, source: Framebuffer | None, rects: tuple[int, int],
              **uniforms) -> None:
        """Draw the rectangles ``rects`` (first, count) of the run's list into ``target`` with ``program``,
        reading ``source``."""
        target.bind()
        if source is not None:
            GL.glActiveTexture(GL.GL_TEXTURE0)
            GL.glBindTexture(GL.GL_TEXTURE_2D, source.texture)
        program.use()
        program.set(u_target=(target.width, target.height), u_first=rects[0], **uniforms)
        GL.glDrawArraysInstanced(GL.GL_TRIANGLE_STRIP, 0, 4, rects[1])

    def shift(self, dx: int, dy: int) -> None:
        """Move ``output`` by ``(dx, dy)`` window pixels (y down), for a pan."""
        spare = self._pool.take((self.output.width, self.output.height))
        self.output.blit_to(spare.handle, dx, -dy)  # GL rows go up
        self._pool.give_back(self.output)
        self.output = spare

    def delete(self) -> None:
        self.output.delete()


class FramebufferPool:
    """Float framebuffers by size, for passes to borrow and give back (kept for the next run)."""

    def __init__(self) -> None:
        self._free: dict[tuple[int, int], list[Framebuffer]] = {}

    def take(self, size: tuple[int, int]) -> Framebuffer:
        free = self._free.setdefault(size, [])
        framebuffer = free.pop() if free else Framebuffer(GL.GL_RGBA32F)
        framebuffer.resize(*size)
        return framebuffer

    def give_back(self, framebuffer: Framebuffer) -> None:
        self._free.setdefault((framebuffer.width, framebuffer.height), []).append(framebuffer)

    def delete(self) -> None:
        for free in self._free.values():
            for framebuffer in free:
                framebuffer.delete()
        self._free.clear()


def read_first_channel(framebuffer: Framebuffer) -> np.ndarray:
    """The red channel of a float framebuffer, ``(height, width)`` float32, GL rows (bottom first)."""
    GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, framebuffer.handle)
    GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
    data = GL.glReadPixels(0, 0, framebuffer.width, framebuffer.height, GL.GL_RED, GL.GL_FLOAT)
    return np.frombuffer(data, np.float32).reshape(framebuffer.height, framebuffer.width)
