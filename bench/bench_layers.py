"""Layers benchmark: a 3-layer document with masks against the same curves in one layer (issue 13).

    python bench/bench_layers.py [FILE] [--size S] [--repeat N]

FILE (default lady_bug.xml from ../shared/data) is split into three layers by
curve order (its curves, a third each): the middle one masked by a closed
circle (a sharp curve mask) and hue-rotated, the top one masked by diffusion
points (a soft mask) at 80% opacity.  The flat document is FILE itself: the
same curves in one layer.  Side by side, in one run, best of N (the machine
is shared and noisy):

- **canvas redraw**: ``PictureRenderer.draw`` with nothing changed (a copy of
  the composed image), and the **full evaluation** (every window pixel of every
  layer and mask evaluated and composed: a zoom or a resize), S x S window;
- **CPU raster**: ``engine.rasterise`` of the composite and of the flat
  document at the canvas size and at S x S, one sample a pixel;
- **mask dab**: one diffusion point into the top layer's mask, from the edit
  to the finished frame (engine update, renderer update, draw, ``glFinish``);
- **hue change**: the middle layer's hue turned, edit to frame (no solve: the
  transform applies at composition).

Targets: composite redraw within 1.5x the flat document's, mask dab <= 10 ms,
hue change <= 30 ms.

A second table sets the flat document beside the same curves with every right-hand stop at alpha 0.5
(a translucent layer, which solves and draws an alpha field as well): build, CPU raster (best of N on one
stack, and the first raster after each build, which also pays for its fresh arrays' pages), canvas full
evaluation, a stop colour edit (engine update, and edit to frame) and, of the translucent one, a stop alpha
edit to frame (issue 28's target: alpha adds at most a third).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
from bench_canvas import DEFAULT_FILE, best, full_evaluations, redraws, start_xvfb

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))


def layered(document):
    """FILE's curves in three layers, with a curve mask, a points mask, a hue rotation and an opacity."""
    from shapes import circle_points, uniform_curve

    from fmr_editor.model import DiffusionPoint, Document, Layer, Mask
    from fmr_editor.model.color_transform import hue_rotation

    w, h = document.width, document.height
    thirds = np.array_split(np.arange(len(document.curves)), 3)
    curves = [tuple(document.curves[i] for i in part) for part in thirds]
    rng = np.random.default_rng(3)
    circle = Mask(curves=[uniform_curve(circle_points(0.55 * w, 0.45 * h, 0.3 * min(w, h)), 1.0, 0.0)])
    soft = Mask(points=[DiffusionPoint((float(x), float(y)), float(r), (1.0, 1.0, 1.0), 0.8)
                        for x, y, r in zip(rng.uniform(0, w, 40), rng.uniform(0, h, 40), rng.uniform(15, 60, 40))])
    layers = (Layer(curves[0], name="bottom"),
              Layer(curves[1], name="middle", mask=circle, transform=hue_rotation(120)),
              Layer(curves[2], name="top", mask=soft, opacity=0.8))
    return Document(w, h, layers=layers, active=2)


def translucent(document):
    """``document`` with every curve's right-hand stops (a black one where it has none) at alpha 0.5."""
    from dataclasses import replace

    from fmr_editor.model import ColorStop

    def half(curve):
        right = tuple(replace(stop, alpha=0.5) for stop in curve.right or (ColorStop(0.0, (0.0, 0.0, 0.0)),))
        return replace(curve, right=right, id=curve.id)

    return replace(document, layers=(document.layers[0].with_curves(map(half, document.curves)),))


def alpha_rows(args, opaque_document) -> dict:
    """Build, raster (the first after a build, whose fresh arrays take their pages, and again), full evaluation and
    a stop colour edit of the opaque document and its translucent twin."""
    from fmr_editor.engine import LiveStack, rasterise
    from fmr_editor.model import edits

    rows = {}
    for name, document in (("opaque", opaque_document), ("translucent", translucent(opaque_document))):
        builds, firsts, rasters, recolours = [], [], [], []
        for run in range(args.repeat):
            start = time.perf_counter()
            stack = LiveStack(document)
            builds.append(time.perf_counter() - start)
            for times in (firsts, rasters):
                start = time.perf_counter()
                rasterise(stack.composite, samples=1)
                times.append(time.perf_counter() - start)
            curve = stack.document.curves[run % len(stack.document.curves)]
            start = time.perf_counter()
            stack.update(edits.set_stop_color(stack.document, curve.id, "right", 0, (0.2, 0.4, 0.9)))
            recolours.append(time.perf_counter() - start)
        rows[name] = (best(builds) / 1e3, best(rasters), best(recolours), stack, best(firsts))
    return rows


def gl_rows(args, flat_picture, stack, fields_count, alpha_stacks: dict) -> tuple[list[tuple], dict]:
    """Redraw and full evaluation of both pictures in a S x S canvas; the edits' frames; and of each of
    ``alpha_stacks``, by name, the full evaluation, a stop colour's and a stop alpha's edit to frame (ms; the
    opaque one's alpha None)."""
    from OpenGL import GL
    from PySide6.QtTest import QTest

    from fmr_editor.model import DiffusionPoint, edits, layer_edits
    from fmr_editor.model.color_transform import hue_rotation
    from fmr_editor.render import View
    from fmr_editor.ui.canvas import Canvas

    size = args.size
    view = View(size / max(flat_picture.width, flat_picture.height), 0.0, 0.0, size, size)
    canvas = Canvas()
    canvas.resize(size, size)
    canvas.show()
    QTest.qWaitForWindowExposed(canvas)
    canvas.repaint()
    if canvas.renderer is None:
        sys.exit(f"bench_layers: no OpenGL canvas: {canvas.error}")
    canvas.makeCurrent()
    renderer, fbo = canvas.renderer, canvas.defaultFramebufferObject()
    results = {}
    for name, picture in (("flat", flat_picture), ("layers", stack.composite)):
        renderer.upload(picture)
        renderer.draw(view, fbo)
        GL.glFinish()
        results[name] = (best(redraws(renderer, view, fbo, args.repeat, args.frames)),
                         best(full_evaluations(renderer, view, fbo, args.repeat)))
    alpha_evaluations = {}
    for name, alpha_stack in alpha_stacks.items():
        renderer.upload(alpha_stack.composite)
        renderer.draw(view, fbo)
        GL.glFinish()
        full = best(full_evaluations(renderer, view, fbo, args.repeat))
        curves = alpha_stack.document.curves
        colours = [edit_to_frame(alpha_stack, edits.set_stop_color(alpha_stack.document, curves[i % len(curves)].id,
                                                                   "right", 0, (0.2, 0.4, 0.1 * (i % 9))),
                                 renderer, view, fbo)[1] for i in range(args.repeat)]
        alphas = [edit_to_frame(alpha_stack, edits.set_stop_alpha(alpha_stack.document, curves[i % len(curves)].id,
                                                                  "right", 0, 0.3 + 0.04 * (i % 5)),  # never 0.5
                                renderer, view, fbo)[1] for i in range(args.repeat)] if name == "translucent" else None
        alpha_evaluations[name] = (full, best(colours), None if alphas is None else best(alphas))
    renderer.upload(stack.composite)
    rows = [("canvas redraw, nothing changed (ms)", results["flat"][0], results["layers"][0]),
            (f"canvas full evaluation, {size}x{size} (ms)", results["flat"][1], results["layers"][1])]

    top, middle = stack.document.layers[2], stack.document.layers[1]
    rng = np.random.default_rng(5)
    dabs, hues = [], []
    for i in range(args.repeat):
        point = DiffusionPoint(tuple(rng.uniform(0, flat_picture.width, 2)), 20.0, (1.0, 1.0, 1.0), -0.5)
        document = layer_edits.add_mask_points(stack.document, 2, [point])
        dabs.append(edit_to_frame(stack, document, renderer, view, fbo))
        document = layer_edits.set_transform(stack.document, 1, hue_rotation(120 + 7 * (i + 1)))
        hues.append(edit_to_frame(stack, document, renderer, view, fbo))
    assert stack.document.layers[2].id == top.id and stack.document.layers[1].id == middle.id
    dab, hue = np.min(dabs, axis=0) * 1e3, np.min(hues, axis=0) * 1e3
    rows += [("mask dab: engine update (ms)", None, dab[0]), ("mask dab: edit to frame (ms)", None, dab[1]),
             ("hue change: engine update (ms)", None, hue[0]), ("hue change: edit to frame (ms)", None, hue[1])]
    canvas.close()
    return rows, alpha_evaluations


def edit_to_frame(stack, document, renderer, view, fbo) -> tuple[float, float]:
    """Seconds of the engine update and of the whole edit to the finished frame."""
    from OpenGL import GL

    start = time.perf_counter()
    update = stack.update(document)
    engine = time.perf_counter()
    renderer.update(stack.composite, {key: field.changed for key, field in update.fields.items()})
    renderer.draw(view, fbo)
    GL.glFinish()
    return engine - start, time.perf_counter() - start


def main() -> None:
    from fmr_editor.engine import setup_process

    setup_process()  # the engine's thread and memory policy, as the editor's
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", default=str(DEFAULT_FILE))
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--frames", type=int, default=30)
    args = parser.parse_args()
    xvfb = start_xvfb()
    os.environ["QT_QPA_PLATFORM"] = "xcb"
    from PySide6.QtWidgets import QApplication

    from fmr_editor.engine import LiveStack, rasterise
    from fmr_editor.io import load_document

    app = QApplication([])
    flat_document = load_document(args.file)
    flat = LiveStack(flat_document).composite
    stack = LiveStack(layered(flat_document))
    fields = len(stack.fields)
    print(f"# Layers benchmark\n\n{Path(args.file).name} ({flat.width}x{flat.height}, {len(flat_document.curves)} "
          f"curves): flat = one layer; layers = its curves in 3 layers with a curve mask, a points mask, a hue "
          f"rotation and an opacity ({fields} fields). {os.cpu_count()} cores; best of {args.repeat} runs.\n")
    rasters = []
    for label, side in (("canvas size", None), (f"{args.size}x{args.size}", args.size)):
        rows = []
        for picture in (flat, stack.composite):
            runs = []
            for _ in range(args.repeat):
                start = time.perf_counter()
                rasterise(picture, side, side, samples=1)
                runs.append(time.perf_counter() - start)
            rows.append(best(runs))
        rasters.append((f"CPU raster, {label}, 1 sample (ms)", *rows))
    alpha = alpha_rows(args, flat_document)
    layer_rows, evaluations = gl_rows(args, flat, stack, fields, {name: alpha[name][3]
                                                                  for name in ("opaque", "translucent")})
    table = [*rasters, *layer_rows]
    print("| measure | flat | layers | ratio |\n|---|---:|---:|---:|")
    for name, one, many in table:
        ratio = f"{many / one:.2f}x" if one else ""
        print(f"| {name} | {'' if one is None else f'{one:.1f}'} | {many:.1f} | {ratio} |")
    print("\nAlpha: the flat document opaque, and with every right-hand stop at alpha 0.5 (an alpha field too)\n")
    print("| measure | opaque | translucent | ratio |\n|---|---:|---:|---:|")
    opaque, clear = alpha["opaque"], alpha["translucent"]
    (full, colour, _), (clear_full, clear_colour, clear_alpha) = evaluations["opaque"], evaluations["translucent"]
    for name, one, many in (("build (s)", opaque[0], clear[0]), ("CPU raster, canvas size, 1 sample (ms)", opaque[1],
                            clear[1]), ("CPU raster, the first after a build (ms)", opaque[4], clear[4]),
                            (f"canvas full evaluation, {args.size}x{args.size} (ms)", full, clear_full),
                            ("stop colour: engine update (ms)", opaque[2], clear[2]),
                            ("stop colour: edit to frame (ms)", colour, clear_colour)):
        print(f"| {name} | {one:.2f} | {many:.2f} | {many / one:.2f}x |")
    print(f"| stop alpha: edit to frame (ms) |  | {clear_alpha:.2f} |  |")
    app.quit()
    del xvfb


if __name__ == "__main__":
    main()
