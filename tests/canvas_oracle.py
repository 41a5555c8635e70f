"""What the canvas should show, computed on the CPU: the oracle of the canvas tests."""

from __future__ import annotations

import numpy as np

from fmr_editor.engine import Composite, Representation, evaluate_points
from fmr_editor.engine.blur import window_picture
from fmr_editor.render import View

#: Checkerboard grey levels outside the canvas (shaders/canvas.frag), in 8 bits.
CHECKER = {round(0.8 * 255), round(0.6 * 255)}


def window_samples(view: View) -> np.ndarray:
    """Document positions of every window pixel's centre, ``(height * width, 2)``, row by row."""
    xs = (np.arange(view.width) + 0.5 - view.offset_x) / view.scale
    ys = (np.arange(view.height) + 0.5 - view.offset_y) / view.scale
    return np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1).reshape(-1, 2)


def checkerboard(view: View, square: float = 8.0) -> np.ndarray:
    """The checkerboard's grey at every window pixel, ``(height * width,)`` (shaders/canvas.frag, compose.frag)."""
    columns = np.floor((np.arange(view.width) + 0.5) / square).astype(int)
    rows = np.floor((np.arange(view.height) + 0.5) / square).astype(int)
    return np.where((rows[:, None] + columns[None, :]) % 2 == 0, 0.8, 0.6).ravel()


def shown_colours(rep: Representation | Composite, view: View, inside: np.ndarray) -> np.ndarray:
    """What the canvas shows at the window pixels ``inside`` the canvas (a mask of ``window_samples``): the
    picture's colour over black plus the checkerboard where it is not opaque, ``(count, 3)``; a picture with
    blur fields blurred as the CPU blurs a window (``engine.blur.window_picture``)."""
    if isinstance(rep, Composite) and any(layer.blur is not None for layer in rep.shown):
        values = window_picture(rep, (-view.offset_x / view.scale, -view.offset_y / view.scale), 1 / view.scale,
                                view.width, view.height).reshape(-1, 4)[inside]
    else:
        values = evaluate_points(rep, window_samples(view)[inside], coverage=True)
    return values[:, :3] + (1.0 - values[:, 3:]) * checkerboard(view)[inside, None]


def error_levels(shown: np.ndarray, expected: np.ndarray) -> float:
    """Largest difference of an 8-bit image from a float one, in 8-bit levels."""
    return float(np.abs(shown.astype(np.float64) - np.clip(expected, 0, 1) * 255).max(initial=0.0))


def distance_to_segments(points: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance from each of a few points to the nearest segment."""
    d = q - p
    length2 = np.maximum((d * d).sum(axis=1), 1e-300)
    out = np.empty(len(points))
    for i, point in enumerate(points):
        t = np.clip(((point - p) * d).sum(axis=1) / length2, 0, 1)
        out[i] = np.sqrt((((p + t[:, None] * d) - point) ** 2).sum(axis=1).min())
    return out


def mismatches(shown: np.ndarray, rep: Representation | Composite, view: View, levels: float) -> dict[str, int]:
    """Where the 8-bit ``shown`` window differs from ``rep`` (or a composite) seen through ``view`` by more than
    ``levels``.

    Inside the canvas a pixel is compared with the field at its centre, one
    sample per pixel; a pixel whose centre lies on a curve (to 1e-9 px) is
    left out, since which side of the jump a sample gets there is decided by
    rounding.  Outside the canvas the checkerboard must show.

    Returns
    -------
    dict
        ``{"inside": pixels off, "outside": pixels not checkerboard, "on_curves": left out}``.
    """
    samples = window_samples(view)
    flat = shown.reshape(-1, 3)
    inside = ((samples >= 0) & (samples <= [rep.width, rep.height])).all(axis=1)
    expected = np.clip(shown_colours(rep, view, inside), 0, 1) * 255
    off = np.abs(flat[inside].astype(np.float64) - expected).max(axis=1) > levels
    suspects = samples[inside][off]
    sources = rep.representations if isinstance(rep, Composite) else (rep,)
    p = np.concatenate([source.segments.p for source in sources] or [np.zeros((0, 2))])  # none: nothing shows
    q = np.concatenate([source.segments.q for source in sources] or [np.zeros((0, 2))])
    on_curves = distance_to_segments(suspects, p, q) < 1e-9 if len(suspects) else off[:0]
    outside = flat[~inside]
    checker = np.isin(outside, list(CHECKER)).all(axis=1)
    return {"inside": int((~on_curves).sum()), "outside": int((~checker).sum()), "on_curves": int(on_curves.sum())}
