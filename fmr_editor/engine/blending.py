"""One layer blended over the picture below it, sample by sample, in one compiled pass (``composite.compose``).

``composite.compose_reference`` is the plain numpy form: each step there is
a pass over the samples with an array of its own (clamps, the transform,
the mask's luminance, the weight, the blend), 60% of a layered document's
CPU raster; here each sample is read and written once.
"""

from __future__ import annotations

import numba


@numba.njit(inline="always")
def _clamped(value: float) -> float:
    return min(max(value, 0.0), 1.0)


@numba.njit(inline="always")
def _weight(i, mask, luma, mask_base, mask_enabled, mask_inverted, negligible, alpha, alpha_column, opacity):
    """Sample ``i``'s weight ``clamp(a, 0, 1) opacity clamp(M, 0, 1)``, 0 or 1 within ``negligible`` of them
    (``composite.snapped``; ``blend_layer``'s parameters)."""
    weight = opacity
    if mask_enabled:
        value = mask_base
        if mask.shape[0] > 0 and mask.shape[1] == 1:  # the luminance already (``composite.scalar_reads``)
            value += mask[i, 0]
        elif mask.shape[0] > 0:
            value += mask[i, 0] * luma[0] + mask[i, 1] * luma[1] + mask[i, 2] * luma[2]
        if mask_inverted:
            value = 1.0 - value
        weight *= _clamped(value)
    if alpha.shape[0] > 0:
        weight *= _clamped(alpha[i, alpha_column])
    if weight <= negligible:
        return 0.0
    return 1.0 if weight >= 1.0 - negligible else weight


@numba.njit(parallel=True, cache=True)
def layer_weights(weights, mask, luma, mask_base, mask_enabled, mask_inverted, negligible, alpha, alpha_column,
                  opacity):
    """``weights (n,)``: each sample's weight, as ``blend_layer`` blends with it (its parameters)."""
    for i in numba.prange(weights.shape[0]):
        weights[i] = _weight(i, mask, luma, mask_base, mask_enabled, mask_inverted, negligible, alpha, alpha_column,
                             opacity)


@numba.njit(inline="always")
def _blend_sample(i, out, coverage, colour, matrix, offset, transformed, weight, first):
    """Sample ``i`` of ``blend_layer`` at its ``weight``; ``colour`` may be ``out`` itself (read, then written)."""
    if weight == 0.0:
        if first:
            out[i, 0], out[i, 1], out[i, 2], coverage[i] = 0.0, 0.0, 0.0, 0.0
        return
    r, g, b = _clamped(colour[i, 0]), _clamped(colour[i, 1]), _clamped(colour[i, 2])
    if transformed:
        r, g, b = (_clamped(matrix[0, 0] * r + matrix[0, 1] * g + matrix[0, 2] * b + offset[0]),
                   _clamped(matrix[1, 0] * r + matrix[1, 1] * g + matrix[1, 2] * b + offset[1]),
                   _clamped(matrix[2, 0] * r + matrix[2, 1] * g + matrix[2, 2] * b + offset[2]))
    if weight == 1.0:
        out[i, 0], out[i, 1], out[i, 2], coverage[i] = r, g, b, 1.0
    elif first:  # over 0: the same values as below
        out[i, 0], out[i, 1], out[i, 2], coverage[i] = weight * r, weight * g, weight * b, weight
    else:
        out[i, 0] += weight * (r - out[i, 0])
        out[i, 1] += weight * (g - out[i, 1])
        out[i, 2] += weight * (b - out[i, 2])
        coverage[i] += weight * (1.0 - coverage[i])


@numba.njit(parallel=True, cache=True)
def blend_layer(out, coverage, colour, matrix, offset, transformed, mask, luma, mask_base, mask_enabled,
                mask_inverted, negligible, alpha, alpha_column, opacity, covers, first, in_place):
    """``out``, ``coverage`` with one layer over them, in place (``composite.compose_reference``'s loop body).

    Parameters
    ----------
    out, coverage : numpy.ndarray
        ``(n, 3)`` the colours below and ``(n,)`` their coverage.
    colour : numpy.ndarray
        ``(n, 3)`` the layer's image values, or ``(n, 4)`` (the fourth not read).
    matrix, offset : numpy.ndarray
        ``(3, 3)`` and ``(3,)``: the layer's colour transform, applied when ``transformed``.
    mask : numpy.ndarray
        ``(n, 3)`` the mask's values, ``(n, 1)`` their luminance, or ``(0, 3)``: none (``mask_base`` alone, when
        ``mask_enabled``).
    luma : numpy.ndarray
        ``(3,)`` weights of the mask's luminance.
    negligible : float
        Weights within it of 0 or 1 are 0 or 1 (``composite.NEGLIGIBLE_WEIGHT``): the layer leaves the colour
        below as it is, or replaces it, whatever its image's (finite) values are there.
    alpha : numpy.ndarray
        ``(n, k)`` the alpha field's values, or ``(0, 3)``: opaque.
    alpha_column : int
        The column of ``alpha`` that is the alpha: 0 of the alpha field's own values, 3 of its image's values of
        four channels that carry it.
    covers : bool
        The layer hides everything below: ``out`` becomes what it shows, ``coverage`` 1.
    first : bool
        Nothing lies below: ``out`` and ``coverage`` are written, not read (as if they were 0).
    in_place : bool
        The layer's image values are ``out``'s own (``raster._composed`` evaluates the bottom layer's image into
        the picture): ``colour`` is not read.  One array read and written, not ``colour`` the same memory as
        ``out``: numba compiles its arrays as never overlapping.
    """
    if in_place:
        for i in numba.prange(out.shape[0]):
            weight = 1.0 if covers else _weight(i, mask, luma, mask_base, mask_enabled, mask_inverted, negligible,
                                                alpha, alpha_column, opacity)
            _blend_sample(i, out, coverage, out, matrix, offset, transformed, weight, first)
    else:
        for i in numba.prange(out.shape[0]):
            weight = 1.0 if covers else _weight(i, mask, luma, mask_base, mask_enabled, mask_inverted, negligible,
                                                alpha, alpha_column, opacity)
            _blend_sample(i, out, coverage, colour, matrix, offset, transformed, weight, first)
