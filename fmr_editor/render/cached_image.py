"""The canvas's cached image: the evaluated window, and the 8-bit copy a redraw shows.

A float image (the default) keeps unclamped colours, to which a change can be
added; it is converted into an 8-bit copy once per change (only the part that
changed: ``touch``), so that plain redraws copy a quarter of the bytes.  A pan
moves the image into a spare framebuffer (``shift``).
"""

from __future__ import annotations

from OpenGL import GL

from .gl import Framebuffer
from .view import View

#: The window's colour around the canvas, and before the first image.
BACKGROUND = (0.7, 0.7, 0.7, 1.0)


class CachedImage:
    """A window-sized framebuffer of ``cache_format`` with its spare and its 8-bit copy (for float formats).

    GL calls need the caller's context current.
    """

    def __init__(self, cache_format: int) -> None:
        self.image = Framebuffer(cache_format)
        self._spare = Framebuffer(cache_format)
        self.additive = cache_format == GL.GL_RGBA32F
        self._display = Framebuffer(GL.GL_RGBA8) if self.additive else None
        self._stale: tuple[int, int, int, int] | None = None  # GL pixels of the image not yet in the copy
        self._changed: tuple[int, int, int, int] | None = None  # GL pixels changed since take_changed

    @property
    def size(self) -> tuple[int, int]:
        return self.image.width, self.image.height

    def bind(self, width: int | None = None, height: int | None = None) -> None:
        """Draw into the image from now on (resized to ``width x height`` first, when given)."""
        if width is not None:
            self.image.resize(width, height)
        self.image.bind()

    def touch(self, rect: tuple[int, int, int, int]) -> None:
        """Note that the GL pixels ``(x0, y0, x1, y1)`` of the image changed."""
        self._stale = union(self._stale, rect)
        self._changed = union(self._changed, rect)

    def take_changed(self) -> tuple[int, int, int, int] | None:
        """The GL pixels changed since the last call (None: none), for a reader of the image."""
        changed, self._changed = self._changed, None
        return changed

    def shown(self) -> Framebuffer:
        """The image as the window shows it (its 8-bit copy, brought up to date, for a float image)."""
        if self._display is None:
            return self.image
        width, height = self.size
        if (self._display.width, self._display.height) != (width, height):
            self._display.resize(width, height)
            self._stale = (0, 0, width, height)
        if self._stale is not None:
            x0, y0, x1, y1 = self._stale
            GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self.image.handle)
            GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, self._display.handle)
            GL.glBlitFramebuffer(x0, y0, x1, y1, x0, y0, x1, y1, GL.GL_COLOR_BUFFER_BIT, GL.GL_NEAREST)
            self._stale = None
        return self._display

    def shift(self, width: int, height: int, dx: int, dy: int) -> None:
        """Move the image by ``(dx, dy)`` window pixels (y down) at size ``width x height``; then draw into it."""
        self._spare.resize(width, height)
        self.image.blit_to(self._spare.handle, dx, -dy)  # GL rows go up
        self.image, self._spare = self._spare, self.image
        self.touch((0, 0, width, height))
        self.image.bind()

    def read(self):
        return self.image.read()

    def delete(self) -> None:
        for item in (self.image, self._spare, self._display):
            if item is not None:
                item.delete()


def union(a: tuple[int, int, int, int] | None, b: tuple[int, int, int, int] | None) -> tuple | None:
    """The smallest rectangle ``(x0, y0, x1, y1)`` holding both (None is empty)."""
    if a is None or b is None:
        return a if b is None else b
    return (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))


def show_scaled(source: Framebuffer, cached: View, view: View, target: int) -> None:
    """``source``, an image of the window seen through ``cached``, scaled and moved to ``view``, over a plain
    background, into framebuffer ``target`` (a zoom's quick preview)."""
    GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, target)
    GL.glClearColor(*BACKGROUND)
    GL.glClear(GL.GL_COLOR_BUFFER_BIT)
    ratio = cached.scale / view.scale  # cached window = target window * ratio + shift
    rect = []
    for offset, cached_offset, size, cached_size in ((view.offset_x, cached.offset_x, view.width, cached.width),
                                                    (view.offset_y, cached.offset_y, view.height, cached.height)):
        shift = cached_offset - offset * ratio
        low, high = max(shift, 0.0), min(size * ratio + shift, float(cached_size))
        if high <= low:
            return
        rect.append((low, high, (low - shift) / ratio, (high - shift) / ratio))
    (sx0, sx1, dx0, dx1), (sy0, sy1, dy0, dy1) = rect
    GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, source.handle)
    GL.glBlitFramebuffer(round(sx0), round(cached.height - sy1), round(sx1), round(cached.height - sy0),
                         round(dx0), round(view.height - dy1), round(dx1), round(view.height - dy0),
                         GL.GL_COLOR_BUFFER_BIT, GL.GL_LINEAR)
