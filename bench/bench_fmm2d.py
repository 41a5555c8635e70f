"""The engine's FMM on point charges and dipoles against fmm2d (Flatiron's Fortran FMM).

    python bench/bench_fmm2d.py [--sizes 1e4 1e5 1e6] [--eps 1e-3 1e-6 1e-9] [--repeat N]
                                [--threads 2] [--check-targets 2000] [--no-fmm2d]

Both sides get the same seeded random problem: n sources in the unit square,
each with a charge and a dipole, the sources their own targets (own term
dropped), kernel ``c ln|x - y| - d.(x - y)/|x - y|^2`` (fmm2d's ``rfmm2d``).
fmm2d (``fmm2dpy`` from PyPI, which needs numpy<2) runs in its own virtual
environment, created once in ``bench/.venv-fmm2d`` (ignored by git through a
``.gitignore`` inside it), as a subprocess that times its own calls.

Accuracy: for each requested fmm2d ``eps`` the relative l2 error of fmm2d is
measured on a random subset of targets against the direct sum; our order is
then the smallest whose error on the same targets is no larger, so the
comparison never favours us on accuracy.  Times are the best of N runs (the
machine is shared and noisy), after a warm-up (numba compile or cache load;
fmm2d's first call), import time excluded on both sides.  Both use the same
number of threads (OMP_NUM_THREADS for fmm2d, numba's for us; our few matrix
products use OpenBLAS's default, all cores, which is 2 here).

Prints Markdown tables on stdout (progress on stderr).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from bench_engine import machine
from point_fmm import evaluate_points_fmm, evaluate_points_reference, fmm_levels

VENV = Path(__file__).resolve().parent / ".venv-fmm2d"
STAGES = ("sort", "p2m", "m2m", "downward", "evaluate")

#: Runs inside the fmm2d virtual environment: argv = data folder, eps, repeat.
FMM2D_SCRIPT = r'''
import ctypes, glob, json, os, sys, time
from importlib.metadata import version
import numpy as np
import fmm2dpy

folder, eps, repeat = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
sources = np.load(os.path.join(folder, "sources.npy"))      # (n, 2) C order: .T is Fortran (2, n)
charges = np.load(os.path.join(folder, "charges.npy"))
dipstr = np.load(os.path.join(folder, "dipstr.npy"))
dipvec = np.load(os.path.join(folder, "dipvec.npy"))        # (n, 2)
check = np.load(os.path.join(folder, "check.npy"))

def run():
    return fmm2dpy.rfmm2d(eps=eps, sources=sources.T, charges=charges, dipstr=dipstr, dipvec=dipvec.T, pg=1)

threads = None
for lib in glob.glob(os.path.join(os.path.dirname(fmm2dpy.__file__), os.pardir, "fmm2dpy.libs", "libgomp*")):
    threads = ctypes.CDLL(lib).omp_get_max_threads()
out = run()  # warm-up
times, cpu = [], []
for _ in range(repeat):
    wall0, cpu0 = time.perf_counter(), time.process_time()
    out = run()
    times.append(time.perf_counter() - wall0)
    cpu.append(time.process_time() - cpu0)
np.save(os.path.join(folder, "fmm2d_check.npy"), out.pot[check])
best = min(range(repeat), key=times.__getitem__)
print(json.dumps({"times": times, "cpu_over_wall": cpu[best] / times[best], "omp_max_threads": threads,
                  "ier": int(out.ier), "version": version("fmm2dpy"),
                  "numpy": np.__version__}))
'''


def log(message: str) -> None:
    """A progress line on stderr."""
    print(message, file=sys.stderr, flush=True)


def fmm2d_python(venv: Path) -> tuple[Path | None, str]:
    """The fmm2d environment's python, created on first use; ``(None, reason)`` when that fails."""
    python = venv / "bin" / "python"
    probe = [str(python), "-c", "import fmm2dpy, numpy; print(numpy.__version__)"]
    if python.exists() and subprocess.run(probe, capture_output=True).returncode == 0:
        return python, "cached"
    log(f"creating {venv} with fmm2dpy and numpy<2 (once)")
    steps = [
        [sys.executable, "-m", "venv", "--clear", str(venv)],
        [str(python), "-m", "pip", "install", "--quiet", "fmm2dpy", "numpy<2"],
    ]
    for step in steps:
        try:
            result = subprocess.run(step, capture_output=True, text=True, timeout=900)
        except (OSError, subprocess.TimeoutExpired) as error:
            return None, f"{' '.join(step[:4])}: {error}"
        if step[1:3] == ["-m", "venv"] and result.returncode == 0:
            (venv / ".gitignore").write_text("*\n")
        if result.returncode != 0:
            tail = (result.stderr or result.stdout).strip().splitlines()[-3:]
            return None, f"{' '.join(step[:4])} failed: {' / '.join(tail)}"
    if subprocess.run(probe, capture_output=True).returncode != 0:
        return None, "fmm2dpy installed but does not import"
    return python, "created"


def run_fmm2d(python: Path, folder: Path, eps: float, repeat: int, threads: int) -> dict:
    """fmm2d's timings (best of ``repeat`` after a warm-up) and its potential at the check targets."""
    script = folder / "run_fmm2d.py"
    script.write_text(FMM2D_SCRIPT)
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    result = subprocess.run([str(python), str(script), str(folder), repr(eps), str(repeat)],
                            capture_output=True, text=True, env=env)
    if result.returncode != 0:
        raise RuntimeError(result.stderr.strip().splitlines()[-1] if result.stderr else "fmm2d failed")
    report = json.loads(result.stdout.strip().splitlines()[-1])
    report["check"] = np.load(folder / "fmm2d_check.npy")
    return report


def relative_error(got: np.ndarray, expected: np.ndarray) -> float:
    return float(np.linalg.norm(got - expected) / np.linalg.norm(expected))


def ours(problem: dict, order: int, repeat: int = 1) -> tuple[float, np.ndarray, dict[str, float], int]:
    """Our best time of ``repeat`` runs, the last potential, the best time of each stage, the depth."""
    sources, charges, dipoles = problem["sources"], problem["charges"], problem["dipoles"]
    best, stages, out = float("inf"), {}, None
    for _ in range(repeat):
        timings: dict[str, float] = {}
        start = time.perf_counter()
        out = evaluate_points_fmm(sources, charges, dipoles, order=order, timings=timings)
        best = min(best, time.perf_counter() - start)
        stages = {k: min(v, stages.get(k, np.inf)) for k, v in timings.items()}
    return best, out, stages, fmm_levels(len(sources), len(sources), order)


def match_order(problem: dict, target_error: float) -> tuple[int, float]:
    """The smallest order whose error on the check targets is at most ``target_error``.

    Starts from the error measured on uniform points, about 1.5e-4 at order 6
    falling by 0.4 an order, and steps from there.
    """
    check, reference = problem["check"], problem["reference"]
    guess = int(np.clip(round(6 + np.log(target_error / 1.5e-4) / np.log(0.4)), 2, 40))

    def error(order: int) -> float:
        return relative_error(ours(problem, order)[1][check], reference)

    order, err = guess, error(guess)
    if err <= target_error:
        while order > 2:
            lower = error(order - 1)
            if lower > target_error:
                break
            order, err = order - 1, lower
    else:
        while err > target_error and order < 40:
            order += 1
            err = error(order)
    return order, err


def make_problem(n: int, seed: int, check_targets: int, folder: Path) -> dict:
    """Seeded sources, charges, dipoles and check targets, saved as .npy for the fmm2d side."""
    rng = np.random.default_rng(seed)
    sources = rng.uniform(0.0, 1.0, (n, 2))
    charges = rng.normal(size=n)
    dipstr = rng.normal(size=n)
    angle = rng.uniform(0.0, 2 * np.pi, n)
    dipvec = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    check = np.sort(rng.choice(n, min(n, check_targets), replace=False))
    for name, value in (("sources", sources), ("charges", charges), ("dipstr", dipstr), ("dipvec", dipvec),
                        ("check", check)):
        np.save(folder / f"{name}.npy", value)
    start = time.perf_counter()
    dipoles = dipstr[:, None] * dipvec
    reference = evaluate_points_reference(sources, charges, dipoles, sources[check])
    log(f"  direct sum at {len(check)} check targets: {time.perf_counter() - start:.1f} s")
    return {"sources": sources, "charges": charges, "dipoles": dipoles, "check": check, "reference": reference}


def main(argv: list[str] | None = None) -> None:
    from fmr_editor.engine import setup_process

    setup_process()  # the engine's thread and memory policy, as the editor's
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", nargs="+", type=float, default=[1e4, 1e5, 1e6])
    parser.add_argument("--eps", nargs="+", type=float, default=[1e-3, 1e-6, 1e-9],
                        help="fmm2d tolerances; our order is matched to fmm2d's achieved error")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--check-targets", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--no-fmm2d", action="store_true", help="our side only, at orders 8, 16 and 24")
    args = parser.parse_args(argv)

    numba.set_num_threads(args.threads)
    python, status = (None, "skipped (--no-fmm2d)") if args.no_fmm2d else fmm2d_python(VENV)
    if python is None:
        log(f"fmm2d unavailable: {status}; timing our side only")
    start = time.perf_counter()
    rng = np.random.default_rng(0)
    small = rng.uniform(0, 1, (2000, 2))
    evaluate_points_fmm(small, rng.normal(size=2000), rng.normal(size=(2000, 2)), order=8)  # compile or load
    warm_up = time.perf_counter() - start
    print(f"Machine: {machine()}; load average before: {os.getloadavg()[0]:.2f}")
    print(f"numba warm-up (compile or cache load): {warm_up:.2f} s; fmm2d environment: {status}")
    print(f"Times: best of {args.repeat} after a warm-up, {args.threads} threads each; errors: relative l2 "
          f"at {args.check_targets} random sources (own term dropped) against the direct sum.\n")

    rows, stage_rows, fmm2d_info = [], [], None
    with tempfile.TemporaryDirectory(prefix="bench_fmm2d_") as tmp:
        folder = Path(tmp)
        for size in args.sizes:
            n = int(size)
            log(f"n = {n}")
            problem = make_problem(n, args.seed, args.check_targets, folder)
            targets = [(None, order) for order in (8, 16, 24)] if python is None else [(eps, None) for eps in args.eps]
            for eps, order in targets:
                their_time = their_error = None
                if python is not None:
                    log(f"  fmm2d eps={eps:g}")
                    try:
                        report = run_fmm2d(python, folder, eps, args.repeat, args.threads)
                    except RuntimeError as error:
                        log(f"  fmm2d failed: {error}")
                        continue
                    fmm2d_info = report
                    their_time, their_error = min(report["times"]), relative_error(report["check"],
                                                                                    problem["reference"])
                    order, _ = match_order(problem, their_error)
                log(f"  ours order={order}")
                our_time, out, stages, levels = ours(problem, order, args.repeat)
                our_error = relative_error(out[problem["check"]], problem["reference"])
                rows.append((n, eps, order, levels, our_time, their_time, our_error, their_error))
                stage_rows.append((n, order, levels, our_time, stages))

    print("| n | fmm2d eps / our order (depth) | ours (s) | fmm2d (s) | our error | fmm2d error | "
          "throughput ratio (fmm2d time / ours) |")
    print("|---|---|---|---|---|---|---|")
    for n, eps, order, levels, our_time, their_time, our_error, their_error in rows:
        eps_text = "-" if eps is None else f"{eps:g}"
        their = "-" if their_time is None else f"{their_time:.3f}"
        their_err = "-" if their_error is None else f"{their_error:.1e}"
        ratio = "-" if their_time is None else f"{their_time / our_time:.2f}"
        print(f"| {n:.0e} | {eps_text} / {order} ({levels}) | {our_time:.3f} | {their} | {our_error:.1e} | "
              f"{their_err} | {ratio} |")
    if fmm2d_info is not None:
        print(f"\nfmm2d: fmm2dpy {fmm2d_info['version']} with numpy "
              f"{fmm2d_info['numpy']}; OMP_NUM_THREADS={args.threads}, omp_get_max_threads() = "
              f"{fmm2d_info['omp_max_threads']}, CPU time / wall time of its last best run = "
              f"{fmm2d_info['cpu_over_wall']:.2f}")
    print("\nWhere our time goes (best of each stage, seconds; they need not add up to the best total):\n")
    print("| n | order (depth) | sources per cell | total | " + " | ".join(STAGES) + " |")
    print("|---|---|---|---|" + "---|" * len(STAGES))
    for n, order, levels, total, stages in stage_rows:
        cells = " | ".join(f"{stages.get(stage, 0.0):.3f}" for stage in STAGES)
        print(f"| {n:.0e} | {order} ({levels}) | {n / 4**levels:.0f} | {total:.3f} | {cells} |")
    print(f"\nLoad average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
