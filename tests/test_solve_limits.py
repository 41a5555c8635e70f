"""Inputs too large for the dense solve fail early, with a clear message, before allocating."""

from __future__ import annotations

import pytest
from shapes import circle_points, uniform_curve

from fmr_editor import cli
from fmr_editor.engine import bem, build
from fmr_editor.engine.bem import SolveTooLargeError
from fmr_editor.model import Document

DOC = Document(64, 64, [uniform_curve(circle_points(32, 32, 20), 1.0, 0.0)])


@pytest.fixture
def no_assembly(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the dense system was assembled although it cannot fit")

    monkeypatch.setattr(bem, "assemble", refuse)


def test_too_many_segments_fail_before_assembly(monkeypatch, no_assembly):
    monkeypatch.setattr(bem, "DENSE_LIMIT", 50)
    with pytest.raises(SolveTooLargeError, match=r"boundary segments need a .* dense system \(limit 50 segments"):
        build(DOC)


def test_too_little_memory_fails_before_assembly(monkeypatch, no_assembly):
    monkeypatch.setattr(bem, "available_memory", lambda: 1_000_000)
    with pytest.raises(SolveTooLargeError, match=r"GB available"):
        build(DOC)


def test_command_line_reports_it_in_one_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(bem, "DENSE_LIMIT", 50)
    source = tmp_path / "big.xml"
    source.write_text(
        '<curve_set image_width="64" image_height="64"><curve><control_points_set>'
        + "".join(f'<control_point x="{x}" y="{y}"/>' for x, y in [(10, 10), (20, 50), (40, 5), (54, 54)])
        + "</control_points_set></curve></curve_set>"
    )
    assert cli.main(["render", str(source), "-o", str(tmp_path / "out.png")]) == 2
    err = capsys.readouterr().err
    assert "dense system" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out.png").exists()
