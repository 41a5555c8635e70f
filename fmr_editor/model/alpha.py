"""A layer's alpha as a diffusion image: its curves with each colour stop's alpha as a grey.

Alpha diffuses exactly as a colour channel does, on the same curves (docs/design.md section 5): the
engine solves this image as the layer's alpha field and reads its first channel.  A side without
stops is opaque (alpha 1).  Diffusion points carry no alpha: they add colour only.

Both functions keep what they made on the object they were given, so the same curve (or layer) always
gives the same object: the engine recognises unchanged curves, and whole images it has seen, by identity.
"""

from __future__ import annotations

from dataclasses import replace

from .curve import ColorStop, DiffusionCurve
from .layer import Layer

#: The alpha of a side without stops.
OPAQUE = (ColorStop(0.0, (1.0, 1.0, 1.0)),)


def alpha_curve(curve: DiffusionCurve) -> DiffusionCurve:
    """``curve`` (same geometry and id) with each colour stop ``(a, a, a)`` for its alpha ``a``."""
    memo = curve.__dict__  # not a field of the curve: no part of its value
    if "_alpha_curve" not in memo:
        def greys(side: tuple[ColorStop, ...]) -> tuple[ColorStop, ...]:
            return tuple(ColorStop(stop.position, (stop.alpha,) * 3) for stop in side) if side else OPAQUE

        memo["_alpha_curve"] = replace(curve, left=greys(curve.left), right=greys(curve.right), blur=())
    return memo["_alpha_curve"]


def alpha_image(layer: Layer) -> Layer | None:
    """``layer``'s alpha as a layer of curves to diffuse; None when it is opaque (no stop has alpha below 1)."""
    memo = layer.__dict__
    if "_alpha_image" not in memo:
        memo["_alpha_image"] = Layer(tuple(alpha_curve(curve) for curve in layer.curves)) if layer.translucent else None
    return memo["_alpha_image"]
