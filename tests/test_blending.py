"""The compiled composition (``composite.compose``, ``blending.blend_layer``) against its plain numpy form."""

from __future__ import annotations

import numpy as np
import pytest

from fmr_editor.engine.composite import Composite, LayerFields, compose, compose_reference
from fmr_editor.model.color_transform import hue_rotation, saturation

SHAPE = (7, 11, 3)


def values_of(seed: int) -> dict[str, np.ndarray]:
    """Random field values, well outside [0, 1] too, so that every clamp matters."""
    rng = np.random.default_rng(seed)
    return {name: rng.uniform(-0.5, 1.5, SHAPE) for name in ("bottom", "image", "mask", "alpha")}


LAYERS = {
    "opaque": dict(),
    "opacity": dict(opacity=0.6),
    "mask": dict(mask="mask", mask_base=0.2),
    "inverted mask": dict(mask="mask", mask_inverted=True, opacity=0.9),
    "mask disabled": dict(mask="mask", mask_enabled=False, opacity=0.7),
    "base alone": dict(mask_base=0.4),
    "alpha": dict(alpha="alpha"),
    "alpha, mask, hue": dict(alpha="alpha", mask="mask", transform=hue_rotation(120)),
    "saturation": dict(transform=saturation(2.5), opacity=0.5),
}


@pytest.mark.parametrize("coverage", [False, True])
@pytest.mark.parametrize("top", sorted(LAYERS))
@pytest.mark.parametrize("bottom", [dict(), dict(opacity=0.5), dict(alpha="alpha")])  # covering and not
def test_compose_equals_the_plain_composition(top, bottom, coverage):
    values = values_of(len(top))
    picture = Composite(11, 7, (LayerFields("bottom", **bottom), LayerFields("image", **LAYERS[top])))
    got = compose(picture, values.__getitem__, SHAPE, coverage)
    expected = compose_reference(picture, values.__getitem__, SHAPE, coverage)
    assert got.shape == expected.shape == SHAPE[:-1] + (4 if coverage else 3,)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-14)


def test_compose_of_scattered_samples_equals_the_plain_composition():
    rng = np.random.default_rng(5)
    values = {name: rng.uniform(-0.5, 1.5, (40, 3)) for name in ("bottom", "image", "mask")}
    picture = Composite(10, 10, (LayerFields("bottom", opacity=0.3), LayerFields("image", mask="mask", opacity=0.8)))
    np.testing.assert_allclose(compose(picture, values.__getitem__, (40, 3), True),
                               compose_reference(picture, values.__getitem__, (40, 3), True), rtol=0, atol=1e-14)


@pytest.mark.parametrize("bottom", sorted(LAYERS))
def test_a_bottom_image_in_the_picture_itself_is_blended_in_place(bottom):
    """``compose``'s ``out`` holding the bottom layer's image values (``raster._composed``): the same picture as
    from values of their own, under any mask, alpha, opacity and transform, the layer above read as usual."""
    values = values_of(len(bottom) + 1)
    picture = Composite(11, 7, (LayerFields("bottom", **LAYERS[bottom]), LayerFields("image", **LAYERS["mask"])))
    out = values["bottom"].copy()
    reads = []

    def in_out(name: str) -> np.ndarray:
        reads.append(name)
        return out if name == "bottom" else values[name]

    got = compose(picture, in_out, SHAPE, out=out)
    assert np.shares_memory(got, out) and reads[0] == "bottom"
    np.testing.assert_allclose(got, compose_reference(picture, values.__getitem__, SHAPE), rtol=0, atol=1e-14)
