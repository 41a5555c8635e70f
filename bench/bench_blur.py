"""Blur benchmark: the blur field's solve and the CPU raster with blur beside the sharp one (issue 29).

    python bench/bench_blur.py [--repeat N] [--samples S]

On the shared real files that carry blur (lady_bug, glass_droplet_blur, fruits from ../shared/data), opened
from their .xml: the blur field's first solve (``LiveStack.blur``), then ``engine.rasterise`` of the picture
and ``engine.blur.rasterise_blurred`` at the canvas size, best of N, side by side.  The canvas does not show
blur yet; the issue's bar for it is a full evaluation at most 2x the sharp one.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "orzan_xml" / "berkbavas"


def seconds(work, repeat: int) -> float:
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        work()
        runs.append(time.perf_counter() - start)
    return min(runs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--samples", type=int, default=1)
    args = parser.parse_args()
    from fmr_editor.engine import LiveStack, rasterise, setup_process
    from fmr_editor.engine.blur import rasterise_blurred
    from fmr_editor.io import load_document

    setup_process()
    print(f"# Blur\n\nBest of {args.repeat}; {args.samples} x {args.samples} samples a pixel.\n")
    print("| file | blur field solve (s) | largest blur (px) | raster sharp (ms) | raster blurred (ms) | ratio |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in ("lady_bug", "glass_droplet_blur", "fruits"):
        document = load_document(DATA / f"{name}.xml")
        stack = LiveStack(document)
        start = time.perf_counter()
        blur = stack.blur(document.layer)
        solve = time.perf_counter() - start
        largest = float(np.max(rasterise(blur, samples=1)))
        sharp = seconds(lambda: rasterise(stack.composite, samples=args.samples), args.repeat)
        soft = seconds(lambda: rasterise_blurred(stack.composite, {document.layer.id: blur}, samples=args.samples),
                       args.repeat)
        print(f"| {name} | {solve:.2f} | {largest:.1f} | {sharp * 1e3:.0f} | {soft * 1e3:.0f} | {soft / sharp:.0f}x |")


if __name__ == "__main__":
    main()
