"""PNG export: permissions and atomic replacement."""

from __future__ import annotations

import os

import numpy as np
import pytest
from PIL import Image

from fmr_editor.io import png


def test_a_new_png_gets_the_usual_permissions(tmp_path):
    umask = os.umask(0o022)
    try:
        written = png.save_png(np.full((4, 5, 3), 0.5), tmp_path / "a.png")
    finally:
        os.umask(umask)
    assert written.stat().st_mode & 0o777 == 0o644  # not mkstemp's 0o600
    assert Image.open(written).size == (5, 4)


def test_a_failed_write_leaves_the_old_png(tmp_path, monkeypatch):
    target = png.save_png(np.zeros((2, 2, 3)), tmp_path / "b.png")
    before = target.read_bytes()
    monkeypatch.setattr(png, "to_rgb8", lambda image: (_ for _ in ()).throw(OSError("disk full")))
    with pytest.raises(OSError):
        png.save_png(np.ones((2, 2, 3)), target)
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["b.png"]  # no temporary file left
