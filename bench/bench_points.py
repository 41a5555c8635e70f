"""Diffusion-point benchmark: polynomial build, 1024x1024 evaluation, one brush dab.

    python bench/bench_points.py [--repeat N] [--order P] [--tolerance T] [--levels L]

A 1024 px canvas on a ``2^L`` lattice (default 7: 8 px cells).  Points have
uniform centres, colours in [0, 1], amplitude 1 and radii log-uniform over
1.5-12 cells (12-96 px): all of them go into the polynomials, so evaluation is
the cell polynomial alone, whatever the number of points (the paper's
Figure 10).  Points below about 1.3 cells (order 8; 0.7 at order 12) would be
near points, evaluated exactly per sample: a last table shows what they cost.
Every time is the best of N runs (evaluations: of at least 10; the machine is
shared); numba's compile or cache load happens in a warm-up first.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_engine import best_of, machine  # noqa: E402

from fmr_editor.engine import setup_process  # noqa: E402
from fmr_editor.engine.fmm.lattice import Lattice  # noqa: E402
from fmr_editor.engine.points.gauss import GaussPoints, PointSettings, expansion_ratios  # noqa: E402
from fmr_editor.engine.points.increments import add_to_tensor  # noqa: E402
from fmr_editor.engine.points.near import evaluate_grid, near_points  # noqa: E402
from fmr_editor.engine.points.tensor import point_polynomials  # noqa: E402

SIDE = 1024.0
COUNTS = (10_000, 100_000, 1_000_000)


def points(rng: np.random.Generator, count: int, r_min: float, r_max: float) -> GaussPoints:
    return GaussPoints(rng.uniform(0, SIDE, (count, 2)),
                       np.exp(rng.uniform(math.log(r_min), math.log(r_max), count)),
                       rng.uniform(0, 1, (count, 3)))


def main() -> None:
    setup_process()  # the engine's thread and memory policy, as the editor's
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--order", type=int, default=PointSettings.order)
    parser.add_argument("--tolerance", type=float, default=PointSettings.tolerance)
    parser.add_argument("--levels", type=int, default=7)
    args = parser.parse_args()
    lattice = Lattice(args.levels, SIDE)
    settings = PointSettings(args.order, args.tolerance)
    cell = lattice.cell_size
    r_min, r_max = 1.5 * cell, 12 * cell
    rng = np.random.default_rng(0)
    xs = ys = np.arange(1024) + 0.5

    start = time.perf_counter()
    few = points(rng, 50, 0.5, 200.0)
    evaluate_grid(point_polynomials(few, lattice, settings), near_points(few, lattice, settings), xs[:64], ys[:64])
    add_to_tensor(point_polynomials(few, lattice, settings), few, lattice, settings)
    print(f"# Diffusion points\n\n{machine()}\n")
    print(f"Canvas {SIDE:.0f} px, {lattice.cells_per_side}^2 cells of {cell:g} px, order {settings.order}, "
          f"tolerance {settings.tolerance:g} a point; best of {args.repeat}; "
          f"warm-up {time.perf_counter() - start:.1f} s.\n")

    print(f"Radii {r_min:g}-{r_max:g} px (log-uniform), every point in the polynomials.\n")
    print("| points | build polynomials | evaluate 1024x1024 | per sample |")
    print("| ---: | ---: | ---: | ---: |")
    evaluations = []
    tensor_100k = None
    for count in COUNTS:
        batch = points(rng, count, r_min, r_max)
        assert (expansion_ratios(batch, lattice, settings) > 0).all()
        build, poly = best_of(args.repeat, lambda: point_polynomials(batch, lattice, settings))
        near = near_points(batch, lattice, settings)
        # evaluation is short and the machine noisy: more runs
        evaluate, _ = best_of(max(args.repeat, 10), lambda: evaluate_grid(poly, near, xs, ys))
        evaluations.append(evaluate)
        if count == 100_000:
            tensor_100k = poly
        print(f"| {count:,} | {build:.2f} s | {evaluate * 1e3:.0f} ms | {evaluate / xs.size / ys.size * 1e9:.0f} ns |")
    print(f"\nSlowest evaluation / fastest: {max(evaluations) / min(evaluations):.2f}\n")

    print("One dab into the 100,000-point tensor (radii 12-48 px), added then removed:\n")
    print("| points in the dab | add | remove |")
    print("| ---: | ---: | ---: |")
    for size in (1, 5, 20):
        dab = points(rng, size, 12.0, 48.0)
        dab = GaussPoints(dab.positions * 0.1 + 460, dab.radii, dab.weights)  # clustered like a brush
        add, _ = best_of(args.repeat, lambda: add_to_tensor(tensor_100k, dab, lattice, settings))
        remove, _ = best_of(args.repeat, lambda: add_to_tensor(tensor_100k, dab.negated(), lattice, settings))
        print(f"| {size} | {add * 1e3:.2f} ms | {remove * 1e3:.2f} ms |")

    print("\nFor comparison, radii 0.5-200 px (log-uniform): the points below about a cell are near points.\n")
    print("| points | near points | build (polynomials + near lists) | evaluate 1024x1024 |")
    print("| ---: | ---: | ---: | ---: |")
    for count in COUNTS[:2]:
        batch = points(rng, count, 0.5, 200.0)
        build, (poly, near) = best_of(args.repeat, lambda: (point_polynomials(batch, lattice, settings),
                                                            near_points(batch, lattice, settings)))
        evaluate, _ = best_of(args.repeat, lambda: evaluate_grid(poly, near, xs, ys))
        print(f"| {count:,} | {len(near):,} | {build:.2f} s | {evaluate * 1e3:.0f} ms |")


if __name__ == "__main__":
    main()
