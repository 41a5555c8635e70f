"""The Hilbert benchmark DCI of the FMR paper (Sun, Thamjaroenporn and Zheng 2014, Table 1).

    python bench/hilbert.py [--size S] [--max-iteration I] [--engine]

prints how iterations map to segment counts.

Construction
------------
The paper's text was not found (see ``bench/bench_paper.py``); its Table 1 rows
have 2,048, 8,192, 32,768, 131,072 and 524,288 segments, i.e. ``2 * 4^i`` for
``i = 5..9``.  No closed grid curve of a Hilbert kind has ``2 * 4^i`` unit edges
(a Moore curve, the closed Hilbert loop, of order ``i`` has ``4^i``), so:

- ``hilbert_document(i)`` is **one closed diffusion curve along the Moore curve
  of order i** (four order ``i - 1`` Hilbert curves joined into a loop) on a
  ``2^i x 2^i`` grid spread over the canvas with a margin (``size / 32`` by
  default), so vertices are ``(size - 2 margin) / (2^i - 1)`` pixels apart;
- **each grid edge is two straight cubic pieces** (split at its midpoint;
  control points at 1/3 and 2/3 of each piece), so iteration ``i`` has
  ``k = 2 * 4^i`` pieces: iteration 5 -> 2,048 pieces, ..., 9 -> 524,288, one
  paper row each.  Splitting an edge does not change the image, only the
  number of boundary elements, which is what the paper's rows count.
  ``pieces_per_edge=1`` gives the plain Moore curve (``4^i`` pieces).

Every piece is straight, so the engine flattens each into exactly one segment
when ``Settings.max_length`` is at least the piece length (the chord tolerance
adds nothing for straight pieces); ``hilbert_settings`` returns such settings.
The engine then still cuts segments at the lattice's cell edges and adds the
canvas border (``segment_counts(engine=True)`` reports both).

Colours: stops only at whole piece positions (so they add no breakpoints),
at most ``STOPS`` per side; the left side's hue turns ``TURNS`` times around
the colour wheel along the loop, the right side's the same with half a turn
of phase and darker, so the colour jump is never zero and the solve is not
trivial.  The hue returns to its start at ``s = k``, so colours are continuous
where the loop closes.
"""

from __future__ import annotations

import argparse
import colorsys
import sys

import numpy as np

from fmr_editor.model import ColorStop, DiffusionCurve, Document

#: Iterations matching the paper's Table 1 rows (2 * 4^i segments).
PAPER_ITERATIONS = (5, 6, 7, 8, 9)
#: Hue turns along the loop.
TURNS = 3
#: Largest number of colour-stop intervals per side.
STOPS = 96


def hilbert_points(order: int) -> np.ndarray:
    """Integer grid points ``(4^order, 2)`` of the Hilbert curve of ``order``, in path order.

    Starts at ``(0, 0)`` and ends at ``(2^order - 1, 0)``; consecutive points
    are one grid step apart.  Vectorised form of the classic ``d2xy``.
    """
    n = 1 << order
    t = np.arange(n * n, dtype=np.int64)
    x = np.zeros_like(t)
    y = np.zeros_like(t)
    s = 1
    while s < n:
        rx = 1 & (t // 2)
        ry = 1 & (t ^ rx)
        flip = (ry == 0) & (rx == 1)
        x = np.where(flip, s - 1 - x, x)
        y = np.where(flip, s - 1 - y, y)
        swap = ry == 0
        x, y = np.where(swap, y, x), np.where(swap, x, y)
        x = x + s * rx
        y = y + s * ry
        t = t // 4
        s *= 2
    return np.stack([x, y], axis=1)


def moore_points(order: int) -> np.ndarray:
    """Integer grid points ``(4^order, 2)`` of the closed Moore curve of ``order >= 1``.

    Four Hilbert curves of order ``order - 1``, rotated so that the last point
    is one grid step from the first: the loop has ``4^order`` unit edges.
    """
    if order < 1:
        raise ValueError("the Moore curve needs order >= 1")
    h = hilbert_points(order - 1)
    m = 1 << (order - 1)
    hx, hy = h[:, 0], h[:, 1]
    parts = [
        np.stack([m - 1 - hy, hx], axis=1),
        np.stack([m - 1 - hy, hx + m], axis=1),
        np.stack([hy + m, 2 * m - 1 - hx], axis=1),
        np.stack([hy + m, m - 1 - hx], axis=1),
    ]
    return np.concatenate(parts)


def piece_count(iteration: int, pieces_per_edge: int = 2) -> int:
    """Number of cubic pieces of ``hilbert_document(iteration)``: ``pieces_per_edge * 4^iteration``."""
    return pieces_per_edge * 4**iteration


def margin_of(size: int) -> float:
    """The default margin between the loop and the canvas edge, in pixels."""
    return size / 32


def loop_vertices(iteration: int, size: int = 1024, margin: float | None = None,
                  pieces_per_edge: int = 2) -> np.ndarray:
    """End points ``(k + 1, 2)`` of the pieces in document pixels; the last equals the first."""
    margin = margin_of(size) if margin is None else float(margin)
    grid = moore_points(iteration).astype(np.float64)
    side = (1 << iteration) - 1
    points = margin + grid * ((size - 2 * margin) / side)
    following = np.roll(points, -1, axis=0)
    fractions = np.arange(pieces_per_edge) / pieces_per_edge
    ends = (points[:, None] + fractions[None, :, None] * (following - points)[:, None]).reshape(-1, 2)
    return np.concatenate([ends, ends[:1]])


def _hsv(hue: np.ndarray, saturation: float, value: float) -> list[tuple[float, float, float]]:
    return [colorsys.hsv_to_rgb(h % 1.0, saturation, value) for h in hue]


def hilbert_document(iteration: int, size: int = 1024, margin: float | None = None,
                     pieces_per_edge: int = 2) -> Document:
    """The Hilbert benchmark document: one closed loop along the Moore curve of ``iteration``.

    Parameters
    ----------
    iteration : int
        Moore-curve order, ``>= 1``; 5 to 9 give the paper's Table 1 rows.
    size : int
        Square canvas side in pixels.
    margin : float, optional
        Gap between the loop and the canvas edge; defaults to ``size / 32``.
    pieces_per_edge : int
        Straight cubic pieces per grid edge (2 matches the paper's counts).

    Returns
    -------
    Document
        ``size x size`` with one curve of ``pieces_per_edge * 4^iteration``
        straight pieces whose last control point equals its first.
    """
    if pieces_per_edge < 1:
        raise ValueError("pieces_per_edge must be at least 1")
    ends = loop_vertices(iteration, size, margin, pieces_per_edge)
    k = len(ends) - 1
    control = np.empty((3 * k + 1, 2))
    control[0::3] = ends
    step = ends[1:] - ends[:-1]
    control[1::3] = ends[:-1] + step / 3
    control[2::3] = ends[:-1] + 2 * step / 3
    positions = np.unique(np.round(np.linspace(0, k, min(k, STOPS) + 1)))
    hue = TURNS * positions / k
    left = tuple(ColorStop(float(s), c) for s, c in zip(positions, _hsv(hue, 0.85, 0.95)))
    right = tuple(ColorStop(float(s), c) for s, c in zip(positions, _hsv(hue + 0.5, 0.6, 0.45)))
    return Document(size, size, (DiffusionCurve(control, left=left, right=right),))


def hilbert_settings(size: int = 1024, **overrides):
    """``Settings`` under which every straight piece is flattened into one segment.

    ``max_length`` is the canvas side, longer than any piece.
    """
    from fmr_editor.engine import Settings

    return Settings(**{"max_length": float(size), **overrides})


def segment_counts(max_iteration: int = 9, size: int = 1024, engine: bool = False) -> list[dict]:
    """How iterations map to segment counts (and to the paper's Table 1 rows).

    Parameters
    ----------
    max_iteration : int
    size : int
    engine : bool
        Also run the engine's discretisation (flatten + clip, ``choose_levels``,
        cut at cells + border) to report what it actually solves for.

    Returns
    -------
    list of dict
        One per iteration 1..``max_iteration``.
    """
    rows = []
    for i in range(1, max_iteration + 1):
        row = {
            "iteration": i,
            "grid": f"{1 << i}x{1 << i}",
            "grid edges (Moore loop)": 4**i,
            "pieces": piece_count(i),
            "paper row": f"{2 * 4**i:,}" if i in PAPER_ITERATIONS else "-",
            "vertex spacing px": (size - 2 * margin_of(size)) / ((1 << i) - 1),
        }
        if engine:
            from fmr_editor.engine.fmm.lattice import Lattice
            from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments
            from fmr_editor.engine.representation import choose_levels

            document, settings = hilbert_document(i, size), hilbert_settings(size)
            curves = curve_segments(document, settings.tolerance, settings.max_length)
            levels = settings.levels or choose_levels(curves, float(size))
            lattice = Lattice(levels, float(size))
            segments = boundary_segments(curves, document, lattice.cell_size, settings.border_spacing)
            border = int(segments.on_border.sum())
            row.update({
                "curve segments": len(curves),
                "L": levels,
                "after cut at cells": f"{len(segments) - border} + {border} border",
            })
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> None:
    """Print the mapping as a Markdown table."""
    parser = argparse.ArgumentParser(description="Hilbert benchmark DCI: iterations and segment counts")
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--max-iteration", type=int, default=9)
    parser.add_argument("--engine", action="store_true", help="also run the engine's discretisation")
    args = parser.parse_args(argv)
    rows = segment_counts(args.max_iteration, args.size, args.engine)
    keys = list(rows[0])
    print("| " + " | ".join(keys) + " |")
    print("|" + "---:|" * len(keys))
    for row in rows:
        print("| " + " | ".join(f"{v:.2f}" if isinstance(v, float) else str(v) for v in row.values()) + " |")
    print(f"\nCanvas {args.size}x{args.size}, margin {margin_of(args.size):g} px; "
          "pieces = 2 per Moore-loop edge = 2 * 4^i (paper rows: 2,048 ... 524,288 for i = 5..9).", file=sys.stdout)


if __name__ == "__main__":
    main()
