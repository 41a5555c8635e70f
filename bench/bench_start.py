"""Whole-process start-up times of the command line (issue 26), best of N with the slowest, warm caches.

    .venv/bin/python bench/bench_start.py [--repeats 5] [--window]

Each figure is a fresh process, as a user starts it: ``fmr-editor --version``, ``fmr-editor render`` of
lady_bug and of a 3-curve file at one sample a pixel, from the shared real files (``../shared/data``), and
``import fmr_editor.engine`` alone.  ``--window`` also starts the editor on lady_bug under its own Xvfb and
screenshots the screen every half second (ImageMagick's ``import``) until it stops changing: the first
screenshot within 1/255 mean of the last one is when the image showed (an upper bound, to the interval and
the screenshot's own time).  ``docs/performance.md`` keeps the figures.
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "orzan_xml"
EDITOR = Path(sys.executable).with_name("fmr-editor")


def timed(command: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def screenshot(display: str) -> np.ndarray:
    shot = subprocess.run(["import", "-window", "root", "png:-"], env={**os.environ, "DISPLAY": display},
                          check=True, capture_output=True).stdout
    return np.asarray(Image.open(io.BytesIO(shot)).convert("RGB"), dtype=np.int16)


def window_first_image(document: Path, display: str = ":117", timeout: float = 60.0) -> float:
    """Seconds from starting ``fmr-editor DOCUMENT`` to the first screenshot showing what it finally shows."""
    server = subprocess.Popen(["Xvfb", display, "-screen", "0", "1400x1000x24"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    time.sleep(1.0)
    start = time.perf_counter()
    editor = subprocess.Popen([str(EDITOR), str(document)], env={**os.environ, "DISPLAY": display},
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    shots: list[tuple[float, np.ndarray]] = []
    try:
        while time.perf_counter() - start < timeout:
            shots.append((time.perf_counter() - start, screenshot(display)))
            steady = len(shots) > 6 and all(np.abs(shot - shots[-1][1]).mean() < 0.05 for _, shot in shots[-6:])
            if steady:
                break
            time.sleep(0.5)
    finally:
        editor.kill()
        server.kill()
        editor.wait(), server.wait()
    final = shots[-1][1]
    return next(when for when, shot in shots if np.abs(shot - final).mean() < 1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--window", action="store_true", help="also time the editor window's first image")
    arguments = parser.parse_args()
    repeats = arguments.repeats
    with tempfile.TemporaryDirectory() as scratch:
        out = str(Path(scratch) / "out.png")
        commands = {
            "fmr-editor --version": ([str(EDITOR), "--version"], "0.3 s"),
            "import fmr_editor.engine": ([sys.executable, "-c", "import fmr_editor.engine"], "-"),
            "render lady_bug.xml --samples 1": (
                [str(EDITOR), "render", str(DATA / "berkbavas" / "lady_bug.xml"), "-o", out, "--samples", "1"],
                "1.5 s"),
            "render test5.xml (3 curves) --samples 1": (
                [str(EDITOR), "render", str(DATA / "handmade" / "test5.xml"), "-o", out, "--samples", "1"], "1.0 s"),
        }
        timed(commands["render lady_bug.xml --samples 1"][0])  # caches (numba's, the disk's) warm
        print(f"| command (whole process, best of {repeats}) | best | slowest | target |")
        print("|---|---:|---:|---|")
        for name, (command, target) in commands.items():
            times = [timed(command) for _ in range(repeats)]
            print(f"| `{name}` | {min(times):.2f} s | {max(times):.2f} s | {target} |", flush=True)
    if arguments.window:
        times = [window_first_image(DATA / "berkbavas" / "lady_bug.xml") for _ in range(repeats)]
        print(f"| `fmr-editor lady_bug.xml`: the image in the window | {min(times):.1f} s | {max(times):.1f} s "
              "| 3 s |", flush=True)


if __name__ == "__main__":
    main()
