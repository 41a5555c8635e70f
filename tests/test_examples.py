"""The examples under ``docs/examples`` run as written and give what their comments say; the README's
Python example is the quick start, word for word."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest
from scipy.ndimage import maximum_filter, minimum_filter

from fmr_editor import load, render_image

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "docs" / "examples"
RIBBON = ROOT / "resources" / "samples" / "ribbon.xml"


def run(name: str, folder: Path, monkeypatch) -> dict:
    """The example's globals after running it as a script in ``folder``."""
    monkeypatch.chdir(folder)
    return runpy.run_path(str(EXAMPLES / name), run_name="__main__")


def test_the_readme_shows_the_quick_start_as_it_is():
    readme = (ROOT / "README.md").read_text()
    code = (EXAMPLES / "quick_start.py").read_text()
    body = code[code.index("from pathlib"):]
    assert f"```python\n{body}```" in readme


def test_quick_start_renders_the_ribbon_and_the_glow_adds_its_gaussian(tmp_path, monkeypatch):
    found = run("quick_start.py", tmp_path, monkeypatch)
    image, glowing = found["image"], found["glowing"]
    assert image.shape == (256, 256, 3) and image.dtype == np.float32
    ys, xs = np.mgrid[0:256, 0:256] + 0.5
    gaussian = 0.5 * np.exp(-((xs - 120) ** 2 + (ys - 80) ** 2) / 25.0**2)[..., None] * np.array([1.0, 0.8, 0.2])
    expected = image + gaussian
    # Where no sample of a pixel was clipped, before the glow or after it: render_image clips each of a pixel's
    # 3 x 3 samples to [0, 1] before averaging, and a pixel's samples differ by at most its neighbours' range.
    spread = maximum_filter(image, size=(3, 3, 1)) - minimum_filter(image, size=(3, 3, 1))
    unclipped = (image - spread > 0) & (expected + spread < 1)
    assert unclipped.mean() > 0.5
    assert np.abs(glowing - expected)[unclipped].max() < 2e-3  # 3 x 3 samples against the centre's value
    assert (glowing - image)[80, 120].max() > 0.1  # and the point does show


def test_scripted_editing_example_runs(tmp_path, capsys, monkeypatch):
    found = run("scripted_editing.py", tmp_path, monkeypatch)
    session = found["session"]
    assert capsys.readouterr().out.startswith("colours ")
    assert session.history.labels == ("", "Change Stop Colour", "Glow Stroke") and session.history.index == 2
    assert found["image"].shape == (128, 128, 3)
    assert (tmp_path / "out" / "edited.png").stat().st_size > 0


def test_layers_example_renders_the_ribbon_turned_under_the_dabs(tmp_path, monkeypatch):
    from fmr_editor.model.color_transform import hue_rotation

    image = run("layers.py", tmp_path, monkeypatch)["image"]
    plain = render_image(load(RIBBON))
    h, w = plain.shape[:2]
    turned = np.clip(hue_rotation(120).apply(plain), 0, 1)
    centre, corner = (h // 2, w // 2), (2, 2)
    np.testing.assert_allclose(image[centre], turned[centre], atol=2 / 255)  # the mask is 1 there: turned
    np.testing.assert_allclose(image[corner], plain[corner], atol=2 / 255)  # and about 0 far from the dabs
    assert np.abs(turned[centre] - plain[centre]).max() > 0.1  # the two differ there


def test_cloning_example_blends_the_region_into_the_flower(shared_data, tmp_path, monkeypatch):
    import shapely

    found = run("seamless_cloning.py", tmp_path, monkeypatch)
    image, cloned = found["image"], found["cloned"]
    assert len(cloned.layers) == 2 and cloned.layer.clone is not None
    flower = render_image(load(shared_data / "orzan_xml/berkbavas/flower.xml"), samples=1)
    region = shapely.Polygon(cloned.layer.clone.placed_region)
    ys, xs = np.mgrid[0:image.shape[0], 0:image.shape[1]] + 0.5
    distance = shapely.distance(region.exterior, shapely.points(xs.ravel(), ys.ravel())).reshape(xs.shape)
    inside = shapely.contains_xy(region, xs.ravel(), ys.ravel()).reshape(xs.shape)
    outside = ~inside & (distance > 3)
    assert np.abs(image[outside] - flower[outside]).max() <= 1 / 255  # the flower untouched outside
    assert np.abs(image[inside & (distance > 10)] - flower[inside & (distance > 10)]).max() > 0.2  # the clone shows


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.py")), ids=lambda path: path.name)
def test_every_example_is_tested_here(path):
    assert f'"{path.name}"' in Path(__file__).read_text()
