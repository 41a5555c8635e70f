"""Seamless cloning benchmark (issue 14, engine side): paste and drag frames, no GL.

    python bench/bench_clone.py [SOURCE] [TARGET] [--repeat N]

A disc of 40 corners covering 0.6 of the source's width and height is cloned
into the middle of the target (scaled to its size):

- **paste**: ``SeamlessClone`` (the copied segments clipped, the boundary's
  dense factorisation, the copied segments' sum at it) plus ``clone_layer``
  (the target at the boundary, one back-substitution, the layer's and its
  mask's expansions);
- **drag frame**: the clone moved by a few pixels (``placed``: factorisation
  kept) and its layer made again.

Best of N (the machine is shared and noisy).  Paper (Table 3 of
``../shared/paper_tables.md``): 242-301 ms to paste about 20,000 curves.
Targets: paste <= 100 ms on 2 cores; drag >= 30 fps on lady_bug, >= 10 fps on roses.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "orzan_xml" / "berkbavas"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", nargs="?", default=str(DATA / "lady_bug.xml"))
    parser.add_argument("target", nargs="?", default=str(DATA / "lady_bug.xml"))
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    from fmr_editor.engine import LiveStack, SeamlessClone, Similarity, build
    from fmr_editor.engine.cloning import clone_layer
    from fmr_editor.io import load_document

    source = build(load_document(args.source))
    below = LiveStack(load_document(args.target)).composite
    w, h = source.width, source.height
    angles = np.linspace(0, 2 * np.pi, 41)[:-1]
    region = np.stack([w / 2 + 0.3 * w * np.cos(angles), h / 2 + 0.3 * h * np.sin(angles)], axis=1)
    scale = min(below.width / w, below.height / h)
    similarity = Similarity(scale, 0.0, (below.width / 2 - scale * w / 2, below.height / 2 - scale * h / 2))
    pastes, frames = [], []
    for i in range(args.repeat):
        start = time.perf_counter()
        clone = SeamlessClone(source.segments, region, similarity, canvas=(below.width, below.height))
        middle = time.perf_counter()
        clone_layer(clone, below)
        pastes.append((middle - start, time.perf_counter() - start))
        start = time.perf_counter()
        clone_layer(clone.placed(3.0, 2.0 * (i % 2)), below)
        frames.append(time.perf_counter() - start)
    setup, paste = np.min(pastes, axis=0) * 1e3
    frame = min(frames) * 1e3
    print(f"# Seamless cloning: {Path(args.source).name} ({len(source.segments):,} segments) into "
          f"{Path(args.target).name}; best of {args.repeat}\n")
    print(f"copied segments {len(clone.copied):,}, boundary segments {len(clone.midpoints):,}\n")
    print("| measure | ms | target |\n|---|---:|---|")
    print(f"| paste (of which the clone's setup {setup:.0f} ms) | {paste:.0f} | <= 100 (paper 242-301) |")
    print(f"| drag frame, engine side | {frame:.0f} ({1e3 / frame:.0f} fps) | >= 30 fps lady_bug, >= 10 roses |")


if __name__ == "__main__":
    main()
