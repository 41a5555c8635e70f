"""Colour transforms of layers (``model.color_transform``) against the W3C filter-effects definitions."""

from __future__ import annotations

import numpy as np
import pytest

from fmr_editor.model.color_transform import (
    IDENTITY,
    LUMA,
    ColorTransform,
    brightness_contrast,
    hue_rotation,
    inversion,
    saturation,
)

rng = np.random.default_rng(12)
COLORS = rng.uniform(0, 1, (50, 3))


def test_the_presets_at_their_neutral_settings_change_nothing():
    for transform in (hue_rotation(0.0), hue_rotation(360.0), saturation(1.0), brightness_contrast(1.0, 1.0)):
        np.testing.assert_allclose(transform.apply(COLORS), COLORS, atol=1e-12)
    assert IDENTITY.is_identity and ColorTransform(np.eye(3), np.zeros(3)) == IDENTITY


@pytest.mark.parametrize("degrees", [30.0, 90.0, 180.0, 275.0])
def test_hue_rotation_keeps_greys_and_follows_the_w3c_matrix(degrees):
    greys = np.repeat(rng.uniform(0, 1, (10, 1)), 3, axis=1)
    rotated = hue_rotation(degrees)
    np.testing.assert_allclose(rotated.apply(greys), greys, atol=1e-12)
    # the W3C formula for the red channel of pure red: .213 + .787 cos + (-.213) sin
    theta = np.radians(degrees)
    red = rotated.apply(np.array([1.0, 0.0, 0.0]))
    assert red[0] == pytest.approx(0.213 + 0.787 * np.cos(theta) - 0.213 * np.sin(theta), abs=1e-12)
    assert red[1] == pytest.approx(0.213 - 0.213 * np.cos(theta) + 0.143 * np.sin(theta), abs=1e-12)


def test_saturation_zero_gives_the_luminance_grey_and_inversion_undoes_itself():
    grey = saturation(0.0).apply(COLORS)
    np.testing.assert_allclose(grey, np.repeat((COLORS @ LUMA)[:, None], 3, axis=1), atol=1e-12)
    np.testing.assert_allclose(inversion().apply(COLORS), 1.0 - COLORS, atol=0)
    np.testing.assert_allclose(inversion().then(inversion()).apply(COLORS), COLORS, atol=1e-15)


def test_brightness_scales_and_contrast_pivots_about_mid_grey():
    np.testing.assert_allclose(brightness_contrast(2.0, 1.0).apply(COLORS), 2 * COLORS, atol=1e-15)
    np.testing.assert_allclose(brightness_contrast(1.0, 0.0).apply(COLORS), 0.5, atol=0)
    np.testing.assert_allclose(brightness_contrast(1.5, 2.0).apply(COLORS), 2 * (1.5 * COLORS) - 0.5, atol=1e-14)


def test_then_is_applying_one_after_the_other():
    a = ColorTransform(rng.normal(size=(3, 3)), rng.normal(size=3))
    b = ColorTransform(rng.normal(size=(3, 3)), rng.normal(size=3))
    np.testing.assert_allclose(a.then(b).apply(COLORS), b.apply(a.apply(COLORS)), atol=1e-12)


@pytest.mark.parametrize("matrix, offset", [(np.eye(2), np.zeros(3)), (np.eye(3), np.zeros(4)),
                                            (np.full((3, 3), np.nan), np.zeros(3)), (np.eye(3), [0, np.inf, 0]),
                                            (np.eye(3) * 1e308, np.zeros(3)), (np.eye(3), [0, 0, -2e6])])
def test_malformed_transforms_are_refused(matrix, offset):
    with pytest.raises(ValueError, match="colour transform"):
        ColorTransform(matrix, offset)
