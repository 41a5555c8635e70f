"""Boundary-solve benchmark: every Orzan sample built and rendered, and the dense/fast crossover.

    python bench/bench_solve.py [FILES...] [--repeat N] [--samples K] [--dense-max N] [--crossover | --crossover-only]

For each file, in a fresh process (so its peak memory is its own): load,
build (discretise, solve, upward, downward), render at its canvas size with
K x K samples a pixel (1 by default, as issue 15 measures); the best of N
builds (N = 1 above 20,000 segments: say so), the solver used, the GMRES
iterations of the build's solve, the peak resident memory, and, where the dense
solve fits (``--dense-max`` segments), the largest relative difference of the
solved E and C from the dense solve's.  ``--crossover`` times the dense and
the fast solve side by side on synthetic documents of growing size.  A second
table splits each fast solve into the factorisation (the preconditioner's
construction) and the rest (GMRES with its right-hand side), best of N each.

Markdown on stdout, progress on stderr.
"""

from __future__ import annotations

import argparse
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

import fmr_editor  # noqa: E402
from fmr_editor.engine import build, rasterise, setup_process  # noqa: E402
from fmr_editor.engine.fmm.lattice import Lattice, sort_into_cells  # noqa: E402
from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments  # noqa: E402
from fmr_editor.engine.representation import SOLVE_SEGMENTS_PER_CELL, choose_levels  # noqa: E402
from fmr_editor.engine.solve import solver as fast_solve  # noqa: E402
from fmr_editor.engine.solve.dense import solve_dense  # noqa: E402
from fmr_editor.engine.solve.skeleton import SkeletonFactorization  # noqa: E402

ORZAN = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "orzan_xml"
STAGES = ("discretise", "solve", "upward", "downward")
SINGLE_RUN_ABOVE = 20_000


def counted_gmres(*args, **kwargs):
    """``solver.gmres``, keeping its iteration count in ``counted_gmres.iterations``."""
    unknown, report = _GMRES(*args, **kwargs)
    counted_gmres.iterations.append(report.iterations)
    return unknown, report


counted_gmres.iterations = []
_GMRES = fast_solve.gmres


class TimedFactorization(SkeletonFactorization):
    """The preconditioner, recording how long each construction took (``seconds``)."""

    seconds: list[float] = []

    def __init__(self, *args, **kwargs) -> None:
        start = time.perf_counter()
        super().__init__(*args, **kwargs)
        TimedFactorization.seconds.append(time.perf_counter() - start)


def boundary_system(document):
    """Segments and the solve lattice, as ``build`` makes them."""
    side = float(max(document.width, document.height))
    curves = curve_segments(document)
    segments = boundary_segments(curves, document, Lattice(choose_levels(curves, side), side).cell_size)
    return segments, Lattice(choose_levels(curves, side, SOLVE_SEGMENTS_PER_CELL), side)


def fast_and_dense(segments, lattice):
    """Seconds and unknowns of both solves on one system (fast first)."""
    ordered, cell_start = sort_into_cells(segments, lattice)
    start = time.perf_counter()
    fast, report = fast_solve.solve_fmm(ordered, cell_start, lattice)
    fast_time = time.perf_counter() - start
    start = time.perf_counter()
    dense = solve_dense(ordered)
    return fast_time, time.perf_counter() - start, fast.unknowns(), dense.unknowns(), report


def one_file(path: Path, repeat: int, dense_max: int, samples: int = 1) -> dict:
    """Measure one file in this process; a JSON-able dict."""
    warm_up()
    runs = 1 if len(boundary_system(fmr_editor.load(path))[0]) > SINGLE_RUN_ABOVE else repeat
    best = dict.fromkeys(("load", *STAGES, "factor", "gmres", "render"), float("inf"))
    fast_solve.SkeletonFactorization = TimedFactorization  # what solve_fmm constructs
    fast_solve.gmres = counted_gmres  # what BoundarySolver.solve calls
    for _ in range(runs):
        start = time.perf_counter()
        document = fmr_editor.load(path)
        best["load"] = min(best["load"], time.perf_counter() - start)
        TimedFactorization.seconds.clear()
        counted_gmres.iterations.clear()
        rep = build(document)
        for stage in STAGES:
            best[stage] = min(best[stage], rep.timings[stage])
        if TimedFactorization.seconds:
            best["factor"] = min(best["factor"], TimedFactorization.seconds[0])
            best["gmres"] = min(best["gmres"], rep.timings["solve"] - TimedFactorization.seconds[0])
        start = time.perf_counter()
        image = rasterise(rep, document.width, document.height, samples=samples)
        best["render"] = min(best["render"], time.perf_counter() - start)
    result = {"segments": len(rep.segments), "runs": runs, "size": f"{document.width}x{document.height}",
              "finite": bool(np.isfinite(image).all()), **best, "samples": samples,
              "build_iterations": counted_gmres.iterations[0] if counted_gmres.iterations else None,
              "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}  # before the dense check
    if len(rep.segments) <= dense_max and len(rep.segments) > fast_solve.DENSE_CROSSOVER:
        segments, lattice = boundary_system(document)
        _, _, fast, dense, report = fast_and_dense(segments, lattice)
        result["difference"] = float(np.abs(fast - dense).max() / np.abs(dense).max())
        result["iterations"] = report.iterations
    return result


def file_table(files: list[Path], repeat: int, dense_max: int, samples: int = 1) -> tuple[list[str], list[str]]:
    """One row per file, each measured in a subprocess; and the fast solves' factor/GMRES split."""
    split = ["| file | solve | factorisation | GMRES (and right-hand side) | GMRES iterations |",
             "|---|---:|---:|---:|---:|"]
    rows = ["| file | canvas | segments | solver | load | discretise | solve | upward | downward | build total "
            f"| peak memory | {samples}x{samples} render | build and render | E vs dense |",
            "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for path in files:
        log(f"{path.name} ...")
        done = subprocess.run([sys.executable, __file__, "--one", str(path), "--repeat", str(repeat),
                               "--dense-max", str(dense_max), "--samples", str(samples)],
                              capture_output=True, text=True)
        if done.returncode:
            message = (done.stderr.strip().splitlines() or ["failed"])[-1]
            rows.append(f"| {path.name} | | | failed: {message} |" + " |" * 10)
            continue
        r = json.loads(done.stdout.strip().splitlines()[-1])
        total = r["load"] + sum(r[stage] for stage in STAGES)
        solver = "dense" if r["segments"] <= fast_solve.DENSE_CROSSOVER else "fast"
        runs = "" if r["runs"] > 1 else " (1 run)"
        difference = f"{r['difference']:.1e} ({r['iterations']} it.)" if "difference" in r else "-"
        rows.append(
            f"| {path.name}{runs} | {r['size']} | {r['segments']:,} | {solver} | {r['load']:.2f} | "
            f"{r['discretise']:.2f} | {r['solve']:.2f} | {r['upward']:.2f} | {r['downward']:.2f} | "
            f"{total:.2f} | {r['peak_mb']:,.0f} MB | {r['render']:.2f}{'' if r['finite'] else ' (NaN!)'} | "
            f"**{total + r['render']:.2f}** | {difference} |"
        )
        if np.isfinite(r["factor"]):
            split.append(f"| {path.name}{runs} | {r['solve']:.2f} | {r['factor']:.2f} | {r['gmres']:.2f} | "
                         f"{r['build_iterations']} |")
    return rows, split


def crossover_table(repeat: int) -> list[str]:
    """Dense and fast solve side by side on random circles, growing canvases and counts."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from shapes import scattered_document

    rows = ["| segments | dense (s) | fast (s) | fast / dense | difference |", "|---:|---:|---:|---:|---:|"]
    for size, circles in ((128, 1), (256, 1), (256, 4), (512, 1), (512, 8), (512, 20)):
        document = scattered_document(size, circles=circles, seed=circles)
        segments, lattice = boundary_system(document)
        log(f"crossover: {len(segments)} segments")
        fast_time = dense_time = float("inf")
        for _ in range(repeat):
            f, d, fast, dense, _ = fast_and_dense(segments, lattice)
            fast_time, dense_time = min(fast_time, f), min(dense_time, d)
        difference = np.abs(fast - dense).max() / np.abs(dense).max()
        rows.append(f"| {len(segments):,} | {dense_time:.2f} | {fast_time:.2f} | {fast_time / dense_time:.2f} | "
                    f"{difference:.1e} |")
    return rows


def main(argv: list[str] | None = None) -> None:
    """Parse arguments and print the tables."""
    setup_process()  # the engine's thread and memory policy, as the editor's
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=Path, help="XML files (default: every file under orzan_xml/)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per measurement; the best is reported")
    parser.add_argument("--samples", type=int, default=1, help="render with K x K samples a pixel")
    parser.add_argument("--dense-max", type=int, default=12_000, help="largest system also solved densely")
    parser.add_argument("--crossover", action="store_true", help="also time dense against fast on synthetic documents")
    parser.add_argument("--crossover-only", action="store_true", help="only the dense/fast comparison")
    parser.add_argument("--one", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(one_file(args.one, args.repeat, args.dense_max, args.samples)))
        return
    files = args.files or sorted(ORZAN.rglob("*.xml"))
    print(f"Machine: {machine()}; load average {os.getloadavg()[0]:.1f} at the start. "
          f"Best of {args.repeat} runs unless marked; seconds.\n")
    if not args.crossover_only:
        rows, split = file_table(files, args.repeat, args.dense_max, args.samples)
        print("\n".join(rows))
        print("\nThe fast solves split (each column its own best):\n")
        print("\n".join(split))
        print(f"\nLoad average {os.getloadavg()[0]:.1f} at the end.")
    if args.crossover or args.crossover_only:
        print("\nDense against fast solve (random circles on 128 to 512 px canvases):\n")
        print("\n".join(crossover_table(args.repeat)))


if __name__ == "__main__":
    main()
