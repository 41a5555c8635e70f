"""Blur along curves: each point of a layer convolved with the Gaussian of its blur field's value there.

A layer's blur field ``s(x)`` is the diffusion of its curves' blur stops (``model.blur``), clamped at 0: the
standard deviation, in document pixels, of the Gaussian that softens the layer at ``x``.  The blurred
layer at ``x`` is its picture convolved with that Gaussian centred at ``x``, the canvas border reflecting
(as it does for the colours).  Its image and alpha fields are blurred so; its mask is not.

``blurred`` is the fast path on a raster: the image prefiltered at a ladder of standard deviations
(``LEVEL_RATIO`` apart, reflecting, in single precision), each pixel interpolating linearly in the
deviation between the two levels about its own.  A raster's pixel is the mean of the picture over it, so
each level's kernel is the Gaussian integrated over each pixel (``pixel_kernel``), not sampled at its
centre: a picture constant on each pixel is blurred exactly (a sampled kernel misses an edge's normal CDF
by a level at 1.5 px).
``blurred_reference`` is the plain sum, pixel by pixel, of a finely sampled picture under each pixel's
own Gaussian, averaged over the pixel.  Being in document pixels, the blur scales with the output: a
raster twice as large is blurred by twice as many of its pixels.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.ndimage import correlate1d
from scipy.special import ndtr

from .composite import Composite, Role, compose
from .raster import output_size, rasterise
from .representation import Representation

#: Successive prefiltered deviations differ by this factor: interpolating between them, an edge under any
#: blur from 0.3 to 12 px is off its normal CDF by 0.35 of an 8-bit level at most (1.08: 0.06, at twice the
#: levels).
LEVEL_RATIO = 1.2
#: The smallest deviation prefiltered (pixels); below it, pixels interpolate from the sharp image (an edge's
#: blur is flat there: Phi(-0.5 / 0.1) = 3e-7, so halfway the interpolation is off by half Phi(-2.5), 0.003).
FIRST_LEVEL = 0.2
#: The Gaussians are cut this many deviations out (what is left is 6e-5 of their weight).
TRUNCATE = 4.0


def levels(largest: float) -> list[float]:
    """The ladder of deviations: 0, then ``FIRST_LEVEL`` times powers of ``LEVEL_RATIO`` up to ``largest``."""
    ladder = [0.0]
    if largest > 0:
        count = max(0, math.ceil(math.log(max(largest, FIRST_LEVEL) / FIRST_LEVEL) / math.log(LEVEL_RATIO)))
        ladder += [FIRST_LEVEL * LEVEL_RATIO**k for k in range(count + 1)]
    return ladder


def pixel_kernel(sigma: float) -> np.ndarray:
    """The Gaussian of deviation ``sigma`` pixels integrated over each pixel about the centre one."""
    radius = math.ceil(TRUNCATE * sigma + 0.5)
    k = np.arange(-radius, radius + 1)
    weights = ndtr((k + 0.5) / sigma) - ndtr((k - 0.5) / sigma)
    return weights / weights.sum()


def _filtered(image: np.ndarray, sigma: float) -> np.ndarray:
    """``image`` convolved with ``pixel_kernel(sigma)`` along both axes, the border reflecting."""
    kernel = pixel_kernel(sigma)
    return correlate1d(correlate1d(image, kernel, axis=0, mode="reflect"), kernel, axis=1, mode="reflect")


def blurred(image: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """``image (H, W, C)`` blurred at each pixel by a Gaussian of deviation ``sigma (H, W)`` pixels (clamped
    at 0), the border reflecting: see the module."""
    sigma = np.maximum(sigma, 0.0)
    ladder = levels(float(sigma.max()))
    out = image.copy()
    image = image.astype(np.float32)  # filtered in single precision: 1e-7 of a colour, twice as fast
    lower = image
    for k in range(1, len(ladder)):
        low, high = ladder[k - 1], ladder[k]
        between = (sigma > low) & (sigma <= high)
        wanted_later = k + 1 < len(ladder) and bool(((sigma > high) & (sigma <= ladder[k + 1])).any())
        if not between.any() and not wanted_later:
            lower = None  # not needed: the next level starts afresh
            continue
        upper = _filtered(image, high)
        if between.any():
            if lower is None:
                lower = _filtered(image, low)
            t = ((sigma[between] - low) / (high - low))[:, None]
            out[between] = (1.0 - t) * lower[between] + t * upper[between]
        lower = upper
    return out


def blurred_reference(fine: np.ndarray, sigma: np.ndarray, margin: int = 0) -> np.ndarray:
    """The plain blur, pixel by pixel: each pixel of ``sigma (H, W)`` (pixels) the mean over the pixel of the
    picture under the Gaussian of that pixel's deviation, the picture given as ``fine``, sampled ``f`` times
    finer than the pixels, with ``margin`` pixels of it beyond ``sigma``'s on every side (0: the canvas,
    reflected at its border)."""
    height, width = sigma.shape
    f = fine.shape[0] // (height + 2 * margin)
    reach = math.ceil(TRUNCATE * max(float(sigma.max()), 1.0 / f) * f) + f
    if margin == 0:
        fine = np.pad(fine, ((reach, reach), (reach, reach), (0, 0)), mode="symmetric")
    elif margin * f < reach:
        raise ValueError(f"a margin of {margin} pixels is narrower than the blur's reach, {reach / f:.1f}")
    start = margin * f - reach if margin else 0  # where the window of pixel (0, 0) starts in ``fine``
    offsets = np.arange(-reach, f + reach) + 0.5  # fine samples about the pixel's corner, in fine samples
    within = np.arange(f) + 0.5  # the pixel's own fine samples
    out = np.empty((height, width, fine.shape[2]))
    for i in range(height):
        for j in range(width):
            s = max(float(sigma[i, j]), 0.0) * f
            window = fine[start + i * f : start + i * f + f + 2 * reach, start + j * f : start + j * f + f + 2 * reach]
            if s < 0.3:  # narrower than a fine sample: the picture's mean over the pixel
                out[i, j] = window[reach : reach + f, reach : reach + f].mean(axis=(0, 1))
                continue
            g = np.exp(-0.5 * ((offsets[None, :] - within[:, None]) / s) ** 2)
            g = (g / g.sum(axis=1, keepdims=True)).mean(axis=0)  # each sample's Gaussian, averaged over the pixel
            out[i, j] = np.einsum("a,b,abc->c", g, g, window)
    return out


def rasterise_blurred(composite: Composite, blurs: dict[int, Representation], width: int | None = None,
                      height: int | None = None, samples: int = 3, coverage: bool = False,
                      progress: Callable[[str, float], None] | None = None) -> np.ndarray:
    """``engine.rasterise`` of ``composite`` with each layer blurred by its blur field in ``blurs`` (by layer
    id; a layer without one is sharp).  The blur is in document pixels: with the aspect ratio changed, by the
    mean of the two scales."""
    width, height = output_size(composite.width, composite.height, width, height)
    scale = math.sqrt(width / composite.width * height / composite.height)  # output pixels a document pixel
    fields: dict[int, np.ndarray] = {}
    shown = composite.shown
    for number, layer in enumerate(shown):
        blur = blurs.get(layer.id)
        sigma = rasterise(blur, width, height, samples=1)[..., 0] * scale if blur is not None else None
        for role, rep in layer.read:
            values = rasterise(rep, width, height, samples=samples)
            fields[id(rep)] = values if sigma is None or role is Role.MASK else blurred(values, sigma)
        if progress:
            progress("blur", (number + 1) / len(shown))
    return compose(composite, lambda rep: fields[id(rep)], (height, width, 3), coverage)
