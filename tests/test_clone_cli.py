"""``fmr-editor clone``: a region of one document pasted seamlessly into another, from the command line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import shapely
from cli_runs import run
from PIL import Image
from shapes import scattered_document

from fmr_editor.engine import LiveStack, Settings, build, rasterise
from fmr_editor.io import load_fmr, save_fmr
from fmr_editor.io.png import to_rgb8

SIZE = 128
PIXELS = 48
REGION = "30,36 90,36 100,70 60,95 25,70"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("clone")
    paths = {"target": folder / "target.fmr", "source": folder / "source.fmr", "plain": folder / "plain.fmr"}
    for name, seed in (("target", 8), ("source", 3)):
        document = scattered_document(SIZE, seed=seed)
        save_fmr(paths[name], document, build(document), settings=Settings())
    save_fmr(paths["plain"], scattered_document(SIZE, seed=5))  # no representation: clone solves it
    return paths


def test_clone_places_the_region_turned_and_scaled_about_its_centroid_and_render_draws_it(tmp_path, inputs):
    out = tmp_path / "out.fmr"
    code, printed, err = run("clone", str(inputs["target"]), str(inputs["source"]), "--region", REGION,
                             "--offset", "6,-4", "--rotate", "30", "--scale", "0.9", "-o", str(out))
    assert code == 0 and "2 layers" in printed, err
    opened = load_fmr(out)
    document = opened.document
    assert opened.composite is not None and document.active == 1  # saved whole: opening solves nothing
    clone = document.layer.clone
    corners = np.array([[float(v) for v in corner.split(",")] for corner in REGION.split()])
    centroid = np.asarray(shapely.Polygon(corners).centroid.coords[0])
    turn = np.radians(30.0)
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    expected = centroid + 0.9 * (corners - centroid) @ rotation.T + [6.0, -4.0]
    np.testing.assert_allclose(clone.placed_region, expected, atol=1e-9)
    assert clone.source == load_fmr(inputs["source"]).document
    png = tmp_path / "out.png"
    assert run("render", str(out), "-o", str(png), "--width", str(PIXELS), "--samples", "1")[0] == 0
    fresh = to_rgb8(rasterise(LiveStack(document).composite, PIXELS, samples=1).clip(0, 1)).astype(int)
    got = np.asarray(Image.open(png).convert("RGB")).astype(int)
    assert np.abs(got - fresh).max() <= 1  # what the file keeps is the clone made afresh
    target = to_rgb8(rasterise(build(load_fmr(inputs["target"]).document), PIXELS, samples=1).clip(0, 1))
    assert np.abs(got - target.astype(int)).max() > 20  # and the clone shows


def test_clone_solves_inputs_saved_without_a_representation(tmp_path, inputs):
    out = tmp_path / "out.fmr"
    code, _, err = run("clone", str(inputs["plain"]), str(inputs["plain"]), "--region", REGION, "--offset", "10,5",
                       "-o", str(out))
    assert code == 0, err
    assert load_fmr(out).composite is not None


@pytest.mark.parametrize("extra, message", [
    (("--region", "0,0 10,10 10,0 0,10"), "crosses itself"),
    (("--region", "1,2 3,4"), "at least three corners"),
    (("--region", "1,2 3,x 5,6"), "must be a number"),
    (("--region", "0,0 10,10 20,20"), "no area"),
    (("--region", "200,200 220,200 210,230"), "wholly outside the canvas"),
    (("--region", REGION, "--offset", "500,0"), "where the clone goes, the region lies wholly outside the canvas"),
    (("--region", REGION, "--scale", "-1"), "the scale must be positive"),
    (("--region", REGION, "--rotate", "nan"), "must be a finite number"),
    (("--region", REGION, "--offset", "1"), "two numbers as X,Y"),
])
def test_clone_refuses_bad_input_with_one_line_and_writes_nothing(tmp_path, inputs, extra, message):
    out = tmp_path / "out.fmr"
    code, _, err = run("clone", str(inputs["target"]), str(inputs["source"]), "-o", str(out), *extra)
    assert code == 2 and message in err.strip().splitlines()[-1], err
    assert "Traceback" not in err and not out.exists()


def test_clone_of_a_missing_file_or_to_a_png_says_so(tmp_path, inputs):
    code, _, err = run("clone", str(inputs["target"]), "missing.fmr", "--region", REGION, "-o", str(tmp_path / "o.fmr"))
    assert code == 2 and "cannot open missing.fmr: file not found" in err
    code, _, err = run("clone", str(inputs["target"]), str(inputs["source"]), "--region", REGION,
                       "-o", str(tmp_path / "o.png"))
    assert code == 2 and "clone writes an .fmr document" in err and not (tmp_path / "o.png").exists()
