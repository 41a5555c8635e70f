"""Engine benchmark: build stages, FMR raster against the direct sum, kernel throughput.

    python bench/bench_engine.py [FILES...] [--repeat N] [--direct-pixels K] [--size S] [--max-segments M]

Prints Markdown tables on stdout (progress goes to stderr).  Every time is the
best of N runs, each stage taken separately; numba's one-off compile (or cache
load) happens in a warm-up before any timing and is printed on its own.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numba
import numpy as np

import fmr_editor
from fmr_editor.engine import Settings, build, rasterise, setup_process
from fmr_editor.engine.fmm.lattice import Lattice, sort_into_cells
from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.engine.kernels.potentials import direct_sum_reference
from fmr_editor.engine.kernels.segment_sums import direct_sum, near_sum
from fmr_editor.engine.raster import sample_coordinates
from fmr_editor.engine.representation import choose_levels
from fmr_editor.engine.solve.dense import assemble
from fmr_editor.model import ColorStop, DiffusionCurve, Document

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "orzan_xml" / "berkbavas"
DEFAULT_FILES = ("lady_bug.xml", "poivron.xml", "zephyr.xml", "flower.xml")
STAGES = ("discretise", "solve", "upward", "downward")


def log(message: str) -> None:
    """A progress line on stderr."""
    print(message, file=sys.stderr, flush=True)


def best_of(repeat: int, run):
    """Smallest wall time of ``repeat`` calls of ``run()``, and the last result."""
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = run()
        best = min(best, time.perf_counter() - start)
    return best, result


def machine() -> str:
    """CPU model, core count and library versions, one line."""
    cpu = "unknown CPU"
    try:
        cpu = next(line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    try:
        layer = f", layer {numba.threading_layer()}"
    except ValueError:  # known only once a parallel kernel has run
        layer = ""
    return (f"{cpu}, {os.cpu_count()} cores ({numba.get_num_threads()} numba threads{layer}); "
            f"Python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}")


def warm_up() -> float:
    """Build and rasterise a tiny document once so every numba kernel is compiled; its seconds."""
    curve = DiffusionCurve(np.array([[8, 8], [20, 30], [40, 2], [56, 56]], float),
                           left=(ColorStop(0, (1, 0, 0)),), right=(ColorStop(1, (0, 0, 1)),))
    start = time.perf_counter()
    rep = build(Document(64, 64, (curve,)))
    rasterise(rep, 32, 32, samples=1)
    seg = rep.segments
    direct_sum(np.zeros((4, 2)), seg.p, seg.q, seg.flux, seg.jump)
    return time.perf_counter() - start


def segment_count(document: Document, settings: Settings) -> int:
    """Segments (curves + border) ``build`` would solve for, without solving."""
    side = float(max(document.width, document.height))
    curves = curve_segments(document, settings.tolerance, settings.max_length)
    levels = settings.levels or choose_levels(curves, side)
    return len(boundary_segments(curves, document, Lattice(levels, side).cell_size, settings.border_spacing))


def bench_file(path: Path, args: argparse.Namespace, notes: set) -> str:
    """One Markdown table row for ``path``; adds warnings to ``notes``; LookupError to skip it."""
    if not path.is_file():
        raise LookupError(f"{path.name}: not found ({path})")
    document, settings = fmr_editor.load(path), Settings()
    count = segment_count(document, settings)
    if count > args.max_segments:
        raise LookupError(f"{path.name}: {count} segments > --max-segments {args.max_segments} "
                          "(the solve is dense, O(n^3) time and n^2 memory)")
    stages = dict.fromkeys(STAGES, float("inf"))
    for run in range(args.repeat):
        log(f"{path.name}: build {run + 1}/{args.repeat} ({count} segments)")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            rep = build(document, settings)
        stages = {stage: min(stages[stage], rep.timings[stage]) for stage in STAGES}
    notes.update(f"{path.name}: build warned: {warning.message}" for warning in caught)
    size = args.size
    log(f"{path.name}: FMR raster {size}x{size}")
    fmr_time, image = best_of(args.repeat, lambda: rasterise(rep, size, size, samples=1))
    # A random subsample of the same 1-sample grid, summed over every segment.
    rng = np.random.default_rng(0)
    pick = rng.choice(size * size, size=min(args.direct_pixels, size * size), replace=False)
    rows, cols = np.divmod(pick, size)
    xs, ys = sample_coordinates(size, rep.width, 1), sample_coordinates(size, rep.height, 1)
    targets = np.stack([xs[cols], ys[rows]], axis=1)
    seg = rep.segments
    log(f"{path.name}: direct sum on {len(pick)} pixels")
    direct_time, direct = best_of(args.repeat, lambda: direct_sum(targets, seg.p, seg.q, seg.flux, seg.jump))
    per_pixel = direct_time / len(pick)
    full = per_pixel * size * size
    error = np.abs(image[rows, cols] - direct).max() * 255
    border = int(seg.on_border.sum())
    ms = [f"{1e3 * stages[stage]:.0f}" for stage in STAGES]
    return (f"| {path.name} | {document.width}x{document.height} | {len(document.curves)} | "
            f"{len(seg)} ({len(seg) - border} + {border}) | {rep.lattice.levels} | {' | '.join(ms)} | "
            f"{1e3 * fmr_time:.0f} | {1e6 * per_pixel:.1f} | {full:.1f} | {full / fmr_time:.0f}x | {error:.2g}/255 |")


def kernel_table(repeat: int, segments: int = 2000, targets: int = 20000, numpy_targets: int = 2000,
                 assembled: int = 3000, near_segments: int = 20000) -> list[str]:
    """Markdown rows: million target-segment pairs per second, numba against numpy.

    ``direct_sum``: random short segments and points on a 512 px canvas.
    ``dense.assemble``: the dense collocation system of ``assembled`` random
    segments (n^2 pairs).  ``near_sum``: ``near_segments`` random short
    segments sorted into a 64 x 64 lattice, evaluated at their own midpoints
    (the iterative solve's near field; pairs = the 3x3 blocks' sizes).
    """
    rng = np.random.default_rng(1)
    p = rng.uniform(0, 512, (segments, 2))
    q = p + rng.uniform(-1.5, 1.5, (segments, 2))
    flux, jump = rng.normal(size=(segments, 3)), rng.normal(size=(segments, 3))
    points = rng.uniform(0, 512, (targets, 2))

    def random_segments(count: int, extent: float) -> Segments:
        start = rng.uniform(0, extent, (count, 2))
        return Segments(start, start + rng.uniform(-1.5, 1.5, (count, 2)), rng.normal(size=(count, 3)),
                        rng.normal(size=(count, 3)), rng.random(count) < 0.3, rng.normal(size=(count, 3)))

    system = random_segments(assembled, 512.0)
    lattice = Lattice(6, 512.0)
    near, cell_start = sort_into_cells(random_segments(near_segments, 512.0), lattice)
    mids, own, side = near.midpoints, np.arange(near_segments), lattice.cells_per_side
    cells = lattice.cell_of(mids)
    padded = np.pad(np.diff(cell_start).reshape(side, side), 1)
    block = sum(padded[1 + dy : 1 + dy + side, 1 + dx : 1 + dx + side] for dy in (-1, 0, 1) for dx in (-1, 0, 1))
    near_pairs = int(block[cells[:, 0], cells[:, 1]].sum())

    def run_near():
        return near_sum(mids, lattice.cells_per_side, lattice.cell_size, cell_start, near.p, near.q, near.flux,
                        near.jump, own)

    threads = numba.get_num_threads()
    # (name, threads, run, shape, pairs)
    cases = [(f"numba `direct_sum`, {threads} threads", threads, lambda: direct_sum(points, p, q, flux, jump),
              f"{segments} x {targets}", segments * targets),
             ("numba `direct_sum`, 1 thread", 1, lambda: direct_sum(points, p, q, flux, jump),
              f"{segments} x {targets}", segments * targets),
             (f"numba `dense.assemble`, {threads} threads", threads, lambda: assemble(system),
              f"{assembled} x {assembled}", assembled**2),
             (f"numba `near_sum` at midpoints, {threads} threads", threads, run_near,
              f"{near_segments} in 3x3 blocks", near_pairs),
             ("numpy `direct_sum_reference`", threads,
              lambda: direct_sum_reference(points[:numpy_targets], p, q, flux, jump),
              f"{segments} x {numpy_targets}", segments * numpy_targets)]
    rows, results = [], {}
    for name, use_threads, run, shape, pairs in cases:
        log(f"kernels: {name}")
        numba.set_num_threads(use_threads)
        try:
            run()  # compile or load from the cache outside the timing
            seconds, results[name] = best_of(repeat, run)
        finally:
            numba.set_num_threads(threads)
        rows.append((name, shape, seconds, pairs / seconds / 1e6))
    numpy_rate = rows[-1][3]
    agree = np.abs(results[cases[0][0]][:numpy_targets] - results[cases[-1][0]]).max()
    table = ["| kernel | segments x targets | best time (ms) | M pairs/s | vs numpy |", "|---|---|---:|---:|---:|"]
    table += [f"| {name} | {shape} | {1e3 * s:.0f} | {rate:.1f} | {rate / numpy_rate:.1f}x |"
              for name, shape, s, rate in rows]
    return table + ["", f"Largest |numba - numpy| on the common {numpy_targets} targets: {agree:.2e}. "
                    "\"vs numpy\" compares pairs per second with `direct_sum_reference` (the same closed forms)."]


def main(argv: list[str] | None = None) -> None:
    """Parse arguments, warm up, print both tables."""
    setup_process()  # the engine's thread and memory policy, as the editor's
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", default=list(DEFAULT_FILES),
                        help="XML files (default: four berkbavas samples)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per measurement; the best is reported")
    parser.add_argument("--direct-pixels", type=int, default=2000, help="pixels summed directly")
    parser.add_argument("--size", type=int, default=1024, help="raster size (size x size, one sample per pixel)")
    parser.add_argument("--max-segments", type=int, default=12000, help="skip larger files (dense O(n^3) solve)")
    parser.add_argument("--kernels-only", action="store_true", help="print only the kernel throughput table")
    args = parser.parse_args(argv)
    if args.repeat < 1 or args.direct_pixels < 1 or args.size < 1:
        parser.error("--repeat, --direct-pixels and --size must be positive")
    log("warming up the numba kernels")
    compile_time = warm_up()
    s = args.size
    print(f"## fmr-editor engine benchmark (best of {args.repeat} runs)\n\nMachine: {machine()}\n")
    print(f"One-off first call of the numba kernels (compile, or load from numba's cache; not in the timings "
          f"below): {compile_time:.1f} s\n")
    if args.kernels_only:
        print(f"### Kernel throughput (best of {args.repeat} runs)\n")
        print("\n".join(kernel_table(args.repeat)))
        return
    print(f"| file | canvas | curves | segments (curve + border) | L | discretise ms | solve ms | upward ms | "
          f"downward ms | FMR raster {s}x{s} ms | direct us/px | direct {s}x{s} s (extrap.) | direct/FMR | "
          "max \\|FMR - direct\\| |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    notes = set()
    for name in args.files:
        try:
            path = Path(name) if Path(name).exists() else DATA / name  # a path, or a sample's name
            print(bench_file(path, args, notes), flush=True)
        except LookupError as note:
            log(f"skipped {note}")
            notes.add(f"skipped {note}")
    print("\n".join(["", *(f"- {note}" for note in sorted(notes))]))
    print(f"\nRaster: one sample per pixel, canvas scaled onto {s}x{s}. Direct: `kernels.direct_sum` over every "
          f"segment on {args.direct_pixels} random pixels of that grid, time extrapolated to {s * s} pixels. "
          f"Each column is its own best of {args.repeat}.\n")
    print(f"### Kernel throughput (best of {args.repeat} runs)\n")
    print("\n".join(kernel_table(args.repeat)))


if __name__ == "__main__":
    main()
