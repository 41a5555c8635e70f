"""The FMR paper's Tables 1 and 2 side by side with ours, on the Hilbert benchmark DCIs.

    python bench/bench_paper.py [--repeat N] [--min-iteration I] [--max-iteration I] [--size S]
                                [--levels L] [--order P] [--propagation-order Q] [--seed K]

Table 1 of Sun, Thamjaroenporn and Zheng (SIGGRAPH 2014) times the upward and
downward passes (ms, quad-core C++) on Hilbert DCIs of 2,048 to 524,288
segments; Table 2 the 1024x1024 raster.  Our side skips the boundary solve
(dense, O(n^3) today): the segments are built as ``build`` builds them
(flatten + clip, ``choose_levels``, cut at cells + canvas border), then given a
synthetic, seeded normal-derivative jump ``E`` (standard normal per curve
segment, zero on the border; border colours uniform in [0, 1]) -- the passes'
and the raster's cost does not depend on the values.  ``upward`` is
``sort_into_cells`` + ``upward_pass`` (as ``build`` times it), ``downward`` is
``downward_pass``, the raster is ``rasterise(rep, S, S, samples=1)``.

Markdown on stdout, progress on stderr.  Every time is the best of N runs
(default 3) on a shared, noisy 2-core machine.  Peak RSS is the process's
``ru_maxrss`` after each row: a running maximum, so it belongs to the largest
row so far.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_engine import best_of, log, machine, warm_up  # noqa: E402
from hilbert import PAPER_ITERATIONS, hilbert_document, hilbert_settings  # noqa: E402

from fmr_editor.engine import Representation, rasterise  # noqa: E402
from fmr_editor.engine.fmm.lattice import Lattice, downward_pass, sort_into_cells, upward_pass  # noqa: E402
from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments  # noqa: E402
from fmr_editor.engine.representation import choose_levels  # noqa: E402

#: The paper's numbers, keyed by segment count: (upward ms, downward ms, raster 1024x1024 ms).
#: Not found: the paper's text (Table 1 and 2) could not be retrieved when this was written
#: (searches of stored copies returned only the paper's first page).  Fill these in from the
#: paper itself, with PAPER_SOURCE; never guess them.
PAPER: dict[int, tuple[float | None, float | None, float | None]] = {
    2 * 4**i: (None, None, None) for i in PAPER_ITERATIONS
}
PAPER_SOURCE = "not found"
#: Environment variables that set BLAS threads (the passes make many small matrix products).
BLAS_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def peak_rss_mb() -> float:
    """The process's peak resident set so far, in MB (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def timed(repeat: int, run):
    """Smallest and largest wall time of ``repeat`` calls of ``run()``, and the last result."""
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return min(times), max(times), result


def synthetic_values(segments, seed: int):
    """``segments`` with a seeded random ``E`` on curve segments and random border colours."""
    rng = np.random.default_rng(seed)
    n = len(segments)
    flux = np.where(segments.on_border[:, None], 0.0, rng.standard_normal((n, 3)))
    jump = np.where(segments.on_border[:, None], rng.uniform(0.0, 1.0, (n, 3)), segments.jump)
    return dataclasses.replace(segments, flux=flux, jump=jump)


def discretise(document, settings):
    """What ``build`` does before its solve: segments (curves + border, cut at cells) and the lattice."""
    side = float(max(document.width, document.height))
    curves = curve_segments(document, settings.tolerance, settings.max_length)
    levels = settings.levels or choose_levels(curves, side)
    lattice = Lattice(levels, side)
    return curves, lattice, boundary_segments(curves, document, lattice.cell_size, settings.border_spacing)


def bench_iteration(iteration: int, args: argparse.Namespace) -> dict:
    """Times and sizes for one Hilbert DCI."""
    size = args.size
    settings = hilbert_settings(size, levels=args.levels, order=args.order, propagation_order=args.propagation_order)
    log(f"iteration {iteration}: document")
    start = time.perf_counter()
    document = hilbert_document(iteration, size)
    document_time = time.perf_counter() - start
    log(f"iteration {iteration}: discretise x{args.repeat}")
    discretise_time, (curves, lattice, segments) = best_of(args.repeat, lambda: discretise(document, settings))
    segments = synthetic_values(segments, args.seed)
    p = settings.propagation_order
    log(f"iteration {iteration}: {len(curves)} curve segments -> {len(segments)} after cutting, L = {lattice.levels}; "
        f"upward x{args.repeat}")

    def upward():
        ordered, cell_start = sort_into_cells(segments, lattice)
        return ordered, cell_start, upward_pass(ordered, cell_start, lattice, p)

    upward_time, upward_worst, (ordered, cell_start, multipoles) = timed(args.repeat, upward)
    log(f"iteration {iteration}: downward x{args.repeat}")
    downward_time, downward_worst, local = timed(args.repeat, lambda: downward_pass(multipoles, lattice, p))
    del multipoles
    rep = Representation(size, size, lattice, ordered, cell_start, local, settings.order,
                         {"upward": upward_time, "downward": downward_time})
    log(f"iteration {iteration}: raster {args.raster}x{args.raster} x{args.repeat}")
    raster_time, raster_worst, image = timed(args.repeat, lambda: rasterise(rep, args.raster, args.raster, samples=1))
    if not np.isfinite(image).all():
        log(f"iteration {iteration}: WARNING: non-finite pixels in the raster")
    occupied = int(np.count_nonzero(np.diff(cell_start)))
    return {
        "iteration": iteration,
        "pieces": document.curves[0].piece_count,
        "curve segments": len(curves),
        "segments": len(segments),
        "border": int(segments.on_border.sum()),
        "L": lattice.levels,
        "occupied": occupied,
        "max per cell": int(np.diff(cell_start).max()),
        "document": document_time,
        "discretise": discretise_time,
        "upward": upward_time,
        "downward": downward_time,
        "raster": raster_time,
        "worst": {"upward": upward_worst, "downward": downward_worst, "raster": raster_worst},
        "rss": peak_rss_mb(),
    }


def _ms(row: dict, stage: str) -> str:
    """'best (slowest)' in ms."""
    return f"{1e3 * row[stage]:.0f} ({1e3 * row['worst'][stage]:.0f})"


def _paper_cells(count: int, index: int, ours: float) -> str:
    """'paper ms | ours/paper' cells."""
    value = PAPER.get(count, (None, None, None))[index]
    if value is None:
        return "not found | -"
    return f"{value:g} | {1e3 * ours / value:.2f}"


def main(argv: list[str] | None = None) -> None:
    """Parse arguments, warm up, print both tables."""
    from fmr_editor.engine import Settings

    defaults = Settings()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per measurement; the best is reported")
    parser.add_argument("--min-iteration", type=int, default=PAPER_ITERATIONS[0])
    parser.add_argument("--max-iteration", type=int, default=PAPER_ITERATIONS[-1],
                        help="stop after this iteration (9 = 524,288 segments, the heaviest)")
    parser.add_argument("--size", type=int, default=1024, help="canvas side of the Hilbert documents")
    parser.add_argument("--raster", type=int, default=1024, help="raster side (one sample per pixel)")
    parser.add_argument("--levels", type=int, default=None, help="lattice depth (default: choose_levels)")
    parser.add_argument("--order", type=int, default=defaults.order, help="cell polynomial degree for pixels")
    parser.add_argument("--propagation-order", type=int, default=defaults.propagation_order,
                        help="terms carried through the passes")
    parser.add_argument("--seed", type=int, default=0, help="seed of the synthetic E")
    args = parser.parse_args(argv)
    if args.repeat < 1 or args.size < 1 or args.raster < 1 or args.min_iteration < 1:
        parser.error("--repeat, --size, --raster and --min-iteration must be positive")

    log("warming up the numba kernels")
    compile_time = warm_up()
    print(f"## FMR paper Tables 1 and 2 on the Hilbert DCIs (best of {args.repeat} runs)\n")
    blas = ", ".join(f"{name}={os.environ[name]}" for name in BLAS_VARIABLES if name in os.environ) or "library default"
    print(f"Machine: {machine()}; BLAS threads: {blas}. Shared and noisy: every time is the best of "
          f"{args.repeat}, with the slowest run beside it in brackets.\n")
    depth = f"L = {args.levels} (fixed)" if args.levels else "L from `choose_levels` (the paper's depth was not found)"
    print(f"Settings: {depth}; propagation order {args.propagation_order}, pixel order {args.order}; "
          f"canvas {args.size}x{args.size}, raster {args.raster}x{args.raster} at 1 sample per pixel; "
          f"synthetic E (seed {args.seed}), no solve. Numba first call (not timed below): {compile_time:.1f} s.\n")
    print(f"Paper numbers: {PAPER_SOURCE}" + (" -- the paper's text could not be retrieved; "
          "no paper numbers are shown." if PAPER_SOURCE == "not found" else "") + "\n")

    rows = []
    for iteration in range(args.min_iteration, args.max_iteration + 1):
        rows.append(bench_iteration(iteration, args))
        r = rows[-1]
        log(f"iteration {iteration}: upward {1e3 * r['upward']:.0f} ms, downward {1e3 * r['downward']:.0f} ms, "
            f"raster {1e3 * r['raster']:.0f} ms, peak RSS {r['rss']:.0f} MB")

    print("### Table 1: upward and downward passes (ms)\n")
    print("| Hilbert DCI (pieces) | segments after cut (curve + border) | L | occupied cells | max seg/cell | "
          "discretise ms | upward ms (slowest) | paper upward ms | ours/paper | downward ms (slowest) | "
          "paper downward ms | ours/paper | peak RSS MB |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['pieces']:,} | {r['segments']:,} ({r['segments'] - r['border']:,} + {r['border']:,}) | {r['L']} | "
              f"{r['occupied']:,} | {r['max per cell']} | {1e3 * r['discretise']:.0f} | {_ms(r, 'upward')} | "
              f"{_paper_cells(r['pieces'], 0, r['upward'])} | {_ms(r, 'downward')} | "
              f"{_paper_cells(r['pieces'], 1, r['downward'])} | {r['rss']:.0f} |")
    print(f"\n### Table 2: {args.raster}x{args.raster} raster (ms)\n")
    print("| Hilbert DCI (pieces) | L | raster ms (slowest) | paper raster ms | ours/paper |")
    print("|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['pieces']:,} | {r['L']} | {_ms(r, 'raster')} | {_paper_cells(r['pieces'], 2, r['raster'])} |")
    print("\nPieces = the paper's segment count (2 straight pieces per edge of a closed Moore curve of order i, "
          "bench/hilbert.py); each piece is one curve segment before the engine cuts segments at cell edges. "
          "Upward = sort_into_cells + upward_pass (P2M, M2M); downward = downward_pass (M2L, L2L); raster = "
          "rasterise (cell polynomials + near field over the 3x3 block). The paper's are quad-core C++; ours are "
          "numpy + numba on the machine above.")


if __name__ == "__main__":
    main()
