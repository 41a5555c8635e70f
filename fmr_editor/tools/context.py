"""What every tool works with: the history, the selection, the view's zoom and the options.

No globals: the ui builds one ``ToolContext`` per document window and hands
it to every tool it creates.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace

import numpy as np

from ..model import Document
from ..model.curve import Color
from ..model.history import History
from .hit import CurveIndex, CurveSet

Sampler = Callable[[float, float], Color]
ColorChooser = Callable[[Color], "Color | None"]


@dataclass
class ToolOptions:
    """The tools' settings, shown and changed by the ui's panels.

    Attributes
    ----------
    color : tuple of float
        The foreground colour: new stops, brush dabs, a new curve's left side;
        the eyedropper sets it.
    secondary_color : tuple of float
        The background colour: a new curve's right side; the eyedropper sets
        it with Alt held.
    brush_color : tuple of float
        Colour of the brush's dabs (a dab adds ``amplitude * colour``, so
        black would add nothing).
    brush_radius : float
        Gaussian radius of each dab, document pixels.
    brush_amplitude : float
        Amplitude of each dab (negative subtracts colour).
    brush_spacing : float
        Distance between dabs along a stroke, document pixels.
    brush_mode : str
        ``"paint"`` (dabs cover, through a fill layer's mask; see ``brush``)
        or ``"glow"`` (dabs add colour).
    stroke_left_alpha, stroke_right_alpha : float
        The alpha of an open curve's left and right side, drawn by the pen on a
        clear layer (a closed one is opaque inside and clear outside).
    """

    color: Color = (0.0, 0.0, 0.0)
    secondary_color: Color = (1.0, 1.0, 1.0)
    brush_color: Color = (1.0, 0.55, 0.15)
    brush_radius: float = 20.0
    brush_amplitude: float = 0.3
    brush_spacing: float = 10.0
    brush_mode: str = "paint"
    stroke_left_alpha: float = 1.0
    stroke_right_alpha: float = 1.0


def _set(items) -> frozenset:
    return frozenset(tuple(i) if isinstance(i, list) else i for i in items)


@dataclass(frozen=True)
class Selection:
    """What is selected: curves and points by id, their parts by index on their curve.

    Attributes
    ----------
    curves : frozenset of int
        Ids of curves selected whole.
    control_points : frozenset of (int, int)
        ``(curve id, index)`` anchors and handles.
    stops : frozenset of (int, str, int)
        ``(curve id, side, index)`` colour stops.
    points : frozenset of int
        Ids of diffusion points.
    """

    curves: frozenset[int] = frozenset()
    control_points: frozenset[tuple[int, int]] = frozenset()
    stops: frozenset[tuple[int, str, int]] = frozenset()
    points: frozenset[int] = frozenset()

    @classmethod
    def of(cls, curves: Iterable = (), control_points: Iterable = (), stops: Iterable = (),
           points: Iterable = ()) -> Selection:
        """A selection of the given items (any iterables)."""
        return cls(_set(curves), _set(control_points), _set(stops), _set(points))

    @property
    def empty(self) -> bool:
        return not (self.curves or self.control_points or self.stops or self.points)

    def active_curves(self) -> frozenset[int]:
        """Curves shown with their nodes and stops: selected whole or through a part."""
        return self.curves | {c for c, _ in self.control_points} | {c for c, _, _ in self.stops}

    def __or__(self, other: Selection) -> Selection:
        return Selection(self.curves | other.curves, self.control_points | other.control_points,
                         self.stops | other.stops, self.points | other.points)

    def __xor__(self, other: Selection) -> Selection:
        return Selection(self.curves ^ other.curves, self.control_points ^ other.control_points,
                         self.stops ^ other.stops, self.points ^ other.points)

    def __le__(self, other: Selection) -> bool:
        return (self.curves <= other.curves and self.control_points <= other.control_points
                and self.stops <= other.stops and self.points <= other.points)

    def within(self, document: Document) -> Selection:
        """This selection without the items ``document`` does not have."""
        has = document.has_curve
        points = self.points & document.point_ids() if self.points else self.points
        return replace(
            self,
            curves=frozenset(c for c in self.curves if has(c)),
            control_points=frozenset(
                (c, i) for c, i in self.control_points if has(c) and i < len(document.curve(c).control_points)
            ),
            stops=frozenset((c, s, i) for c, s, i in self.stops if has(c) and i < len(getattr(document.curve(c), s))),
            points=points,
        )


@dataclass(eq=False)
class ToolContext:
    """Shared state of the tools of one document view.

    Parameters
    ----------
    history : History
        Where edits go (a drag: ``begin``, ``preview``..., ``commit`` or ``cancel``).
    sample : callable, optional
        ``sample(x, y) -> (r, g, b)``: the rendered colour at a document
        point, for the eyedropper.
    choose_color : callable, optional
        ``choose_color(current) -> colour or None``: asks the user for a
        colour (the ui opens a dialog); None (the default, or the user
        cancelled) changes nothing.
    options : ToolOptions
    say : callable, optional
        ``say(text)``: a one-line message for the status bar (why something
        was refused, what was done); "" clears it.
    selection : Selection
        Kept within the current document on every change (undo included).
    region : numpy.ndarray or None
        The lasso's selection: ``(k, 2)`` corners of a simple polygon on the
        canvas, document pixels (what Copy copies).
    zoom : float
        Screen pixels per document pixel; the view keeps it current.
    tolerance_px, marker_offset_px, drag_threshold_px : float
        Hit radius, distance of stop markers from their curve, and how far
        the pointer must travel before a press becomes a drag, in screen pixels.
    """

    history: History
    sample: Sampler = lambda x, y: (0.0, 0.0, 0.0)
    choose_color: ColorChooser | None = None
    options: ToolOptions = field(default_factory=ToolOptions)
    say: Callable[[str], None] = lambda text: None
    selection: Selection = field(default_factory=Selection)
    region: np.ndarray | None = None
    zoom: float = 1.0
    tolerance_px: float = 6.0
    marker_offset_px: float = 8.0
    drag_threshold_px: float = 3.0

    def __post_init__(self) -> None:
        self._index: CurveIndex | None = None
        self._sets: tuple[tuple, dict[tuple[int, ...], CurveSet]] = ((), {})
        self.history.subscribe(self._follow)

    def _follow(self, before: Document, after: Document) -> None:
        self.selection = self.selection.within(after)

    @property
    def document(self) -> Document:
        """The history's current document (a drag's preview while one is open)."""
        return self.history.document

    @property
    def tolerance(self) -> float:
        """The hit radius in document pixels."""
        return self.tolerance_px / self.zoom

    @property
    def marker_offset(self) -> float:
        """Distance of stop markers from their curve in document pixels."""
        return self.marker_offset_px / self.zoom

    def curve_index(self) -> CurveIndex:
        """Nearest-point index of the current document's curves (rebuilt when they change)."""
        curves = self.document.curves
        if self._index is None or self._index.curves is not curves:
            self._index = CurveIndex(curves)
        return self._index

    def curve_set(self, ids) -> CurveSet:
        """The current document's curves ``ids`` with outlines and stop markers (cached until they change)."""
        curves = self.document.curves
        key = tuple(sorted(ids))
        if self._sets[0] is not curves:
            self._sets = (curves, {})
        cache = self._sets[1]
        if key not in cache:
            if len(cache) >= 4:
                cache.clear()
            cache[key] = CurveSet(self.document, key)
        return cache[key]

    def moved_far(self, origin, position) -> bool:
        """True once ``position`` is at least the drag threshold from ``origin`` on screen."""
        dx, dy = position[0] - origin[0], position[1] - origin[1]
        return (dx * dx + dy * dy) ** 0.5 * self.zoom >= self.drag_threshold_px
