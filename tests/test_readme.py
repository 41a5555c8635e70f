"""The README's scripted-editing example runs as written."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_scripted_editing_example_runs(tmp_path, capsys, monkeypatch):
    text = (ROOT / "README.md").read_text()
    section = text[text.index("### Scripted editing"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    code = code.replace('"resources/samples/', f'"{ROOT}/resources/samples/')
    monkeypatch.chdir(tmp_path)  # save_png writes out/edited.png here
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102 - the project's own README
    session = namespace["session"]
    assert capsys.readouterr().out.startswith("colours ")
    assert session.history.labels == ("", "Change Stop Colour", "Paint") and session.history.index == 2
    assert namespace["image"].shape == (128, 128, 3)
    assert (tmp_path / "out" / "edited.png").stat().st_size > 0


def test_layers_example_renders_the_ribbon_turned_under_the_dabs(monkeypatch):
    import numpy as np

    from fmr_editor import load, render_image
    from fmr_editor.model.color_transform import hue_rotation

    text = (ROOT / "README.md").read_text()
    section = text[text.index("### Layers\n"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    code = code.replace('"resources/samples/', f'"{ROOT}/resources/samples/')
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102 - the project's own README
    image = namespace["image"]
    plain = render_image(load(ROOT / "resources/samples/ribbon.xml"))
    h, w = plain.shape[:2]
    turned = np.clip(hue_rotation(120).apply(plain), 0, 1)
    centre, corner = (h // 2, w // 2), (2, 2)
    np.testing.assert_allclose(image[centre], turned[centre], atol=2 / 255)  # the mask is 1 there: turned
    np.testing.assert_allclose(image[corner], plain[corner], atol=2 / 255)  # and about 0 far from the dabs
    assert np.abs(turned[centre] - plain[centre]).max() > 0.1  # the two differ there


def test_cloning_example_blends_the_region_into_the_flower(shared_data, monkeypatch):
    import numpy as np
    import shapely

    from fmr_editor import load, render_image

    text = (ROOT / "README.md").read_text()
    section = text[text.index("### Seamless cloning\n\n```python"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    monkeypatch.chdir(ROOT)
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102 - the project's own README
    image, cloned = namespace["image"], namespace["cloned"]
    assert len(cloned.layers) == 2 and cloned.layer.clone is not None
    flower = render_image(load(shared_data / "orzan_xml/berkbavas/flower.xml"), samples=1)
    region = shapely.Polygon(cloned.layer.clone.placed_region)
    ys, xs = np.mgrid[0:image.shape[0], 0:image.shape[1]] + 0.5
    distance = shapely.distance(region.exterior, shapely.points(xs.ravel(), ys.ravel())).reshape(xs.shape)
    inside = shapely.contains_xy(region, xs.ravel(), ys.ravel()).reshape(xs.shape)
    outside = ~inside & (distance > 3)
    assert np.abs(image[outside] - flower[outside]).max() <= 1 / 255  # the flower untouched outside
    assert np.abs(image[inside & (distance > 10)] - flower[inside & (distance > 10)]).max() > 0.2  # the clone shows
