"""Blur along curves: each point of a layer convolved with the Gaussian of its blur field's value there.

A layer's blur field ``s(x)`` is the diffusion of its curves' blur stops (``model.blur``), clamped at 0: the
standard deviation, in document pixels, of the Gaussian that softens the layer at ``x``.  The blurred
layer at ``x`` is its picture convolved with that Gaussian centred at ``x``, the canvas border reflecting
(as it does for the colours).  Its image and alpha fields are blurred so; its mask is not.

``blurred`` is the fast path on a raster (``blurred_within`` on a picture padded beyond it): the image
prefiltered at a ladder of standard deviations (``LEVEL_RATIO`` apart, in single precision; the wide ones
on the image halved, ``octave``), each pixel interpolating linearly in the deviation between the two
levels about its own.  ``window_picture`` is what the canvas shows of a view, which the shader path
(``render.blur_filter``) computes the same way.  A raster's pixel is the mean of the picture over it, so
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
#: The smallest deviation prefiltered (pixels); from ``SHARP`` to it, pixels interpolate from the sharp image
#: (halfway, off by half Phi(-0.5 / 0.2) = 0.003 of an edge's step at most).
FIRST_LEVEL = 0.2
#: Deviations up to this leave a raster's pixel means as they are: an edge on a pixel's border spills
#: Phi(-0.5 / 0.1) = 3e-7 of its step into the next pixel.  Level 0 of the ladder is the picture itself.
SHARP = 0.1
#: The Gaussians are cut this many deviations out (what is left is 6e-5 of their weight).
TRUNCATE = 4.0


def levels(largest: float) -> list[float]:
    """The ladder of deviations: ``SHARP`` (the picture as it is), then ``FIRST_LEVEL`` times powers of
    ``LEVEL_RATIO`` up to ``largest``."""
    ladder = [SHARP]
    if largest > SHARP:
        count = max(0, math.ceil(math.log(max(largest, FIRST_LEVEL) / FIRST_LEVEL) / math.log(LEVEL_RATIO)))
        ladder += [FIRST_LEVEL * LEVEL_RATIO**k for k in range(count + 1)]
    return ladder


def pixel_kernel(sigma: float) -> np.ndarray:
    """The Gaussian of deviation ``sigma`` pixels integrated over each pixel about the centre one."""
    radius = kernel_radius(sigma)
    k = np.arange(-radius, radius + 1)
    weights = ndtr((k + 0.5) / sigma) - ndtr((k - 0.5) / sigma)
    return weights / weights.sum()


#: A level is filtered on the image halved ``d`` times (its octave) when its deviation is at least
#: ``COARSE_SIGMA * 2**d`` pixels: then it spans 3 or more of the halved image's pixels, whose bilinear
#: interpolation back to the output's pixels stays within a fraction of a level of the full-size filter.
COARSE_SIGMA = 3.0
#: The coarsest octave (pixels ``2**DEEPEST`` wide).  Deviations are clamped to ``LARGEST`` (96) pixels of the
#: output: the margin of picture a window needs grows with the deviation (448 px beyond each side at the
#: clamp), so a canvas zoomed far into a strong blur shows it at 96 window pixels, as the CPU draws that view.
DEEPEST = 4
MAX_RADIUS = math.ceil(TRUNCATE * 2 * COARSE_SIGMA + 0.5)
LARGEST = 2 * COARSE_SIGMA * 2**DEEPEST


def octave(sigma: float) -> int:
    """How many times the image is halved before filtering at deviation ``sigma`` (pixels)."""
    d = 0
    while d < DEEPEST and sigma >= COARSE_SIGMA * 2 ** (d + 1):
        d += 1
    return d


def coarse_deviation(sigma: float, d: int) -> float:
    """The deviation, in its own pixels, of the filter on the image halved ``d`` times that makes the whole
    path (``2**d``-pixel means, that filter, bilinear interpolation back) as wide as ``sigma`` at full size:
    the variances of the means, of the coarse pixels' kernel and of the interpolation (over the output
    pixels' phases) are taken out."""
    if d == 0:
        return sigma
    h = 2**d
    phase = ((np.arange(h) + 0.5) / h - 0.5) % 1.0
    taken = (h * h - 1) / 12 + h * h / 12 + h * h * float(np.mean(phase * (1.0 - phase)))
    return math.sqrt(sigma**2 + 1 / 12 - taken) / h


def kernel_radius(sigma: float) -> int:
    """Half the width of ``pixel_kernel(sigma)``, in its pixels."""
    return math.ceil(TRUNCATE * sigma + 0.5)


def margin(largest: float) -> int:
    """Pixels of picture needed beyond the output on every side to blur it up to ``largest``: a multiple of
    the deepest octave's pixel, so that every octave's pixels line up with the output's."""
    ladder = levels(largest)
    reach = 0
    for sigma in ladder[1:]:
        d = octave(sigma)
        reach = max(reach, (kernel_radius(coarse_deviation(sigma, d)) + 2) * 2**d)
    unit = 2 ** octave(ladder[-1])
    return unit * math.ceil(reach / unit)


def halved(image: np.ndarray) -> np.ndarray:
    """The means of ``image``'s 2 x 2 blocks (an odd last row or column dropped)."""
    h, w = image.shape[0] // 2 * 2, image.shape[1] // 2 * 2
    return ((image[0:h:2, 0:w:2] + image[0:h:2, 1:w:2]) + (image[1:h:2, 0:w:2] + image[1:h:2, 1:w:2])) * 0.25


def filtered(image: np.ndarray, sigma: float) -> np.ndarray:
    """``image`` convolved with ``pixel_kernel(sigma)`` along both axes (the border's value beyond it)."""
    kernel = pixel_kernel(sigma).astype(image.dtype)
    return correlate1d(correlate1d(image, kernel, axis=0, mode="nearest"), kernel, axis=1, mode="nearest")


def sampled(level: np.ndarray, d: int, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``level``, an image halved ``d`` times, interpolated bilinearly at the centres of the full-size pixels
    ``(rows, columns)``."""
    if d == 0:
        return level[rows, columns]
    h = 2**d
    out = []
    for index, size in ((rows, level.shape[0]), (columns, level.shape[1])):
        u = (index + 0.5) / h - 0.5
        low = np.floor(u).astype(int)
        out.append((np.clip(low, 0, size - 1), np.clip(low + 1, 0, size - 1), (u - low)[:, None].astype(level.dtype)))
    (r0, r1, ty), (c0, c1, tx) = out
    top = level[r0, c0] + tx * (level[r0, c1] - level[r0, c0])
    bottom = level[r1, c0] + tx * (level[r1, c1] - level[r1, c0])
    return top + ty * (bottom - top)


def blurred(image: np.ndarray, sigma: np.ndarray, largest: float | None = None) -> np.ndarray:
    """``image (H, W, C)`` blurred at each pixel by a Gaussian of deviation ``sigma (H, W)`` pixels (clamped
    to [0, ``largest``], by default its largest value), the border reflecting: see the module."""
    largest = ceiling(sigma, largest)
    extra = margin(largest)
    padded = np.pad(image, ((extra, extra), (extra, extra), (0, 0)), mode="symmetric")
    return blurred_within(padded, sigma, extra, largest)


def ceiling(sigma: np.ndarray, largest: float | None) -> float:
    """The ladder's top for ``sigma``: ``largest`` (by default ``sigma``'s largest value) up to ``LARGEST``."""
    return min(float(np.max(sigma, initial=0.0)) if largest is None else float(largest), LARGEST)


def largest_blur(field: Representation) -> float:
    """The largest value of a blur field (document pixels): its curves' largest blur value, since a diffusion
    takes its extremes on its curves.  The ladder goes up to it, so that it does not change with the part
    of the field in view."""
    segments = field.segments
    if len(segments.p) == 0:
        return 0.0
    return max(float(np.max(segments.mean[:, 0] + 0.5 * np.abs(segments.jump[:, 0]))), 0.0)


def blurred_within(padded: np.ndarray, sigma: np.ndarray, extra: int, largest: float | None = None) -> np.ndarray:
    """The middle ``sigma.shape`` of ``padded (H + 2 extra, W + 2 extra, C)`` blurred by ``sigma (H, W)``
    pixels, clamped to [0, ``largest``] (by default its largest value; at most ``LARGEST``); ``extra`` is at
    least ``margin(largest)`` (``padding``), and ``padded`` may hold more rows and columns after the
    window's.

    The ladder of ``levels``: each level filtered on its ``octave`` of ``padded`` with its
    ``coarse_deviation``; each pixel interpolates linearly in the deviation between the two levels about
    its own, each level interpolated bilinearly to the pixel.
    """
    largest = ceiling(sigma, largest)
    sigma = np.clip(sigma, 0.0, largest)
    height, width = sigma.shape
    out = padded[extra : extra + height, extra : extra + width].copy()  # where sharp, as it is
    padded = padded.astype(np.float32)  # filtered in single precision: 1e-7 of a colour, twice as fast
    ladder = levels(largest)
    bracket = np.searchsorted(ladder, sigma, side="left")  # pixels with ladder[k-1] < s <= ladder[k]: k
    wanted = np.bincount(bracket.ravel(), minlength=len(ladder) + 1)
    octaves = [padded]
    made: dict[int, tuple[np.ndarray, int]] = {0: (padded, 0)}  # level k: its filtered image and octave
    for k in range(1, len(ladder)):
        if wanted[k] == 0:
            made.pop(k - 1, None)
            continue
        for needed in (k - 1, k):
            if needed not in made:
                d = octave(ladder[needed])
                while len(octaves) <= d:
                    octaves.append(halved(octaves[-1]))
                made[needed] = (filtered(octaves[d], coarse_deviation(ladder[needed], d)), d)
        rows, columns = np.nonzero(bracket == k)
        low, high = ladder[k - 1], ladder[k]
        t = ((sigma[rows, columns] - low) / (high - low))[:, None].astype(np.float32)
        lower = sampled(*made[k - 1], rows + extra, columns + extra)
        upper = sampled(*made[k], rows + extra, columns + extra)
        out[rows, columns] = lower + t * (upper - lower)
        made.pop(k - 1)
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


def rasterise_blurred(composite: Composite, width: int | None = None, height: int | None = None, samples: int = 3,
                      method: str = "fmr", order: int | None = None, coverage: bool = False,
                      progress: Callable[[str, float], None] | None = None) -> np.ndarray:
    """``engine.rasterise`` of ``composite`` with each layer that carries a blur field (``LayerFields.blur``)
    blurred by it.  The blur is in document pixels: with the aspect ratio changed, by the mean of the two
    scales."""
    width, height = output_size(composite.width, composite.height, width, height)
    scale = math.sqrt(width / composite.width * height / composite.height)  # output pixels a document pixel
    fields: dict[int, np.ndarray] = {}
    shown = composite.shown
    for number, layer in enumerate(shown):
        sigma = rasterise(layer.blur, width, height, samples=1)[..., 0] * scale if layer.blur is not None else None
        for role, rep in layer.read:
            values = rasterise(rep, width, height, samples=samples, method=method, order=order)
            fields[id(rep)] = (values if sigma is None or role is Role.MASK
                               else blurred(values, sigma, largest_blur(layer.blur) * scale))
        if progress:
            progress("blur", (number + 1) / len(shown))
    return compose(composite, lambda rep: fields[id(rep)], (height, width, 3), coverage)


def reflected(points: np.ndarray, width: float, height: float) -> np.ndarray:
    """``points (n, 2)`` folded into the canvas by reflection at its border (as often as it takes)."""
    size = np.array([width, height], float)
    return size - np.abs(np.mod(points, 2.0 * size) - size)


def window_picture(composite: Composite, origin: tuple[float, float], step: float, width: int,
                   height: int) -> np.ndarray:
    """What the canvas shows of ``composite`` in a window of ``width x height`` pixels whose top-left corner
    lies at document point ``origin``, ``step`` document pixels a window pixel, one sample a pixel at its
    centre: ``(height, width, 4)``, the colour over black and the coverage (``composite.compose``), each
    blurred layer as ``blurred_within`` makes it from its fields evaluated beyond the window, reflected at
    the canvas border.  The canvas's shader path does the same on the GPU (``render.blur_filter``)."""
    from .raster import evaluate_points

    def grid(left: int, top: int, columns: int, rows: int) -> np.ndarray:
        xs = origin[0] + (np.arange(columns) - left + 0.5) * step
        ys = origin[1] + (np.arange(rows) - top + 0.5) * step
        return np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1).reshape(-1, 2)

    window = grid(0, 0, width, height)
    fields: dict[int, np.ndarray] = {}
    for layer in composite.shown:
        sigma = None
        if layer.blur is not None:
            field = evaluate_points(layer.blur, reflected(window, composite.width, composite.height))
            largest = min(largest_blur(layer.blur) / step, LARGEST)
            sigma = np.clip(field[:, 0] / step, 0.0, largest).reshape(height, width)
            extra, below = padding(largest, height)
            padded = grid(extra, extra, width + 2 * extra, height + extra + below)
            padded = reflected(padded, composite.width, composite.height)
        for role, rep in layer.read:
            if sigma is None or role is Role.MASK:
                fields[id(rep)] = evaluate_points(rep, window)
                continue
            values = evaluate_points(rep, padded).reshape(height + extra + below, width + 2 * extra, 3)
            fields[id(rep)] = blurred_within(values, sigma, extra, largest).reshape(-1, 3)
    return compose(composite, lambda rep: fields[id(rep)], (width * height, 3), True).reshape(height, width, 4)


def padding(largest: float, height: int) -> tuple[int, int]:
    """Rows (and columns) of picture around a window ``height`` rows high that ``blurred_within`` needs to
    blur it up to ``largest`` pixels: ``(extra, below)``, ``extra`` above and on both sides, ``below`` under
    it, so that the padded height is a multiple of the deepest octave's pixel (its pixels then line up with
    the window's counted from either end, as the GPU counts them from the bottom)."""
    extra = margin(largest)
    unit = 2 ** octave(levels(largest)[-1]) if largest > 0 else 1
    return extra, extra + (-height) % unit
