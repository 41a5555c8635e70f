"""Whole-process start-up times of the command line (issue 26), best of N with the slowest, warm caches.

    .venv/bin/python bench/bench_start.py [--repeats 5]

Each figure is a fresh process, as a user starts it: ``fmr-editor --version``, ``fmr-editor render`` of
lady_bug and of a 3-curve file at one sample a pixel, from the shared real files (``../shared/data``), and
``import fmr_editor.engine`` alone.  ``docs/performance.md`` keeps the figures.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "orzan_xml"
EDITOR = Path(sys.executable).with_name("fmr-editor")


def timed(command: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    repeats = parser.parse_args().repeats
    with tempfile.TemporaryDirectory() as scratch:
        out = str(Path(scratch) / "out.png")
        commands = {
            "fmr-editor --version": ([str(EDITOR), "--version"], "0.3 s"),
            "import fmr_editor.engine": ([sys.executable, "-c", "import fmr_editor.engine"], "-"),
            "render lady_bug.xml --samples 1": (
                [str(EDITOR), "render", str(DATA / "berkbavas" / "lady_bug.xml"), "-o", out, "--samples", "1"], "1.5 s"),
            "render test5.xml (3 curves) --samples 1": (
                [str(EDITOR), "render", str(DATA / "handmade" / "test5.xml"), "-o", out, "--samples", "1"], "1.0 s"),
        }
        timed(commands["render lady_bug.xml --samples 1"][0])  # caches (numba's, the disk's) warm
        print(f"| command (whole process, best of {repeats}) | best | slowest | target |")
        print("|---|---:|---:|---|")
        for name, (command, target) in commands.items():
            times = [timed(command) for _ in range(repeats)]
            print(f"| `{name}` | {min(times):.2f} s | {max(times):.2f} s | {target} |", flush=True)


if __name__ == "__main__":
    main()
