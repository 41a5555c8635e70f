"""The FMR paper's Tables 1 and 2, every cell, side by side with ours, on the Hilbert benchmark DCIs.

    python bench/bench_paper.py [--repeat N] [--cells ITERATION:LEVEL ...] [--error-pixels K] [--size S] [--order N]

Table 1 of Sun, Thamjaroenporn and Zheng (SIGGRAPH 2014) times the upward pass
(P2M, M2M) and the downward pass (M2L, L2L) on Hilbert DCIs of 2,048 to
524,288 segments at lattice levels 5 to 9; Table 2 the 1024 x 1024 raster at
one sample a pixel, at levels 5 to 10 (``../shared/paper_tables.md``: their
figures, quad-core C++).  Every cell the paper fills is measured here, at the
paper's level (``Settings(levels=L)``), each in a process of its own so that
its peak memory is its own.

Our side skips the boundary solve (the passes' and the raster's cost does
not depend on the values): the segments are made as a build makes them
(flatten, clip, cut at the cells, canvas border), then given a seeded
synthetic normal-derivative jump ``E`` (standard normal per curve segment,
none on the border; border colours uniform in [0, 1]).  ``upward`` and
``downward`` are the two stages of ``Cells.build`` (what a build runs, timed
by its own laps, for pixels of degree ``--order``: the editor's default, 8;
the paper's N = 4 misses 1/255 on these scenes by up to 5.6 levels), the
raster is ``rasterise(rep, S, S, samples=1)``.  The
error is the largest difference from the direct boundary integral
(``method="direct"``) at ``K`` random points (``evaluate_points``) and at the
centres of ``K`` random pixels of the raster, in 8-bit levels; ``load`` the
one-minute load average when the cell finished.  Two more tables say where
the time goes: the passes' parts (P2M, M2M, the fine level's M2L and L2L,
the coarser levels'; Table 1's cells) and the raster's far field alone.

Markdown on stdout, progress on stderr.  Every time is the best of N runs
(default 5) on a shared, noisy 2-core machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_engine import log, machine, warm_up  # noqa: E402
from hilbert import PAPER_ITERATIONS, hilbert_document, hilbert_settings  # noqa: E402

#: The paper's Table 1, ``(pieces, level): (upward ms, downward ms)``, and Table 2, ``(pieces, level): raster ms``.
TABLE_1 = {
    (2048, 5): (2.6, 3.2), (2048, 6): (3.6, 10), (2048, 7): (7.6, 21), (2048, 8): (22, 86), (2048, 9): (92, 318),
    (8192, 6): (4.5, 7.6), (8192, 7): (8.5, 23), (8192, 8): (27, 87), (8192, 9): (96, 310),
    (32768, 7): (12, 24), (32768, 8): (35, 85), (32768, 9): (106, 315),
    (131072, 8): (59, 81), (131072, 9): (126, 318),
    (524288, 9): (187, 324),
}
TABLE_2 = {
    (2048, 5): 51, (2048, 6): 68.3, (2048, 7): 39.4, (2048, 8): 31.1, (2048, 9): 23.9, (2048, 10): 19.8,
    (8192, 6): 57, (8192, 7): 68.1, (8192, 8): 38.2, (8192, 9): 29.8, (8192, 10): 23.1,
    (32768, 7): 171, (32768, 8): 68.8, (32768, 9): 39.8, (32768, 10): 32.2,
    (131072, 8): 176, (131072, 9): 72.0, (131072, 10): 39.2,
    (524288, 9): 180, (524288, 10): 72.5,
}
LEVELS = (5, 6, 7, 8, 9, 10)


def pieces_of(iteration: int) -> int:
    return 2 * 4**iteration


def paper_cells() -> list[tuple[int, int]]:
    """Every ``(iteration, level)`` either table fills, in row order."""
    cells = {(i, level) for i in PAPER_ITERATIONS for level in LEVELS
             if (pieces_of(i), level) in TABLE_1 or (pieces_of(i), level) in TABLE_2}
    return sorted(cells)


def synthetic_values(segments, seed: int):
    """``segments`` with a seeded random ``E`` on curve segments and random border colours."""
    rng = np.random.default_rng(seed)
    n = len(segments)
    flux = np.where(segments.on_border[:, None], 0.0, rng.standard_normal((n, 3)))
    jump = np.where(segments.on_border[:, None], rng.uniform(0.0, 1.0, (n, 3)), segments.jump)
    return dataclasses.replace(segments, flux=flux, jump=jump)


def pass_parts(segments, lattice, propagation_order: int, pixel_order: int, repeat: int) -> dict[str, float]:
    """Best-of-``repeat`` seconds of the passes' parts, run as ``Cells.build`` runs them: P2M, M2M, the fine
    level's M2L and L2L (``fine``) and the coarser levels' (``coarse``)."""
    from fmr_editor.engine.fmm import passes
    from fmr_editor.engine.fmm.lattice import sort_into_cells
    from fmr_editor.engine.fmm.orders import pass_orders

    segments, cell_start = sort_into_cells(segments, lattice)
    orders = pass_orders(lattice.levels, min(pixel_order, propagation_order), propagation_order)
    best: dict[str, float] = {}
    for _ in range(repeat):
        laps = [("start", time.perf_counter())]

        def lap(stage: str) -> None:
            laps.append((stage, time.perf_counter()))

        fine, sources = passes.upward(segments, cell_start, lattice, orders, lap)
        lap("M2M")
        del fine
        passes.downward(sources, lattice, orders, min(pixel_order, propagation_order) + 1, lap,
                        parallel_from=passes.BUILD_PARALLEL_CELLS)  # as build_passes
        parts = {"coarse": 0.0}
        for (_, before), (stage, after) in zip(laps, laps[1:]):
            name = "fine" if stage == f"L{lattice.levels}" else "coarse" if stage.startswith("L") else stage
            parts[name] = parts.get(name, 0.0) + after - before
        best = {name: min(seconds, best.get(name, seconds)) for name, seconds in parts.items()}
    return best


def measure(iteration: int, level: int, args: argparse.Namespace) -> dict:
    """Times, sizes, error and peak memory of one cell (run in a process of its own)."""
    from fmr_editor.engine import Representation, rasterise
    from fmr_editor.engine.cells import Cells
    from fmr_editor.engine.fmm.lattice import Lattice
    from fmr_editor.engine.fmm.orders import sample_degrees
    from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments
    from fmr_editor.engine.kernels.local_grid import local_field_grid
    from fmr_editor.engine.raster import sample_coordinates

    warm_up()
    settings = hilbert_settings(args.size, levels=level, order=args.order)
    document = hilbert_document(iteration, args.size)
    lattice = Lattice(level, float(args.size))
    curves = curve_segments(document, settings.tolerance, settings.max_length)
    segments = synthetic_values(boundary_segments(curves, document, lattice.cell_size, settings.border_spacing),
                                args.seed)
    del curves  # only the cut segments are built from
    # first, so that its arrays are gone before the builds' (the peak memory is theirs)
    parts = (pass_parts(segments, lattice, settings.propagation_order, settings.order, args.repeat)
             if (pieces_of(iteration), level) in TABLE_1 else None)
    passes, rasters, cells = [], [], None
    for _ in range(args.repeat):
        cells = None  # free the last run's expansions before the next is made
        laps = [time.perf_counter()]
        cells = Cells.build(segments, lattice, settings.propagation_order,
                            lambda stage: laps.append(time.perf_counter()), pixel_order=settings.order)
        passes.append(np.diff(laps))
    rep = Representation(args.size, args.size, lattice, cells.segments, cells.cell_start, cells.local, settings.order,
                         centres=cells.centres)
    far = []  # the far field alone, every cell's samples (the raster skips those its sub-cells redo)
    samples = sample_coordinates(args.raster, args.size, 1)
    for _ in range(args.repeat):
        start = time.perf_counter()
        image = rasterise(rep, args.raster, args.raster, samples=1)
        rasters.append(time.perf_counter() - start)
        start = time.perf_counter()
        local_field_grid(rep.local, rep.order, samples, samples, lattice.cell_size, out=np.empty_like(image),
                         degrees=sample_degrees(rep.order), centres=rep.centres)
        far.append(time.perf_counter() - start)
    rng = np.random.default_rng(args.seed)
    pixels = rng.uniform(0, args.size, (args.error_pixels, 2))
    from fmr_editor.engine import evaluate_points
    from fmr_editor.engine.kernels.segment_sums import direct_sum

    seg = rep.segments
    error = np.abs(evaluate_points(rep, pixels) - direct_sum(pixels, seg.p, seg.q, seg.flux, seg.jump)).max() * 255
    # the raster's own pixels (its near field may run in float32): centres of K random pixels
    picked = rng.integers(0, args.raster, (args.error_pixels, 2))
    centres = (picked + 0.5) * (args.size / args.raster)
    raster_error = np.abs(image[picked[:, 1], picked[:, 0]]
                          - direct_sum(centres, seg.p, seg.q, seg.flux, seg.jump)).max() * 255
    best = np.min(passes, axis=0)
    return {"iteration": iteration, "level": level, "pieces": pieces_of(iteration), "segments": len(segments),
            "occupied": int(np.count_nonzero(np.diff(cells.cell_start))), "upward": float(best[0]),
            "downward": float(best[1]), "raster": min(rasters), "far": min(far), "error": float(error),
            "raster_error": float(raster_error), "parts": parts, "load": os.getloadavg()[0],
            "orders": f"{settings.propagation_order}/{settings.order}",
            "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _cell(ours: float, paper: float | None) -> str:
    """'ours (paper, ratio)' in ms."""
    if paper is None:
        return f"{1e3 * ours:.1f}"
    return f"{1e3 * ours:.1f} ({paper:g}, **{1e3 * ours / paper:.2f}**)"


def _table(rows: dict, title: str, value, paper: dict, levels) -> None:
    print(f"### {title}\n")
    print("| curves | " + " | ".join(f"L{level}" for level in levels) + " |")
    print("|---:|" + "---:|" * len(levels))
    for i in PAPER_ITERATIONS:
        cells = []
        for level in levels:
            row, figure = rows.get((i, level)), paper.get((pieces_of(i), level))
            cells.append(_cell(value(row), figure) if row is not None and figure is not None else "")
        print(f"| {pieces_of(i):,} | " + " | ".join(cells) + " |")
    print()


def main(argv: list[str] | None = None) -> None:
    from fmr_editor.engine import setup_process

    setup_process()  # the engine's thread and memory policy, as the editor's
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per measurement; the best is reported")
    parser.add_argument("--cells", nargs="*", help="ITERATION:LEVEL pairs to measure (default: every paper cell)")
    parser.add_argument("--size", type=int, default=1024, help="canvas side of the Hilbert documents")
    parser.add_argument("--raster", type=int, default=1024, help="raster side (one sample per pixel)")
    parser.add_argument("--error-pixels", type=int, default=256, help="random pixels checked against the direct sum")
    parser.add_argument("--seed", type=int, default=0, help="seed of the synthetic E and the checked pixels")
    parser.add_argument("--order", type=int, default=8, help="degree N of the pixels' polynomials (the editor's)")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # ITERATION:LEVEL, measured in this process (as JSON)
    args = parser.parse_args(argv)
    if args.one:
        iteration, level = map(int, args.one.split(":"))
        print(json.dumps(measure(iteration, level, args)))
        return
    cells = [tuple(map(int, cell.split(":"))) for cell in args.cells] if args.cells else paper_cells()
    rows = {}
    for iteration, level in cells:
        log(f"{pieces_of(iteration):,} pieces at L{level}")
        command = [sys.executable, __file__, "--one", f"{iteration}:{level}", "--repeat", str(args.repeat),
                   "--size", str(args.size), "--raster", str(args.raster), "--error-pixels", str(args.error_pixels),
                   "--seed", str(args.seed), "--order", str(args.order)]
        done = subprocess.run(command, capture_output=True, text=True, env=os.environ)
        if done.returncode != 0:
            log(done.stderr[-2000:])
            continue
        rows[iteration, level] = row = json.loads(done.stdout.strip().splitlines()[-1])
        log(f"  upward {1e3 * row['upward']:.1f} ms, downward {1e3 * row['downward']:.1f} ms, raster "
            f"{1e3 * row['raster']:.1f} ms, error {row['error']:.3f}/255 (raster {row['raster_error']:.3f}), "
            f"peak {row['rss']:.0f} MB, load {row['load']:.2f}")

    print(f"## The FMR paper's Tables 1 and 2 on the Hilbert DCIs, best of {args.repeat}\n")
    print(f"Machine: {machine()}. Each cell: ours in ms (the paper's quad-core C++ figure, **ours/paper**).\n")
    _table(rows, "Table 1: upward pass (P2M, M2M)", lambda r: r["upward"], {k: v[0] for k, v in TABLE_1.items()},
           LEVELS[:-1])
    _table(rows, "Table 1: downward pass (M2L, L2L)", lambda r: r["downward"], {k: v[1] for k, v in TABLE_1.items()},
           LEVELS[:-1])
    _table(rows, f"Table 2: {args.raster} x {args.raster} raster, 1 sample a pixel", lambda r: r["raster"], TABLE_2,
           LEVELS)
    print("Where the passes' time goes (best of each part apart, ms): upward = P2M + M2M, downward = the fine "
          "level's M2L and L2L + the coarser levels'.\n")
    print("| curves | L | P2M | M2M | fine M2L + L2L | coarser levels |")
    print("|---:|---:|---:|---:|---:|---:|")
    for (i, level), r in sorted(rows.items()):
        if r["parts"] is None:
            continue
        p = r["parts"]
        print(f"| {r['pieces']:,} | {level} | {1e3 * p['P2M']:.1f} | {1e3 * p['M2M']:.1f} | {1e3 * p['fine']:.1f} | "
              f"{1e3 * p['coarse']:.1f} |")
    print()
    print("The raster's far field alone (every cell's local expansion at every pixel, best of its own; the rest of "
          "the raster is the near field and the sub-cells):\n")
    print("| curves | L | raster ms | far field ms |")
    print("|---:|---:|---:|---:|")
    for (i, level), r in sorted(rows.items()):
        print(f"| {r['pieces']:,} | {level} | {1e3 * r['raster']:.1f} | {1e3 * r['far']:.1f} |")
    print()
    print("| curves | L | segments after cutting | occupied cells | orders (propagation/pixels) | "
          f"max error vs direct sum ({args.error_pixels} points, /255) | raster's ({args.error_pixels} pixels) | "
          "peak RSS MB | load |")
    print("|---:|---:|---:|---:|---|---:|---:|---:|---:|")
    for (i, level), r in sorted(rows.items()):
        print(f"| {r['pieces']:,} | {level} | {r['segments']:,} | {r['occupied']:,} | {r['orders']} | "
              f"{r['error']:.3f} | {r['raster_error']:.3f} | {r['rss']:.0f} | {r['load']:.2f} |")


if __name__ == "__main__":
    main()
