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
