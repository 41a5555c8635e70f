"""Diffusion curves: chains of cubic Beziers with colour stops on either side.

Positions along a curve are in *piece units*: a chain of ``k`` cubic pieces is
parametrised by ``s`` in ``[0, k]``; piece ``floor(s)`` at local parameter
``s - floor(s)`` (``s == k`` is the end of the last piece).  Colours between
stops interpolate linearly in ``s`` and stay constant beyond the first and
last stop.  A side without stops is black.

**Left** is the viewer's left when walking along the curve on screen
(document coordinates: x to the right, y down).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .identity import checked_id
from .limits import MAX_BLUR, MAX_COLOR

Color = tuple[float, float, float]


@dataclass(frozen=True)
class ColorStop:
    """A colour at a position along a curve.

    Parameters
    ----------
    position : float
        Position along the chain in piece units, ``0 <= position <= k``.
    color : tuple of float
        sRGB red, green, blue in ``[0, 1]``.
    alpha : float
        Opacity in ``[0, 1]``, 1 by default; the stops' alphas diffuse into the layer's coverage (``alpha``).
    """

    position: float
    color: Color
    alpha: float = 1.0


@dataclass(frozen=True)
class BlurStop:
    """A blur amount at a position along a curve (``model.blur``; drawn by ``engine.blur``, and by the canvas
    with View > Show Blur).

    Parameters
    ----------
    position : float
        Position along the chain in piece units.
    blur : float
        The deviation of the Gaussian that softens the picture there, in document pixels (Orzan's
        ``best_scale`` times ``io.orzan.BEST_SCALE_DEVIATION``).
    """

    position: float
    blur: float


def _normalised_stops(stops, piece_count: int) -> tuple:
    """Sort stops by position and clamp their positions to ``[0, piece_count]``."""
    if not all(np.isfinite(float(stop.position)) for stop in stops):
        raise ValueError("stop positions must be finite")
    if not all((np.abs(stop.color) <= MAX_COLOR).all() for stop in stops if isinstance(stop, ColorStop)):
        raise ValueError(f"stop colours must be finite and at most {MAX_COLOR:g} in size")
    if not all(0.0 <= float(stop.alpha) <= 1.0 for stop in stops if isinstance(stop, ColorStop)):
        raise ValueError("stop alphas must lie in [0, 1]")
    if not all(abs(float(stop.blur)) <= MAX_BLUR for stop in stops if isinstance(stop, BlurStop)):
        raise ValueError(f"blur values must be finite and at most {MAX_BLUR:g} px in size")
    clamped = [
        type(stop)(min(max(float(stop.position), 0.0), float(piece_count)), *_payload(stop))
        for stop in stops
    ]
    return tuple(sorted(clamped, key=lambda stop: stop.position))


def _payload(stop) -> tuple:
    if isinstance(stop, ColorStop):
        return tuple(float(c) for c in stop.color), float(stop.alpha)
    return (float(stop.blur),)


@dataclass(frozen=True, eq=False)
class DiffusionCurve:
    """An immutable diffusion curve.

    Parameters
    ----------
    control_points : numpy.ndarray
        ``(3k + 1, 2)`` control points of ``k`` cubic Bezier pieces, in
        document pixels (may lie outside the canvas).  Stored as a read-only
        float64 copy.
    left, right : tuple of ColorStop
        Colour stops on each side; sorted and clamped to ``[0, k]`` on creation.
    blur : tuple of BlurStop
        Blur stops: how much the picture is softened along the curve (``model.blur``); sorted and clamped
        as the colour stops.
    id : int, optional
        The curve's stable id (``identity``); a new one when omitted.  Not
        part of the curve's value (equality and hash).
    """

    control_points: np.ndarray
    left: tuple[ColorStop, ...] = ()
    right: tuple[ColorStop, ...] = ()
    blur: tuple[BlurStop, ...] = field(default=())
    id: int | None = None

    def __post_init__(self) -> None:
        points = np.array(self.control_points, dtype=np.float64, copy=True)
        if points.ndim != 2 or points.shape[1] != 2 or len(points) < 4 or (len(points) - 1) % 3:
            raise ValueError(
                f"a curve needs 3k+1 control points (k >= 1) as an (n, 2) array, got shape {points.shape}"
            )
        if not np.all(np.isfinite(points)):
            raise ValueError("control points must be finite")
        points.flags.writeable = False
        object.__setattr__(self, "control_points", points)
        k = self.piece_count
        object.__setattr__(self, "left", _normalised_stops(self.left, k))
        object.__setattr__(self, "right", _normalised_stops(self.right, k))
        object.__setattr__(self, "blur", _normalised_stops(self.blur, k))
        object.__setattr__(self, "id", checked_id(self.id))

    @property
    def translucent(self) -> bool:
        """True when a colour stop has an alpha below 1."""
        return any(stop.alpha != 1.0 for stop in self.left + self.right)

    @property
    def piece_count(self) -> int:
        """Number ``k`` of cubic pieces."""
        return (len(self.control_points) - 1) // 3

    def pieces(self) -> np.ndarray:
        """Control points grouped per piece, shape ``(k, 4, 2)``."""
        k = self.piece_count
        index = 3 * np.arange(k)[:, None] + np.arange(4)[None, :]
        return self.control_points[index]

    def point_at(self, s: np.ndarray) -> np.ndarray:
        """Points on the curve at positions ``s`` (piece units), shape ``(n, 2)``."""
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.piece_count)
        piece = np.minimum(np.floor(s).astype(np.int64), self.piece_count - 1)
        t = (s - piece)[:, None]
        p0, p1, p2, p3 = np.moveaxis(self.pieces()[piece], 1, 0)
        u = 1.0 - t
        return u**3 * p0 + 3 * u * u * t * p1 + 3 * u * t * t * p2 + t**3 * p3

    def inside_on_left(self) -> bool:
        """True when the curve, taken as closed, turns anticlockwise as seen (y down): its inside on its left."""
        x, y = self.point_at(np.linspace(0.0, self.piece_count, 24 * self.piece_count + 1)).T
        return float(np.dot(x[:-1], y[1:]) - np.dot(x[1:], y[:-1])) < 0  # the shoelace sum, y down

    def left_colors_at(self, s: np.ndarray) -> np.ndarray:
        """Left-side colours at positions ``s``, shape ``(n, 3)``."""
        return interpolate_stops(self.left, s)

    def right_colors_at(self, s: np.ndarray) -> np.ndarray:
        """Right-side colours at positions ``s``, shape ``(n, 3)``."""
        return interpolate_stops(self.right, s)

    def blur_at(self, s: np.ndarray) -> np.ndarray:
        """The blur at positions ``s``, shape ``(n,)`` (``interpolate_blur``)."""
        return interpolate_blur(self.blur, s)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, DiffusionCurve):
            return NotImplemented
        return (
            np.array_equal(self.control_points, other.control_points)
            and self.left == other.left
            and self.right == other.right
            and self.blur == other.blur
        )

    def __hash__(self) -> int:
        try:
            return self.__dict__["_hash"]
        except KeyError:
            # + 0.0 turns -0.0 into 0.0, which __eq__ already treats as equal
            value = hash(((self.control_points + 0.0).tobytes(), self.left, self.right, self.blur))
            self.__dict__["_hash"] = value  # immutable, so computed once (edits diff curves often)
            return value


def interpolate_blur(stops: tuple[BlurStop, ...], s: np.ndarray) -> np.ndarray:
    """Piecewise-linear blur through sorted ``stops`` at positions ``s``, constant beyond them; 0 without any."""
    s = np.asarray(s, dtype=np.float64)
    if not stops:
        return np.zeros(s.shape)
    return np.interp(s, [stop.position for stop in stops], [stop.blur for stop in stops])


def interpolate_stops(stops: tuple[ColorStop, ...], s: np.ndarray) -> np.ndarray:
    """Piecewise-linear colour through sorted ``stops`` at positions ``s``.

    Parameters
    ----------
    stops : tuple of ColorStop
        Sorted by position.  Empty means black.
    s : numpy.ndarray
        Positions in piece units.

    Returns
    -------
    numpy.ndarray
        ``(len(s), 3)`` colours, constant beyond the outermost stops.
    """
    s = np.asarray(s, dtype=np.float64)
    if not stops:
        return np.zeros((len(s), 3))
    positions = np.array([stop.position for stop in stops])
    colors = np.array([stop.color for stop in stops], dtype=np.float64)
    return np.stack([np.interp(s, positions, colors[:, c]) for c in range(3)], axis=1)
