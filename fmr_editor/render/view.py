"""The canvas view: how document pixels map to window pixels (pan and zoom), without GL.

``window = document * scale + offset``, both with y down and the origin at the
top-left corner; window pixel ``(i, j)`` (row, column) covers
``[j, j + 1] x [i, i + 1]`` and is evaluated at its centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

#: Zoom limits (window pixels per document pixel).
MIN_SCALE = 1e-3
MAX_SCALE = 1e5


@dataclass(frozen=True)
class View:
    """Pan, zoom and window size.

    Attributes
    ----------
    scale : float
        Window pixels per document pixel.
    offset_x, offset_y : float
        Window position of the document's origin.
    width, height : int
        Window size in pixels.
    """

    scale: float = 1.0
    offset_x: float = 0.0
    offset_y: float = 0.0
    width: int = 1
    height: int = 1

    def __post_init__(self) -> None:
        if not self.scale > 0:
            raise ValueError("scale must be positive")
        if self.width < 1 or self.height < 1:
            raise ValueError("window size must be positive")

    @classmethod
    def fit(cls, canvas_width: float, canvas_height: float, width: int, height: int, margin: float = 0.0) -> View:
        """The view showing the whole canvas centred in a ``width x height`` window.

        Parameters
        ----------
        margin : float
            Window pixels left free on every side (when the window is big enough).
        """
        free_w, free_h = max(width - 2 * margin, 1.0), max(height - 2 * margin, 1.0)
        scale = min(free_w / canvas_width, free_h / canvas_height)
        return cls(scale, (width - canvas_width * scale) / 2, (height - canvas_height * scale) / 2, width, height)

    def to_document(self, x: float, y: float) -> tuple[float, float]:
        """Document position of window point ``(x, y)``."""
        return (x - self.offset_x) / self.scale, (y - self.offset_y) / self.scale

    def to_window(self, x: float, y: float) -> tuple[float, float]:
        """Window position of document point ``(x, y)``."""
        return x * self.scale + self.offset_x, y * self.scale + self.offset_y

    def panned(self, dx: float, dy: float) -> View:
        """This view moved by ``(dx, dy)`` window pixels."""
        return replace(self, offset_x=self.offset_x + dx, offset_y=self.offset_y + dy)

    def zoomed(self, factor: float, x: float, y: float) -> View:
        """This view zoomed by ``factor`` about window point ``(x, y)``, which stays put.

        The scale is kept within ``[MIN_SCALE, MAX_SCALE]``.
        """
        scale = min(max(self.scale * factor, MIN_SCALE), MAX_SCALE)
        doc_x, doc_y = self.to_document(x, y)
        return replace(self, scale=scale, offset_x=x - doc_x * scale, offset_y=y - doc_y * scale)

    def resized(self, width: int, height: int) -> View:
        """This view in a window of another size (the document stays where it was, from the top-left)."""
        return replace(self, width=int(width), height=int(height))


#: A pan within this many window pixels of a whole number of pixels counts as whole.
SHIFT_TOLERANCE = 1e-6


def integer_shift(before: View | None, after: View) -> tuple[int, int] | None:
    """``(dx, dy)`` when ``after`` is ``before`` panned by whole window pixels, else None."""
    if before is None or (before.scale, before.width, before.height) != (after.scale, after.width, after.height):
        return None
    dx, dy = after.offset_x - before.offset_x, after.offset_y - before.offset_y
    if abs(dx - round(dx)) > SHIFT_TOLERANCE or abs(dy - round(dy)) > SHIFT_TOLERANCE:
        return None
    return int(round(dx)), int(round(dy))


def uncovered(view: View, dx: int, dy: int) -> list[tuple[int, int, int, int]]:
    """The GL pixels ``(x0, y0, x1, y1)`` (rows from the bottom) of the window that a pan by ``(dx, dy)`` window
    pixels (y down) uncovers."""
    w, h = view.width, view.height
    strips = []
    if dx:
        strips.append((0, 0, min(dx, w), h) if dx > 0 else (max(w + dx, 0), 0, w, h))
    if dy:  # uncovered window rows at the top: GL rows at the top end
        strips.append((0, max(h - dy, 0), w, h) if dy > 0 else (0, 0, w, min(-dy, h)))
    return strips


def beyond(view: View, side: float) -> list[tuple[int, int, int, int]]:
    """The GL pixels ``(x0, y0, x1, y1)`` (rows from the bottom) of the window beyond the document's square
    ``[0, side]^2`` (a lattice's), as up to four strips reaching a pixel into it: every pixel whose centre lies
    outside the square is in one."""
    w, h = view.width, view.height
    left, right = view.offset_x, view.offset_x + side * view.scale
    bottom, top = h - (view.offset_y + side * view.scale), h - view.offset_y  # GL rows
    strips = [(0, 0, math.ceil(left) + 1, h), (math.floor(right) - 1, 0, w, h),
              (0, 0, w, math.ceil(bottom) + 1), (0, math.floor(top) - 1, w, h)]
    strips = [(max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)) for x0, y0, x1, y1 in strips]
    return [strip for strip in strips if strip[2] > strip[0] and strip[3] > strip[1]]


def visible_grid(view: View, cells: int, cell_size: float) -> np.ndarray:
    """``(cells, cells)`` bool: which cells of a lattice (``cell_size`` document pixels a side) the window
    shows, in whole or in part."""
    index, size = np.arange(cells), cell_size * view.scale
    columns = ((index + 1) * size + view.offset_x >= 0) & (index * size + view.offset_x <= view.width)
    rows = ((index + 1) * size + view.offset_y >= 0) & (index * size + view.offset_y <= view.height)
    return rows[:, None] & columns[None, :]


def visible_cells(view: View, cells: np.ndarray, cell_size: float) -> np.ndarray:
    """Flat indices (int32) of the ``cells`` (a ``(n, n)`` bool grid of cells of ``cell_size`` document pixels)
    that the window shows."""
    return np.flatnonzero(cells & visible_grid(view, len(cells), cell_size)).astype(np.int32)


def row_runs(cells: np.ndarray, codes: np.ndarray | None = None) -> np.ndarray:
    """The ``cells`` (a ``(n, n)`` bool grid) as runs along rows, ``(runs, 2)`` int32: the first cell (flat
    index) and how many follow it, row by row.  With ``codes`` (``(n, n)`` int), a run holds cells of one code
    and a third column gives it, ``(runs, 3)``."""
    marked = np.where(cells, 0 if codes is None else codes, -1)  # -1: not listed
    change = np.ones(marked.shape[:1] + (marked.shape[1] + 1,), bool)  # a run starts or ends between columns
    change[:, 1:-1] = marked[:, 1:] != marked[:, :-1]
    starts = np.flatnonzero(cells & change[:, :-1])
    ends = np.flatnonzero(cells & change[:, 1:])  # a run's last cell, in the order of the starts
    runs = [starts, ends - starts + 1] + ([] if codes is None else [marked.ravel()[starts]])
    return np.stack(runs, axis=1).astype(np.int32)


def cells_rect(view: View, cells: np.ndarray, n: int, cell_size: float) -> tuple[int, int, int, int]:
    """GL pixels ``(x0, y0, x1, y1)`` of the window (y up) that hold ``cells`` (flat indices into ``n`` a side,
    at least one), a pixel to spare on every side."""
    size = cell_size * view.scale
    columns, rows = cells % n, cells // n
    x0 = int(np.floor(columns.min() * size + view.offset_x)) - 1
    x1 = int(np.ceil((columns.max() + 1) * size + view.offset_x)) + 1
    top = int(np.floor(rows.min() * size + view.offset_y)) - 1
    bottom = int(np.ceil((rows.max() + 1) * size + view.offset_y)) + 1
    return max(x0, 0), max(view.height - bottom, 0), min(x1, view.width), min(view.height - top, view.height)
