"""A layer's blur as a diffusion image: its curves with each blur stop's value as a grey.

A blur value is the standard deviation, in document pixels, of the Gaussian that softens the picture
(docs/design.md section 5).  It diffuses as a colour channel does, on the same curves: a curve's blur
stops hold on both its sides, and a curve without blur stops is sharp (0).  Memoised on the layer, as
``model.alpha`` is, so that the engine recognises an unchanged blur by identity.
"""

from __future__ import annotations

from dataclasses import replace

from .curve import ColorStop, DiffusionCurve
from .layer import Layer


def blur_curve(curve: DiffusionCurve) -> DiffusionCurve:
    """``curve`` (same geometry, id and blur stops) with colour stops ``(b, b, b)`` on both sides: its blur
    ``b`` (interpolated linearly between its blur stops, 0 without any) at each position where it has a colour
    or blur stop, so that it breaks into the very segments of ``curve``."""
    memo = curve.__dict__  # not a field of the curve: no part of its value
    if "_blur_curve" not in memo:
        positions = sorted({stop.position for stop in curve.left + curve.right + curve.blur}) or [0.0]
        greys = tuple(ColorStop(position, (float(value),) * 3)
                      for position, value in zip(positions, curve.blur_at(positions)))
        memo["_blur_curve"] = replace(curve, left=greys, right=greys)
    return memo["_blur_curve"]


def blurred(layer: Layer) -> bool:
    """True when a curve of ``layer`` has a blur stop above 0."""
    return any(stop.blur > 0 for curve in layer.curves for stop in curve.blur)


def blur_image(layer: Layer) -> Layer | None:
    """``layer``'s blur as a layer of curves to diffuse; None when nothing of it is blurred."""
    memo = layer.__dict__
    if "_blur_image" not in memo:
        memo["_blur_image"] = Layer(tuple(blur_curve(curve) for curve in layer.curves)) if blurred(layer) else None
    return memo["_blur_image"]
