"""Composition on cell polynomials (``engine.composite``) against evaluating the fields pixel by pixel."""

from __future__ import annotations

import numpy as np
from numpy.polynomial.polynomial import polyval2d

from fmr_editor.engine.composite import blended, transformed, truncated_product, truncated_product_reference
from fmr_editor.model.color_transform import ColorTransform, hue_rotation

rng = np.random.default_rng(32)
P = 6
XI, ETA = rng.uniform(-0.5, 0.5, (2, 40))  # cell coordinates


def values(poly: np.ndarray) -> np.ndarray:
    """A cell's polynomial ``(..., P + 1, P + 1)`` at the sample points, ``(..., 40)``."""
    flat = poly.reshape(-1, *poly.shape[-2:])
    return np.stack([polyval2d(XI, ETA, c) for c in flat]).reshape(poly.shape[:-2] + (len(XI),))


def low_degree(shape: tuple, degree: int) -> np.ndarray:
    """Random coefficients of degree at most ``degree`` per axis, in the ``(P + 1, P + 1)`` tensor."""
    poly = np.zeros(shape + (P + 1, P + 1))
    poly[..., : degree + 1, : degree + 1] = rng.normal(size=shape + (degree + 1, degree + 1))
    return poly


def test_the_product_equals_the_plain_loop():
    mask, poly = rng.normal(size=(4, P + 1, P + 1)), rng.normal(size=(4, 3, P + 1, P + 1))
    np.testing.assert_allclose(truncated_product(mask, poly), truncated_product_reference(mask, poly), atol=1e-12)


def test_a_blend_whose_product_fits_the_degree_equals_blending_the_values():
    mask = low_degree((5,), 2)
    top, below = low_degree((5, 3), P - 2), low_degree((5, 3), P - 2)
    m = values(mask)[:, None, :]
    expected = m * values(top) + (1 - m) * values(below)
    np.testing.assert_allclose(values(blended(mask, top, below)), expected, atol=1e-10)


def test_a_colour_transform_of_the_coefficients_is_the_transform_of_the_colours():
    poly = rng.normal(size=(5, 3, P + 1, P + 1))
    for transform in (hue_rotation(73.0), ColorTransform(rng.normal(size=(3, 3)), rng.normal(size=3))):
        colours = np.moveaxis(values(poly), 1, -1)  # (cells, points, 3)
        got = np.moveaxis(values(transformed(poly, transform)), 1, -1)
        np.testing.assert_allclose(got, transform.apply(colours), atol=1e-10)
