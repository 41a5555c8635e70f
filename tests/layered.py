"""Layered documents for tests, and the plain per-pixel composition they are checked against."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from shapes import circle_points, scattered_document, uniform_curve

from fmr_editor.engine import LiveStack, rasterise
from fmr_editor.model import (
    BlurStop,
    ColorStop,
    DiffusionCurve,
    DiffusionPoint,
    Document,
    Layer,
    Mask,
    edits,
    layer_edits,
)
from fmr_editor.model.alpha import alpha_image
from fmr_editor.model.color_transform import hue_rotation

SIZE = 128
#: The Paint colour of ``paint_over_glow``.
GREEN = (0.2, 0.7, 0.3)


def soft_mask(seed: int = 3) -> Mask:
    """Points of both signs: white dabs adding, a few subtracting, over base 0."""
    rng = np.random.default_rng(seed)
    points = [DiffusionPoint(tuple(rng.uniform(0, SIZE, 2)), rng.uniform(6, 20), (1.0, 1.0, 1.0),
                             amplitude=rng.choice([1.0, 1.0, -0.6])) for _ in range(30)]
    return Mask(points=points)


def sharp_mask() -> Mask:
    """A closed circle, white inside and black outside: 1 inside, 0 outside."""
    return Mask(curves=[uniform_curve(circle_points(60, 70, 35), left=1.0, right=0.0)])


def three_layers() -> Document:
    bottom = Layer(scattered_document(SIZE, seed=2).curves, name="bottom")
    middle = Layer(scattered_document(SIZE, seed=5).curves, name="middle", opacity=0.7, mask=soft_mask())
    top = Layer(scattered_document(SIZE, seed=7).curves, name="top", mask=sharp_mask(), transform=hue_rotation(120))
    return Document(SIZE, SIZE, layers=(bottom, middle, top), active=1)


def with_alphas(curve: DiffusionCurve, left: float, right: float) -> DiffusionCurve:
    """``curve`` with every stop on its left at alpha ``left`` and on its right at ``right`` (a side without
    stops gets a black one)."""
    def side(stops: tuple[ColorStop, ...], alpha: float) -> tuple[ColorStop, ...]:
        return tuple(ColorStop(stop.position, stop.color, alpha) for stop in stops or (ColorStop(0.0, (0, 0, 0)),))

    return DiffusionCurve(curve.control_points, side(curve.left, left), side(curve.right, right), id=curve.id)


def translucent_layers() -> Document:
    """``three_layers`` with alpha: the bottom layer opaque, the middle one's circles opaque inside and clear
    outside, the top one's curves at alphas that vary along them; points on the middle layer."""
    document = three_layers()
    bottom, middle, top = document.layers
    rng = np.random.default_rng(11)
    middle_curves = tuple(with_alphas(curve, 1.0, 0.0) for curve in middle.curves[:-1]) + middle.curves[-1:]
    def varying(curve: DiffusionCurve) -> DiffusionCurve:
        left = tuple(ColorStop(s.position, s.color, float(rng.uniform(0, 1))) for s in curve.left)
        return DiffusionCurve(curve.control_points, left, curve.right, id=curve.id)

    top_curves = tuple(varying(curve) for curve in top.curves)
    dabs = (DiffusionPoint((40.0, 90.0), 12.0, (0.9, 0.8, 0.1), 0.8),)
    layers = (bottom, replace(middle, curves=middle_curves, points=middle.points + dabs),
              replace(top, curves=top_curves))
    return replace(document, layers=layers)


def paint_over_glow() -> Document:
    """A Glow stroke (white underneath far above 1) with a Paint stroke of green across it, as the brush
    makes them: the dabs of the Paint stroke go, white, into the mask of a green fill layer."""
    glow = [DiffusionPoint((64.0, 40.0 + 12 * i), 22.0, (1.0, 0.9, 0.6), amplitude=4.0) for i in range(5)]
    document = edits.add_points(Document(SIZE, SIZE), glow)
    document, fill = layer_edits.with_fill_layer(document, GREEN)
    paint = [DiffusionPoint((20.0 + 9 * i, 64.0), 10.0, (1.0, 1.0, 1.0), amplitude=0.8) for i in range(11)]
    return layer_edits.add_mask_points(document, fill, paint)


def reference(document: Document, width: int, height: int) -> np.ndarray:
    """Per-pixel composition of each layer and mask rendered by the direct sums (no FMR), by the formula
    ``out = m clamp(T(clamp(V))) + (1 - m) below``, ``m = clamp(alpha) opacity clamp(mask)`` (docs/design.md
    section 5)."""
    def direct(target) -> np.ndarray:
        return rasterise(LiveStack(document.flat(target)).representation, width, height, samples=1, method="direct")

    luma = np.array([0.2126, 0.7152, 0.0722])
    out = np.zeros((height, width, 3))
    for layer in document.layers:
        if not layer.visible:
            continue
        value = np.full((height, width), 1.0)
        if layer.mask is not None and layer.mask.enabled:
            value = layer.mask.base + (direct(layer.mask) @ luma if not layer.mask.is_constant else 0.0)
            value = 1.0 - value if layer.mask.inverted else value
        m = layer.opacity * np.minimum(np.maximum(value, 0.0), 1.0)
        if alpha_image(layer) is not None:  # the diffusion of the stops' alphas, as a colour
            m = m * np.minimum(np.maximum(direct(alpha_image(layer))[..., 0], 0.0), 1.0)
        shown = np.minimum(np.maximum(direct(layer), 0.0), 1.0)  # what the layer shows, clamped, ...
        shown = shown @ layer.transform.matrix.T + layer.transform.offset  # ... transformed ...
        colour = np.minimum(np.maximum(shown, 0.0), 1.0)  # ... and clamped again
        out = m[..., None] * colour + (1.0 - m[..., None]) * out
    return out


def blurred_layers() -> Document:
    """``translucent_layers`` with blur on the top layer (masked, hue-rotated, translucent): along each curve
    from sharp to 6 px and back, so that its blur field varies over the canvas."""
    document = translucent_layers()
    top = document.layers[2]
    curves = tuple(replace(curve, blur=(BlurStop(0.0, 0.0), BlurStop(curve.piece_count / 2, 6.0),
                                        BlurStop(float(curve.piece_count), 0.5))) for curve in top.curves)
    return replace(document, layers=document.layers[:2] + (replace(top, curves=curves),))
