"""Compile the engine's kernels into numba's cache before the first render needs them.

    python -m fmr_editor.engine.compile_kernels [--jobs N]

Numba compiles a kernel on its first call and keeps the machine code in its
cache (``__pycache__`` beside the source, or the user's cache directory where
that cannot be written), so every later process only loads it.  Compiling all
of them takes 2-4 minutes of one core (measured on a 2-core EPYC: the near
field on a grid 67 s, the sub-cell raster 53 s, the solver's and the passes'
kernels 80 s, the diffusion points' 35 s; the raster's kernels of four channels again), which a user would
otherwise wait
through in their first render, with no word about it.  ``scripts/setup.sh``
runs this once after installing.

The work is split into ``PARTS`` that touch disjoint kernels, run as parallel
processes (numba compiles on one core); a last pass drives the public API
through a render and every kind of edit, compiling what the parts left out and
loading the rest.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from collections.abc import Callable

import numpy as np

from ..model import ColorStop, DiffusionCurve, DiffusionPoint, Document, edits
from .fmm.lattice import Lattice
from .points.field import PointField, warm_up_points
from .raster import rasterise
from .raster_kernels import blending, four_channels, near_grid, sub_cells
from .stack import LiveStack


def solver() -> None:
    """A build and the kinds of edit a drawing takes (the solver, the passes, the edits' propagation).

    The drawing has more segments than ``solver.DENSE_CROSSOVER``: the compressed factorisation's kernels too.
    """
    document = sample_document(points=False, size=320)
    stack = LiveStack(document)
    curve = document.curves[0]
    moved = edits.move_control_point(document, curve.id, 1, tuple(curve.control_points[1] + 3.0))
    stack.update(moved, exact=False)
    stack.update(moved)
    recoloured = edits.set_stop_color(moved, curve.id, "left", 0, (0.2, 0.9, 0.4))
    stack.update(recoloured)


def points() -> None:
    """Diffusion points: their expansions, near field, raster and incremental edits (``points``)."""
    lattice = Lattice(3, 64.0)
    field = PointField.build(sample_document(points=True).points, lattice, 8)
    coordinates = np.linspace(0.5, 63.5, 64)
    field.add_grid(8, coordinates, coordinates, np.zeros((64, 64, 3)))
    warm_up_points(lattice, 8)


#: Parts that touch disjoint kernels, so that parallel processes never compile the same one twice.
PARTS: dict[str, Callable[[], None]] = {"near_grid": near_grid, "sub_cells": sub_cells,
                                        "four_channels": four_channels, "solver": solver, "points": points,
                                        "blending": blending}


def sample_document(points: bool, size: int = 64) -> Document:
    """A ``size`` square drawing of two closed curves and an open one, with two diffusion points if ``points``."""
    unit = size / 64

    def ring(cx: float, cy: float, r: float) -> np.ndarray:
        k = 0.5523 * r
        return unit * np.array([(cx + r, cy), (cx + r, cy + k), (cx + k, cy + r), (cx, cy + r), (cx - k, cy + r),
                                (cx - r, cy + k), (cx - r, cy), (cx - r, cy - k), (cx - k, cy - r), (cx, cy - r),
                                (cx + k, cy - r), (cx + r, cy - k), (cx + r, cy)])

    curves = (
        DiffusionCurve(ring(22.0, 24.0, 12.0), left=(ColorStop(0.0, (1, 0, 0)), ColorStop(4.0, (1, 1, 0))),
                       right=(ColorStop(0.0, (0, 0, 1)),)),
        DiffusionCurve(ring(44.0, 40.0, 9.0), left=(ColorStop(0.0, (0, 1, 0)),), right=(ColorStop(0.0, (1, 1, 1)),)),
        DiffusionCurve(unit * np.array([(5.0, 58.0), (20.0, 50.0), (40.0, 62.0), (60.0, 52.0)]),
                       left=(ColorStop(0.0, (0.5, 0.2, 0.1)),), right=(ColorStop(0.0, (0.1, 0.6, 0.9)),)),
    )
    dots = (DiffusionPoint((12.0 * unit, 50.0 * unit), 4.0 * unit, (1, 0.5, 0)),
            DiffusionPoint((50.0 * unit, 14.0 * unit), 20.0 * unit, (0, 0.3, 1)))  # near and polynomial
    return Document(size, size, curves, dots if points else ())


def everything() -> None:
    """The public API end to end: a build, renders at one and three samples a pixel, and edits."""
    document = sample_document(points=True)
    stack = LiveStack(document)
    rasterise(stack.composite, samples=1)
    rasterise(stack.composite, samples=3)
    rasterise(stack.composite, 512, 512, samples=3)
    curve = document.curves[1]
    moved = edits.move_control_point(document, curve.id, 1, tuple(curve.control_points[1] + 2.0))
    stack.update(moved, exact=False)
    stack.update(moved)
    stack.warm_up()
    rasterise(stack.composite, samples=1)


def compile_all(jobs: int, say: Callable[[str], None] = print) -> None:
    """Run the ``PARTS`` in up to ``jobs`` processes at once, then ``everything`` here, saying how far it got."""
    start = time.perf_counter()
    waiting = list(PARTS)
    running: dict[str, subprocess.Popen] = {}
    done = 0
    while waiting or running:
        while waiting and len(running) < jobs:
            name = waiting.pop(0)
            running[name] = subprocess.Popen([sys.executable, "-m", f"{__package__}.compile_kernels", "--part", name])
        time.sleep(0.2)
        for name, process in list(running.items()):
            if process.poll() is None:
                continue
            del running[name]
            if process.returncode:
                raise RuntimeError(f"compiling the kernels of {name} failed (exit code {process.returncode})")
            done += 1
            say(f"compiled {done} of {len(PARTS) + 1} parts ({name}, {time.perf_counter() - start:.0f} s)")
    everything()
    say(f"compiled {len(PARTS) + 1} of {len(PARTS) + 1} parts (the rest, {time.perf_counter() - start:.0f} s)")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m fmr_editor.engine.compile_kernels", description=__doc__.split(
        "\n\n")[0])
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="processes at once (default: cores)")
    parser.add_argument("--part", choices=sorted(PARTS), help=argparse.SUPPRESS)
    arguments = parser.parse_args(argv)
    if arguments.part:
        PARTS[arguments.part]()
        return
    compile_all(max(1, arguments.jobs), lambda line: print(f"compile: {line}", flush=True))


if __name__ == "__main__":
    main()
