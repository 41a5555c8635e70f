"""Inputs too large for memory fail early, with a clear message, before allocating."""

from __future__ import annotations

import pytest
from shapes import circle_points, uniform_curve

from fmr_editor import cli
from fmr_editor.engine import build
from fmr_editor.engine.solve import dense as bem
from fmr_editor.engine.solve import solver as fast_solve
from fmr_editor.engine.solve.dense import SolveTooLargeError
from fmr_editor.model import Document

DOC = Document(64, 64, [uniform_curve(circle_points(32, 32, 20), 1.0, 0.0)])
XML = ('<curve_set image_width="64" image_height="64"><curve><control_points_set>'
       + "".join(f'<control_point x="{x}" y="{y}"/>' for x, y in [(10, 10), (20, 50), (40, 5), (54, 54)])
       + "</control_points_set></curve></curve_set>")


@pytest.fixture
def no_assembly(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the dense system was assembled although it cannot fit")

    monkeypatch.setattr(bem, "assemble", refuse)


def test_dense_solve_fails_before_assembly(monkeypatch, no_assembly):
    monkeypatch.setattr(bem, "available_memory", lambda: 1_000_000)
    with pytest.raises(SolveTooLargeError, match=r"boundary segments need a .* dense system \(0.0 GB available"):
        build(DOC)


def test_fast_solve_fails_before_its_top_block(monkeypatch, no_assembly):
    monkeypatch.setattr(fast_solve, "DENSE_CROSSOVER", 10)
    monkeypatch.setattr(bem, "available_memory", lambda: 100_000)
    with pytest.raises(SolveTooLargeError, match=r"compressed factorisation needs more than"):
        build(DOC)


def test_command_line_reports_it_in_one_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(bem, "available_memory", lambda: 1_000_000)
    source = tmp_path / "big.xml"
    source.write_text(XML)
    assert cli.main(["render", str(source), "-o", str(tmp_path / "out.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("fmr-editor: cannot render") and "dense system" in err[-1]
    assert not any("Traceback" in line for line in err)
    assert all(line.startswith("[") for line in err[:-1])  # the rest is progress
    assert not (tmp_path / "out.png").exists()
