"""Blur benchmark: the blur field's solve, the CPU raster and the canvas with blur beside without (issue 29).

    python bench/bench_blur.py [--repeat N] [--samples S] [--size W]

On the shared real files that carry blur (lady_bug, glass_droplet_blur, fruits from ../shared/data), opened
from their .xml, best of N:

- the blur field's solve (``LiveStack.set_blur``, the image's factorisation shared) beside the opening;
- ``engine.rasterise`` of the picture at the canvas size, sharp and blurred;
- the canvas (``render.PictureRenderer`` under Xvfb, llvmpipe) in a ``W x W`` window: a full evaluation
  fitted (scale W / canvas side) and zoomed 4x into the middle, sharp and blurred (the issue's bar: at most
  2x), a pan by 16 px (the blurred images move; the strips uncovered are blurred), and an edit to its frame
  on the blurred picture (a curve's colour; a curve's blur stop):
  ``LiveStack.update`` + ``PictureRenderer.update`` + draw + ``glFinish``.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "orzan_xml" / "berkbavas"
FILES = ("lady_bug", "glass_droplet_blur", "fruits")


def seconds(work, repeat: int) -> float:
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        work()
        runs.append(time.perf_counter() - start)
    return min(runs)


def cpu_rows(args) -> dict:
    from fmr_editor.engine import LiveStack, rasterise
    from fmr_editor.io import load_document

    print(f"# Blur\n\nBest of {args.repeat}; {args.samples} x {args.samples} samples a pixel for the raster.\n")
    print("| file | open (s) | blur field solve (s) | factorisations | largest blur (px) | raster sharp (ms) "
          "| raster blurred (ms) | ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    stacks = {}
    for name in FILES:
        document = load_document(DATA / f"{name}.xml")
        start = time.perf_counter()
        stack = LiveStack(document)
        opened = time.perf_counter() - start
        start = time.perf_counter()
        stack.set_blur(True)
        solve = time.perf_counter() - start
        field = stack.fields[document.layer.id, "blur"]
        largest = float(np.max(rasterise(field.representation, samples=1)))
        picture = stack.composite
        flat = seconds(lambda: rasterise(picture.sharp, samples=args.samples), args.repeat)
        soft = seconds(lambda: rasterise(picture, samples=args.samples), args.repeat)
        print(f"| {name} | {opened:.2f} | {solve:.2f} | {field.factorisations} | {largest:.1f} | {flat * 1e3:.0f} "
              f"| {soft * 1e3:.0f} | {soft / flat:.1f}x |")
        stacks[name] = stack
    return stacks


def canvas_rows(args, stacks: dict) -> None:
    from bench_canvas import start_xvfb
    from OpenGL import GL
    from PySide6.QtGui import QGuiApplication, QOffscreenSurface, QOpenGLContext, QSurfaceFormat

    from fmr_editor.model import BlurStop, ColorStop, edits
    from fmr_editor.render import PictureRenderer, View

    xvfb = start_xvfb()
    app = QGuiApplication([])
    surface_format = QSurfaceFormat()
    surface_format.setVersion(4, 1)
    surface_format.setProfile(QSurfaceFormat.OpenGLContextProfile.CoreProfile)
    context = QOpenGLContext()
    context.setFormat(surface_format)
    context.create()
    surface = QOffscreenSurface()
    surface.setFormat(surface_format)
    surface.create()
    context.makeCurrent(surface)

    def full(renderer, view) -> float:
        def work():
            renderer.invalidate()
            renderer.evaluate(view)
            GL.glFinish()
        return seconds(work, args.repeat)

    size = args.size
    print(f"\nThe canvas, {size} x {size} window pixels (llvmpipe), best of {args.repeat}:\n")
    print("| file | view | full sharp (ms) | full blurred (ms) | ratio | pan 16 px blurred (ms) | edit colour (ms) "
          "| edit blur stop (ms) |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for name, stack in stacks.items():
        document = stack.document
        scale = size / max(document.width, document.height)
        for label, zoom in (("fitted", 1.0), ("4x", 4.0)):
            s = scale * zoom
            view = View(s, size / 2 - document.width / 2 * s, size / 2 - document.height / 2 * s, size, size)
            flat, soft = PictureRenderer(), PictureRenderer()
            flat.upload(stack.composite.sharp)
            soft.upload(stack.composite)
            times = [full(flat, view), full(soft, view)]
            views = [view, view.panned(16, 0)]
            soft.evaluate(view)
            pans = []
            for run in range(args.repeat):
                start = time.perf_counter()
                soft.evaluate(views[(run + 1) % 2])
                GL.glFinish()
                pans.append(time.perf_counter() - start)
            soft.evaluate(view)
            curve = next(c for c in document.curves if c.blur and any(b.blur > 0 for b in c.blur))
            edited = []
            for change in ("colour", "blur"):
                runs = []
                for run in range(args.repeat):
                    if change == "colour":
                        grey = 0.3 + 0.2 * (run % 2)
                        new = replace(curve, left=(ColorStop(0.0, (grey, 0.4, 0.5)),))
                    else:
                        new = replace(curve, blur=(BlurStop(0.0, 1.0 + run % 2),))
                    start = time.perf_counter()
                    update = stack.update(edits.replace_curve(document, curve.id, new))
                    soft.update(stack.composite, {key: field.changed for key, field in update.fields.items()})
                    soft.evaluate(view)
                    GL.glFinish()
                    runs.append(time.perf_counter() - start)
                stack.update(document)
                soft.update(stack.composite, {})
                soft.evaluate(view)
                edited.append(min(runs))
            print(f"| {name} | {label} | {times[0] * 1e3:.0f} | {times[1] * 1e3:.0f} | {times[1] / times[0]:.1f}x "
                  f"| {min(pans) * 1e3:.0f} | {edited[0] * 1e3:.0f} | {edited[1] * 1e3:.0f} |")
            flat.release()
            soft.release()
    context.doneCurrent()
    del app
    if xvfb is not None:
        xvfb.terminate()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--samples", type=int, default=1)
    parser.add_argument("--size", type=int, default=1024)
    args = parser.parse_args()
    from fmr_editor.engine import setup_process

    setup_process()
    canvas_rows(args, cpu_rows(args))


if __name__ == "__main__":
    main()
