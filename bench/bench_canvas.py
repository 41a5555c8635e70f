"""Canvas benchmark: the shader-rendered view of a document under Xvfb (Mesa llvmpipe).

    python bench/bench_canvas.py [FILE] [--size S] [--repeat N] [--frames F] [--points K]

Shows FILE (default: lady_bug.xml from ../shared/data) in a ``S x S`` canvas
widget (default 1024) fitted exactly (scale = S / canvas side) and measures:

- **redraw**: frames per second of ``Canvas.repaint()`` (paintGL, which copies
  the cached image, plus Qt's composition into the window) with nothing
  changed, and of the renderer's copy alone; F frames, best of N runs;
- **full evaluation**: the shader over every window pixel (what a zoom or a
  resize costs), best of N; and a zoom step's preview (the cached image
  scaled, what the canvas shows while zoom steps follow each other);
- **pan**: moving the view by 10 and by 100 window pixels (the cached image
  moves, only the uncovered strips are evaluated), best of N;
- **edit to frame**: a stop-colour change on a few curves, from the edit to
  the finished frame: ``LiveRepresentation.update`` + ``CanvasRenderer.update``
  (partial upload; adds the change to the cells that moved visibly) + draw
  (evaluates what is left) + ``glFinish``; each step timed, best of N (each
  run flips the colour back and forth so every run is a real change);
- with K random diffusion points added (default 2,000; the far field then
  takes the tensor form, and narrow points are exact near points): the full
  evaluation and a brush dab of 5 points, edit to frame.

Every GL timing ends with ``glFinish``.  Starts its own Xvfb (else uses
DISPLAY).  The machine is shared and noisy: best-of figures are the ones to quote.
"""

from __future__ import annotations

import argparse
import os
import select
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DEFAULT_FILE = REPO.parent / "shared" / "data" / "orzan_xml" / "berkbavas" / "lady_bug.xml"
#: Curves whose first left stop is recoloured (lady_bug: a small one, a middling one, the background).
CURVES = (30, 5, 0)


def start_xvfb() -> subprocess.Popen | None:
    """Start Xvfb on a free display and point DISPLAY at it; without Xvfb, use DISPLAY as it is (None)."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        if not os.environ.get("DISPLAY"):
            sys.exit("bench_canvas: needs Xvfb (or a DISPLAY) for OpenGL")
        return None
    read_end, write_end = os.pipe()
    process = subprocess.Popen([xvfb, "-displayfd", str(write_end), "-screen", "0", "1280x1280x24", "-nolisten", "tcp",
                                "-terminate"],  # ends when this process's connection closes
                               pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_end)
    number = b""
    deadline = time.monotonic() + 10.0
    while not number.endswith(b"\n") and select.select([read_end], [], [], max(deadline - time.monotonic(), 0))[0]:
        chunk = os.read(read_end, 16)  # read to the newline: closing the pipe early kills Xvfb (SIGPIPE)
        if not chunk:
            break
        number += chunk
    os.close(read_end)
    number = number.strip()
    if not number.isdigit():
        process.kill()
        sys.exit("bench_canvas: Xvfb did not start")
    os.environ["DISPLAY"] = f":{int(number)}"
    return process


def best(times: list[float]) -> float:
    return min(times) * 1e3


def full_evaluations(renderer, view, fbo, repeat: int) -> list[float]:
    """Seconds of ``repeat`` draws that each evaluate the whole view (the cached image dropped first)."""
    from OpenGL import GL

    runs = []
    for _ in range(repeat):
        renderer.invalidate()
        start = time.perf_counter()
        renderer.draw(view, fbo)
        GL.glFinish()
        runs.append(time.perf_counter() - start)
    return runs


def redraws(renderer, view, fbo, repeat: int, frames: int) -> list[float]:
    """Seconds a draw of ``frames`` draws with nothing changed takes (the cached image copied), ``repeat`` times."""
    from OpenGL import GL

    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(frames):
            renderer.draw(view, fbo)
        GL.glFinish()
        runs.append((time.perf_counter() - start) / frames)
    return runs


def points_rows(args, canvas, document, view, fbo) -> None:
    """The same view with diffusion points added (tensor far field, near points): full evaluation and a dab."""
    from OpenGL import GL

    from fmr_editor.engine import LiveRepresentation
    from fmr_editor.model import DiffusionPoint, edits

    rng = np.random.default_rng(1)
    side = max(document.width, document.height)

    def random_points(count: int) -> list:
        radii = np.exp(rng.uniform(np.log(1.0), np.log(60.0), count))
        return [DiffusionPoint(tuple(rng.uniform(0, side, 2)), float(r), tuple(rng.random(3)), 0.3) for r in radii]

    live = LiveRepresentation(document.with_points(random_points(args.points)))
    rep = live.representation
    canvas.makeCurrent()
    renderer = canvas.renderer
    renderer.upload(rep)
    renderer.draw(view, fbo)
    GL.glFinish()
    runs = full_evaluations(renderer, view, fbo, args.repeat)
    dabs = []
    for _ in range(args.repeat):
        start = time.perf_counter()
        update = live.update(edits.add_points(live.document, random_points(5)))
        engine = time.perf_counter()
        renderer.update(live.representation, update.changed)
        renderer.draw(view, fbo)
        GL.glFinish()
        dabs.append((engine - start, time.perf_counter() - engine, time.perf_counter() - start))
    near = len(rep.points.near)
    dab = np.array(dabs).min(axis=0) * 1e3
    print(f"\nWith {args.points:,} diffusion points added (radii 1-60 px, log-uniform; {near:,} of them near points, "
          f"summed exactly; the far field in tensor form):\n")
    print("| step | ms |\n|---|---:|")
    print(f"| full evaluation ({view.width}x{view.height}) | {best(runs):.1f} |")
    print(f"| a dab of 5 points: engine update | {dab[0]:.1f} |")
    print(f"| a dab of 5 points: renderer update + draw | {dab[1]:.1f} |")
    print(f"| a dab of 5 points: edit to frame | {dab[2]:.1f} |")


def main() -> None:
    from fmr_editor.engine import setup_process

    setup_process()  # the engine's thread and memory policy, as the editor's
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", default=str(DEFAULT_FILE))
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--points", type=int, default=2000,
                        help="also time the view with this many random diffusion points (0: skip)")
    args = parser.parse_args()

    xvfb = start_xvfb()
    os.environ["QT_QPA_PLATFORM"] = "xcb"
    from OpenGL import GL
    from PySide6.QtTest import QTest
    from PySide6.QtWidgets import QApplication

    from fmr_editor.engine import LiveRepresentation
    from fmr_editor.io import load_document
    from fmr_editor.model import edits
    from fmr_editor.render import View
    from fmr_editor.ui.canvas import Canvas

    app = QApplication([])
    document = load_document(args.file)
    live = LiveRepresentation(document)
    rep = live.representation
    size = args.size
    scale = size / max(rep.width, rep.height)
    view = View(scale, 0.0, 0.0, size, size)
    canvas = Canvas()
    canvas.resize(size, size)
    canvas.show()
    QTest.qWaitForWindowExposed(canvas)
    canvas.set_representation(rep, fit=False)
    canvas.set_view(view)
    canvas.repaint()
    renderer = canvas.renderer
    if renderer is None:
        sys.exit(f"bench_canvas: no OpenGL canvas: {canvas.error}")
    canvas.makeCurrent()
    info = f"{GL.glGetString(GL.GL_RENDERER).decode()}, OpenGL {GL.glGetString(GL.GL_VERSION).decode()}"
    lattice = rep.lattice
    print(f"# Canvas benchmark\n\n{Path(args.file).name}: {rep.width}x{rep.height}, {len(rep.segments.p):,} segments, "
          f"{lattice.cells_per_side}^2 cells of {lattice.cell_size:g} px, order {rep.order}, "
          f"{'harmonic' if rep.points is None else 'tensor'} far field; view {size}x{size} at scale {scale:g}.\n"
          f"{info}; {os.cpu_count()} cores. Best of {args.repeat} runs.\n")
    fbo = canvas.defaultFramebufferObject()

    def finish() -> None:
        canvas.makeCurrent()
        GL.glFinish()

    rows = []
    # redraw: nothing changed, the cached image is copied; a frame ends when Qt has shown it (frameSwapped)
    swaps = []
    canvas.frameSwapped.connect(lambda: swaps.append(time.perf_counter()))
    runs = []
    for _ in range(args.repeat):
        start = time.perf_counter()
        for _ in range(args.frames):
            count = len(swaps)
            canvas.update()
            while len(swaps) == count:
                app.processEvents()
        finish()
        runs.append((time.perf_counter() - start) / args.frames)
    rows.append(("redraw (Canvas.update to frameSwapped: copy of the cached image + Qt composition)",
                 best(runs), 1e3 / best(runs)))
    assert renderer.last_evaluation == "none"
    canvas.makeCurrent()
    runs = redraws(renderer, view, fbo, args.repeat, args.frames)
    rows.append(("redraw (CanvasRenderer.draw alone)", best(runs), 1e3 / best(runs)))

    runs = full_evaluations(renderer, view, fbo, args.repeat)
    rows.append((f"full evaluation ({size}x{size} pixels: zoom, resize)", best(runs), 1e3 / best(runs)))
    runs = []
    for i in range(args.repeat):
        start = time.perf_counter()
        renderer.draw(view.zoomed(1.25 ** (i + 1), size / 2, size / 2), fbo, preview=True)
        GL.glFinish()
        runs.append(time.perf_counter() - start)
        assert renderer.last_evaluation == "preview"
    rows.append(("zoom step while zooming (the cached image scaled)", best(runs), 1e3 / best(runs)))
    for step in (10, 100):
        runs = []
        for i in range(args.repeat):
            moved = view.panned(step if i % 2 == 0 else 0, 0)
            renderer.draw(view.panned(0 if i % 2 == 0 else step, 0), fbo)
            GL.glFinish()
            start = time.perf_counter()
            renderer.draw(moved, fbo)
            GL.glFinish()
            runs.append(time.perf_counter() - start)
            assert renderer.last_evaluation == "shift"
        rows.append((f"pan by {step} px (move the cached image, evaluate the strip)", best(runs), 1e3 / best(runs)))
    renderer.draw(view, fbo)
    GL.glFinish()

    print("| step | ms | fps |\n|---|---:|---:|")
    for name, ms, fps in rows:
        print(f"| {name} | {ms:.1f} | {fps:.0f} |")

    print("\nEdit to frame: recolour the first left stop of one curve (flipped back and forth).\n")
    print("| curve | cells reported changed | cells given their change (segments) | cells evaluated in full "
          "| engine update ms | renderer update ms | draw ms | edit to frame ms |\n"
          "|---:|---:|---:|---:|---:|---:|---:|---:|")
    for curve in CURVES:
        if curve >= len(live.document.curves):
            continue
        timings, reported, evaluated = [], 0, 0
        for _ in range(args.repeat):
            old = live.document.curves[curve].left[0].color
            changed = edits.set_stop_color(live.document, live.document.curves[curve].id, "left", 0,
                                           tuple(1 - np.asarray(old)))
            start = time.perf_counter()
            update = live.update(changed)
            engine = time.perf_counter()
            canvas.makeCurrent()
            renderer.update(live.representation, update.changed)
            uploaded = time.perf_counter()
            renderer.draw(view, fbo)
            GL.glFinish()
            done = time.perf_counter()
            timings.append((engine - start, uploaded - engine, done - uploaded, done - start))
            counts = renderer.last_update
            reported, evaluated = counts["changed"], (counts["delta"], counts["segments"], counts["evaluate"])
        t = np.array(timings).min(axis=0) * 1e3
        delta, segments, full = evaluated
        print(f"| {curve} | {reported:,} | {delta:,} ({segments:,}) | {full:,} ({renderer.last_evaluation}) "
              f"| {t[0]:.0f} | {t[1]:.1f} | {t[2]:.1f} | {np.array(timings)[:, 3].min() * 1e3:.0f} |")
    if args.points:
        points_rows(args, canvas, live.document, view, fbo)
    canvas.close()
    app.quit()
    del xvfb  # it ends itself (-terminate) when Qt's connection closes at exit


if __name__ == "__main__":
    main()
