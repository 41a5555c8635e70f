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
