"""The command line, the top-level API and PNG export.

Checks
------
* ``fmr-editor render IN -o OUT.png`` (through ``fmr_editor.cli.main`` and as
  ``python -m fmr_editor``) writes a PNG of the requested size, keeping the
  aspect ratio when only ``--width`` is given, whose pixels are exactly the
  8-bit rounding of ``fmr_editor.render_image``; progress goes to stderr.
* A saved ``.fmr`` file renders like the document it holds.
* ``--method direct`` agrees with the FMR to one 8-bit level.
* Bad input (malformed or missing file) and an unwritable output path end with
  exit code 2 and a one-line message, without a traceback or an output file.
* ``fmr_editor.render_image`` returns float32 ``(H, W, 3)`` in ``[0, 1]`` and
  reproduces closed-form solutions: a constant colour, and a straight line
  across the canvas splitting it into two constant halves.
* ``save_png`` never leaves a temporary file behind and never half-writes.

Outputs are kept small (16-48 pixels wide) so the whole file runs in seconds.
"""

from __future__ import annotations

import contextlib
import io
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from shapes import circle_points, uniform_curve

import fmr_editor
from fmr_editor.cli import main
from fmr_editor.engine import build, rasterise
from fmr_editor.io import save_fmr
from fmr_editor.io.png import save_png, to_rgb8
from fmr_editor.model import Document

REPO = Path(__file__).resolve().parents[1]
RIBBON = REPO / "resources" / "samples" / "ribbon.xml"
PROGRESS_LINE = re.compile(r"^\[\s*\d+\.\ds\] \S+ +\d+%$")


# --- helpers ----------------------------------------------------------------------------------


def run_module(*args: str) -> subprocess.CompletedProcess[str]:
    """``python -m fmr_editor ARGS`` in a fresh interpreter."""
    return subprocess.run(
        [sys.executable, "-m", "fmr_editor", *map(str, args)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
    )


def read_png(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.mode == "RGB"
        return np.asarray(image)


def orzan_xml(width: int, height: int, curves: list[dict]) -> str:
    """An Orzan CurveSetXML file for ``curves`` given in document terms.

    Each curve is ``{"points": [(x, y), ...], "left": [(s, (r, g, b)), ...], "right": [...]}``
    with colours in 0..255.  Orzan's traps are applied here: ``x`` attribute = row = document y,
    ``y`` attribute = column = document x; attribute ``B`` = red, ``R`` = blue; globalID = 10 s.
    """

    def stops(tag: str, items) -> str:
        return "".join(
            f'<{tag} G="{g}" R="{b}" globalID="{10 * s:g}" B="{r}" />' for s, (r, g, b) in items
        )

    body = []
    for curve in curves:
        points = "".join(f'<control_point x="{y:g}" y="{x:g}" />' for x, y in curve["points"])
        body.append(
            f'<curve nb_control_points="{len(curve["points"])}">'
            f"<control_points_set>{points}</control_points_set>"
            f'<left_colors_set>{stops("left_color", curve["left"])}</left_colors_set>'
            f'<right_colors_set>{stops("right_color", curve["right"])}</right_colors_set>'
            "</curve>"
        )
    return (
        "<!DOCTYPE CurveSetXML>\n"
        f'<curve_set image_width="{width}" image_height="{height}" nb_curves="{len(curves)}">'
        + "".join(body)
        + "</curve_set>\n"
    )


@pytest.fixture(scope="module")
def ribbon_48() -> np.ndarray:
    """``fmr_editor.render_image`` of the bundled sample at 48x48, 3x3 samples."""
    return fmr_editor.render_image(fmr_editor.load(RIBBON), 48, 48, samples=3)


@pytest.fixture
def split_canvas(tmp_path) -> Path:
    """A 60x40 canvas cut by a vertical line at x = 20: red right of it, blue left of it.

    The line runs downwards (y increasing), so with y down the viewer's left is +x; it spans the
    canvas, so with the reflecting border each side is exactly constant.
    """
    line = [(20.0, -5.0), (20.0, 12.0), (20.0, 28.0), (20.0, 45.0)]
    path = tmp_path / "split.xml"
    path.write_text(orzan_xml(60, 40, [{"points": line, "left": [(0, (255, 0, 0))], "right": [(0, (0, 0, 255))]}]))
    return path


# --- rendering through the command line -------------------------------------------------------


def test_render_command_writes_the_rendered_png(tmp_path, capsys, ribbon_48):
    out = tmp_path / "ribbon.png"
    assert main(["render", str(RIBBON), "-o", str(out), "--width", "48"]) == 0
    pixels = read_png(out)
    assert pixels.shape == (48, 48, 3)  # the sample is square: --width alone keeps 1:1
    np.testing.assert_array_equal(pixels, to_rgb8(ribbon_48))
    assert str(out) in capsys.readouterr().out


def test_progress_follows_the_current_sys_stderr(tmp_path):
    stream = io.StringIO()
    with contextlib.redirect_stderr(stream):
        assert main(["render", str(RIBBON), "-o", str(tmp_path / "x.png"), "--width", "8", "--samples", "1"]) == 0
    lines = stream.getvalue().strip().splitlines()
    assert lines and all(PROGRESS_LINE.match(line) for line in lines)


def test_width_alone_keeps_the_aspect_ratio_of_a_non_square_canvas(tmp_path, split_canvas):
    out = tmp_path / "split.png"
    assert main(["render", str(split_canvas), "-o", str(out), "--width", "30"]) == 0
    pixels = read_png(out)
    assert pixels.shape == (20, 30, 3)
    reference = fmr_editor.render_image(fmr_editor.load(split_canvas), 30, 20, samples=3)
    np.testing.assert_array_equal(pixels, to_rgb8(reference))
    # closed form: pixel column j covers document x in [2j, 2j + 2]; the line is at x = 20
    expected = np.where((np.arange(30) >= 10)[None, :, None], [255, 0, 0], [0, 0, 255])
    assert np.abs(pixels.astype(int) - expected).max() <= 1


def test_height_alone_keeps_the_aspect_ratio(tmp_path, split_canvas):
    out = tmp_path / "split.png"
    assert main(["render", str(split_canvas), "-o", str(out), "--height", "10", "--samples", "1"]) == 0
    assert read_png(out).shape == (10, 15, 3)


def test_render_command_reads_a_saved_fmr_file(tmp_path, split_canvas, monkeypatch):
    document = fmr_editor.load(split_canvas)
    saved = save_fmr(tmp_path / "split.fmr", document, build(document))
    out = tmp_path / "split.png"
    monkeypatch.setattr(fmr_editor, "render_image",
                        lambda *args, **kwargs: pytest.fail("the saved representation was not used"))
    assert main(["render", str(saved), "-o", str(out), "--width", "30", "--samples", "1"]) == 0
    expected = to_rgb8(rasterise(build(document), 30, 20, samples=1))
    np.testing.assert_array_equal(read_png(out), expected)


def test_python_dash_m_renders_and_reports_progress_on_stderr(tmp_path):
    in_process, subprocess_out = tmp_path / "a.png", tmp_path / "b.png"
    args = ["render", str(RIBBON), "--width", "24", "--samples", "2"]
    assert main([*args, "-o", str(in_process)]) == 0
    result = run_module(*args, "-o", subprocess_out)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    np.testing.assert_array_equal(read_png(subprocess_out), read_png(in_process))
    lines = result.stderr.strip().splitlines()
    assert lines and all(PROGRESS_LINE.match(line) for line in lines), result.stderr
    assert any(line.endswith("100%") for line in lines)
    assert str(subprocess_out) in result.stdout


def test_direct_method_matches_the_fmr_to_one_level(tmp_path):
    fmr, direct = tmp_path / "fmr.png", tmp_path / "direct.png"
    args = ["render", str(RIBBON), "--width", "16", "--samples", "1"]
    assert main([*args, "-o", str(fmr)]) == 0
    assert main([*args, "-o", str(direct), "--method", "direct"]) == 0
    a, b = read_png(fmr).astype(int), read_png(direct).astype(int)
    assert a.shape == b.shape == (16, 16, 3)
    assert np.abs(a - b).max() <= 1


def test_invalid_option_values_are_usage_errors(tmp_path):
    for bad in (["--width", "0"], ["--samples", "-2"], ["--method", "magic"]):
        with pytest.raises(SystemExit) as exit_info:
            main(["render", str(RIBBON), "-o", str(tmp_path / "x.png"), *bad])
        assert exit_info.value.code == 2
    assert list(tmp_path.iterdir()) == []


# --- failures ---------------------------------------------------------------------------------


def assert_clean_failure(result: subprocess.CompletedProcess[str], name: str) -> None:
    """Exit code 2, one line on stderr naming ``name``, no traceback."""
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert name in lines[0]


def test_malformed_file_fails_cleanly(tmp_path):
    broken = tmp_path / "truncated.xml"
    text = RIBBON.read_text()
    broken.write_text(text[: len(text) // 2])
    out = tmp_path / "out.png"
    assert_clean_failure(run_module("render", broken, "-o", out, "--width", "16"), broken.name)
    assert sorted(p.name for p in tmp_path.iterdir()) == [broken.name]


def test_missing_input_fails_cleanly(tmp_path):
    out = tmp_path / "out.png"
    assert_clean_failure(run_module("render", tmp_path / "absent.xml", "-o", out), "absent.xml")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("below", ["out.png", "sub/out.png"])
def test_output_under_a_file_fails_cleanly(tmp_path, capsys, split_canvas, below):
    blocker = tmp_path / "blocker"
    blocker.write_text("not a directory")
    out = blocker / below
    assert main(["render", str(split_canvas), "-o", str(out), "--width", "8", "--samples", "1"]) == 2
    message = capsys.readouterr().err.strip().splitlines()[-1]
    assert message.startswith("fmr-editor: cannot write") and str(out) in message
    assert blocker.read_text() == "not a directory"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker", split_canvas.name]


# --- the top-level API ------------------------------------------------------------------------


def test_render_returns_float32_rgb_in_the_unit_range(ribbon_48):
    assert ribbon_48.dtype == np.float32
    assert ribbon_48.shape == (48, 48, 3)
    assert np.isfinite(ribbon_48).all()
    assert ribbon_48.min() >= 0.0 and ribbon_48.max() <= 1.0
    assert ribbon_48.std() > 0.05, "the sample has visibly varying colours"


def test_render_of_a_constant_document_is_constant():
    doc = Document(40, 30, [uniform_curve(circle_points(22.0, 14.0, 9.0), 0.25, 0.25)])
    image = fmr_editor.render_image(doc, samples=1)
    assert image.dtype == np.float32
    assert image.shape == (30, 40, 3)
    np.testing.assert_allclose(image, 0.25, rtol=0, atol=1e-3)
    assert fmr_editor.render_image(doc, width=20, samples=1).shape == (15, 20, 3)


def test_render_of_a_line_across_the_canvas_gives_two_constant_halves(split_canvas):
    image = fmr_editor.render_image(fmr_editor.load(split_canvas), samples=1)  # canvas size: 60x40
    assert image.shape == (40, 60, 3)
    right_of_line = np.arange(60) + 0.5 > 20.0
    expected = np.where(right_of_line[None, :, None], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(image, np.broadcast_to(expected, image.shape), rtol=0, atol=1e-3)


# --- save_png ---------------------------------------------------------------------------------


def test_save_png_writes_rounded_levels_and_no_temporary_file(tmp_path):
    image = np.linspace(-0.2, 1.2, 4 * 5 * 3).reshape(4, 5, 3)
    written = save_png(image, tmp_path / "deep" / "image.png")
    assert written == (tmp_path / "deep" / "image.png").absolute()
    expected = np.round(np.clip(image, 0, 1) * 255).astype(np.uint8)
    np.testing.assert_array_equal(read_png(written), expected)
    assert [p.name for p in (tmp_path / "deep").iterdir()] == ["image.png"]


def test_save_png_writes_straight_rgba_where_the_coverage_is_below_1_and_rgb_where_it_is_not(tmp_path):
    over_black = np.array([[[0.2, 0.1, 0.0, 0.5], [0.3, 0.6, 0.9, 1.0], [0.0, 0.0, 0.0, 0.0]]])
    with Image.open(save_png(over_black, tmp_path / "clear.png")) as image:
        assert image.mode == "RGBA"
        np.testing.assert_array_equal(np.asarray(image), [[[102, 51, 0, 128], [76, 153, 230, 255], [0, 0, 0, 0]]])
    opaque = over_black.copy()
    opaque[..., 3] = 1.0
    with Image.open(save_png(opaque, tmp_path / "opaque.png")) as image:
        assert image.mode == "RGB"
        np.testing.assert_array_equal(np.asarray(image), np.round(opaque[..., :3] * 255))


@pytest.mark.parametrize("shape", [(4, 5), (4, 5, 2), (4, 5, 5), (0, 5, 3)])
def test_failed_save_leaves_no_temporary_file_and_keeps_the_old_png(tmp_path, shape):
    target = tmp_path / "image.png"
    save_png(np.full((2, 3, 3), 0.5), target)
    before = target.read_bytes()
    with pytest.raises(ValueError):
        save_png(np.zeros(shape), target)
    assert [p.name for p in tmp_path.iterdir()] == ["image.png"]
    assert target.read_bytes() == before


def test_failed_save_to_a_new_path_creates_nothing(tmp_path):
    with pytest.raises(ValueError):
        save_png(np.zeros((4, 5)), tmp_path / "new.png")
    assert list(tmp_path.iterdir()) == []


# --- several documents at once ------------------------------------------------------------------


def test_several_inputs_render_into_a_folder_each_as_alone(tmp_path, split_canvas):
    folder = tmp_path / "renders"
    assert main(["render", str(RIBBON), str(split_canvas), "-o", str(folder), "--width", "24", "--samples", "1"]) == 0
    assert sorted(p.name for p in folder.iterdir()) == [f"{RIBBON.stem}.png", "split.png"]
    alone = tmp_path / "alone.png"
    assert main(["render", str(split_canvas), "-o", str(alone), "--width", "24", "--samples", "1"]) == 0
    np.testing.assert_array_equal(read_png(folder / "split.png"), read_png(alone))


def test_a_bad_input_among_several_is_reported_and_the_rest_rendered(tmp_path, capsys, split_canvas):
    broken = tmp_path / "broken.xml"
    broken.write_text("<curve_set")
    folder = tmp_path / "out"
    assert main(["render", str(broken), str(split_canvas), "-o", str(folder), "--width", "8", "--samples", "1"]) == 2
    assert sorted(p.name for p in folder.iterdir()) == ["split.png"]
    err = capsys.readouterr().err
    assert "broken.xml" in err and "1 of 2 documents failed" in err and "Traceback" not in err


def test_inputs_with_the_same_name_are_refused_before_rendering(tmp_path, capsys, split_canvas):
    other = tmp_path / "other" / "split.xml"
    other.parent.mkdir()
    other.write_text(split_canvas.read_text())
    folder = tmp_path / "out"
    assert main(["render", str(split_canvas), str(other), "-o", str(folder)]) == 2
    assert "split.png" in capsys.readouterr().err and not folder.exists()
