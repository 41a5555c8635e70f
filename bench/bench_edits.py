"""Edit benchmark: incremental updates side by side with full rebuilds of the same document.

    python bench/bench_edits.py [--repeat N] [--data DIR]

Edits (issue 4's targets):
- one stop's colour on ``lady_bug.xml`` and ``fruits.xml`` (a curve of median
  length; its first left stop cycles through colours);
- one control point of that curve on ``lady_bug.xml``, moved by a pixel back
  and forth;
- one brush stroke of 20 dabs (radius 20 px, 10 px apart) into a document of 100,000 points
  (radii 12-96 px, on a 1024 px canvas).

Every time is the best of N runs (the machine is shared and noisy); the
rebuild is ``engine.build`` of the edited document, timed in the same run.
"Pixels" is the largest difference between the updated and the rebuilt
representation's images (one sample per pixel), in 1/255.

The editing session (``--session``, on lady_bug, fruits and roses, issues 11
and 25): each file opened from its ``.xml`` as the editor opens it
(``io.open_live``: a ``LiveStack``, updated as the editor's engine thread
updates it), then a drag's previews, the exact result after it, a direct
anchor move, deleting a curve, undo and redo, jumping through the history, a
stop colour and the first and later brush dabs, each the best of N with the
slowest beside it; the previews' error against the exact picture of the same
document (mean and 99th percentile over the canvas, one sample a pixel, the
worst drag), how many previews showed the last exact picture instead (stale),
the factorisations the session made after opening, and the final image
against a fresh build.

The geometry step of an anchor move (``--geometry``, on lady_bug, fruits and
roses): what ``LiveRepresentation.update`` asks of ``engine.geometry`` per
edit, the document's curve segments (``CurveSegments.segments``) and the
boundary cut at the cells (``boundary_segments``), the last results alive
as the live representation holds them; beside it the plain pipeline
(``curve_segments``, ``boundary_segments``), which it must equal
bit for bit.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_engine import best_of, machine  # noqa: E402

from fmr_editor.engine import LiveRepresentation, LiveStack, build, rasterise, setup_process  # noqa: E402
from fmr_editor.engine.fmm.lattice import Lattice  # noqa: E402
from fmr_editor.engine.geometry import discretise  # noqa: E402
from fmr_editor.engine.geometry.curve_cache import CurveSegments  # noqa: E402
from fmr_editor.engine.memory import affordable_levels  # noqa: E402
from fmr_editor.engine.representation import Settings, choose_levels  # noqa: E402
from fmr_editor.io import load_document, open_live  # noqa: E402
from fmr_editor.model import DiffusionPoint, Document, edits  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "orzan_xml" / "berkbavas"
COLOURS = [(0.9, 0.1, 0.5), (0.2, 0.3, 0.4), (0.5, 0.5, 0.1), (0.0, 0.8, 0.9)]


def edited_curve(document: Document) -> int:
    """The curve of median length among those with a left stop."""
    candidates = [i for i, curve in enumerate(document.curves) if curve.left]
    return sorted(candidates, key=lambda i: document.curves[i].piece_count)[len(candidates) // 2]


def timed_updates(live: LiveRepresentation, documents: list[Document]) -> tuple[float, str]:
    """Best time of updating ``live`` to each document in turn, and the kind of the last update."""
    best, kind = math.inf, ""
    for document in documents:
        start = time.perf_counter()
        update = live.update(document)
        best, kind = min(best, time.perf_counter() - start), update.kind
    return best, kind


def pixel_error(live: LiveRepresentation, rebuilt) -> float:
    width, height = live.document.width, live.document.height
    return 255 * float(np.abs(rasterise(live.representation, width, height, 1)
                              - rasterise(rebuilt, width, height, 1)).max())


def row(name: str, live: LiveRepresentation, documents: list[Document], rebuilds: int, target: str) -> None:
    update, kind = timed_updates(live, documents)
    rebuild, rebuilt = best_of(rebuilds, lambda: build(live.document))
    print(f"| {name} | {kind} | {update * 1e3:.1f} ms | {rebuild:.2f} s | {rebuild / update:.0f}x | "
          f"{pixel_error(live, rebuilt):.4f} | {target} |", flush=True)


def curve_edits(path: Path, repeat: int, rebuilds: int, move: bool) -> None:
    document = load_document(path)
    live = LiveRepresentation(document)
    k = edited_curve(document)
    colours = [edits.set_stop_color(document, document.curves[k].id, "left", 0, COLOURS[i % len(COLOURS)])
               for i in range(repeat)]
    target = "<= 30 ms, >= 10x" if path.stem == "lady_bug" else ">= 10x"
    row(f"{path.stem}: stop colour (curve {k})", live, colours, rebuilds, target)
    if move:
        point = document.curves[k].control_points[1]
        moves = [edits.move_control_point(live.document, live.document.curves[k].id, 1, tuple(point + (i % 2)))
                 for i in range(1, repeat + 1)]
        row(f"{path.stem}: control point (curve {k})", live, moves, rebuilds, "<= 60 ms")


def dab(repeat: int) -> None:
    rng = np.random.default_rng(0)

    def points(count: int) -> list[DiffusionPoint]:
        radii = np.exp(rng.uniform(math.log(12), math.log(96), count))
        return [DiffusionPoint(tuple(xy), r, tuple(c)) for xy, r, c in
                zip(rng.uniform(0, 1024, (count, 2)), radii, rng.uniform(0, 1, (count, 3)))]

    document = Document(1024, 1024, points=points(100_000))
    live = LiveRepresentation(document)

    def stroke() -> list[DiffusionPoint]:
        """20 dabs of the editor's default brush (radius 20 px, spacing 10 px) along a short stroke."""
        start, angle = rng.uniform(200, 800, 2), rng.uniform(0, 2 * math.pi)
        step = 10.0 * np.array([math.cos(angle), math.sin(angle)])
        colour = tuple(rng.uniform(0, 1, 3))
        return [DiffusionPoint(tuple(start + i * step), 20.0, colour, 0.5) for i in range(20)]

    strokes = [edits.add_points(document, stroke()) for _ in range(repeat)]
    start = time.perf_counter()
    edits.add_points(document, stroke())
    edit = time.perf_counter() - start
    best = math.inf
    for edited in strokes:
        live.update(document)
        start = time.perf_counter()
        live.update(edited)
        best = min(best, time.perf_counter() - start)
    rebuild, rebuilt = best_of(1, lambda: build(live.document))
    print(f"| 100,000 points: 20 dabs | points | {best * 1e3:.1f} ms | {rebuild:.2f} s | {rebuild / best:.0f}x | "
          f"{pixel_error(live, rebuilt):.4f} | <= 5 ms |")
    print(f"\nMaking the edited document itself (a tuple of 100,020 points, checked) took {edit * 1e3:.1f} ms, "
          "not counted above.")


#: Issue 25's targets for the session's rows (ms): lady_bug, fruits, roses (None: no target).
SESSION_TARGETS = {
    "drag preview (frame)": (50, None, 150),
    "exact image after release": (150, None, 1000),
    "anchor move, exact": (150, None, 1000),
    "delete a curve": (150, None, 1000),
    "undo (kept state)": (50, 50, 50),
    "redo (kept state)": (50, 50, 50),
    "history jump to the start": (1000, None, None),
    "stop colour": (30, None, 150),
    "first dab (3 points)": (20, None, None),
}
SESSION_FILES = ("lady_bug", "fruits", "roses")


def spread(times: list[float]) -> str:
    return f"{min(times) * 1e3:.0f} ({max(times) * 1e3:.0f})"


def session(path: Path, repeat: int) -> dict:
    """The editor's edits on one file, as its engine thread asks ``LiveStack`` for them (see the module).

    Returns the rows: name -> list of seconds, plus ``"preview error"`` (mean, p99 in 1/255), ``"stale"``
    (previews showing the last exact picture, of all), ``"factorisations"`` and ``"final"`` (1/255).
    """
    start = time.perf_counter()
    live = open_live(path)
    built = time.perf_counter() - start
    live.warm_up()  # as the editor's engine thread does after opening
    (field,) = live.fields.values()
    factorised = field.factorisations
    document = live.document
    k = edited_curve(document)
    anchor = document.curves[k].control_points[3]
    rows: dict = {}
    errors, stale, previews = [], 0, 0

    def timed(name: str, document: Document, exact: bool = True):
        start = time.perf_counter()
        update = live.update(document, exact=exact)
        rows.setdefault(name, []).append(time.perf_counter() - start)
        return update

    for run in range(repeat):
        base = live.document
        moved = [edits.move_control_point(base, base.curves[k].id, 3,
                                          tuple(anchor + 0.5 * (i + 1) * np.array([1.0, run % 3 - 1])))
                 for i in range(10)]
        for preview in moved:  # a drag: 10 previews, then the exact result of the last
            stale += timed("drag preview (frame)", preview, exact=False).stale
            previews += 1
        shown = rasterise(live.composite, samples=1)
        timed("exact image after release", moved[-1])
        if not live.stale:
            difference = 255 * np.abs(np.clip(shown, 0, 1) - np.clip(rasterise(live.composite, samples=1), 0, 1))
            errors.append((float(difference.max(axis=2).mean()), float(np.percentile(difference.max(axis=2), 99))))
        timed("anchor move, exact",
              edits.move_control_point(live.document, live.document.curves[k].id, 3, tuple(anchor + (run + 1.5, 0.5))))
        moved[-1] = live.document
        timed("delete a curve", edits.remove_curves(live.document, [live.document.curves[k].id]))
        deleted, before = live.document, moved[-1]
        timed("undo (kept state)", before)
        timed("redo (kept state)", deleted)
        timed("history jump to the start", document)
        timed("stop colour",
              edits.set_stop_color(live.document, live.document.curves[k].id, "left", 0, COLOURS[run % len(COLOURS)]))
    rows["factorisations"] = field.factorisations - factorised
    final = live.document
    fresh = LiveStack(final, live.settings).composite  # a composite shows each layer clamped to [0, 1]
    rows["final"] = 255 * float(np.abs(rasterise(live.composite, samples=1) - rasterise(fresh, samples=1)).max())
    rows["preview error"] = (max(e[0] for e in errors), max(e[1] for e in errors)) if errors else (0.0, 0.0)
    rows["stale"] = (stale, previews)
    first, later = [], []
    for run in range(repeat):  # dabs into a freshly opened document
        dab_doc = LiveRepresentation(final)
        dab_doc.warm_up()
        for times in (first, later, later):
            stroke = [DiffusionPoint((100.0 + 10 * i + run, 120.0 + len(times)), 20.0, (1.0, 0.55, 0.15), 0.3)
                      for i in range(3)]
            start = time.perf_counter()
            dab_doc.update(edits.add_points(dab_doc.document, stroke))
            times.append(time.perf_counter() - start)
    rows["first dab (3 points)"], rows["later dab (3 points)"] = first, later
    print(f"{path.stem}: {len(field.representation.segments.p):,} segments, opened in {built:.1f} s", flush=True)
    return rows


def session_table(results: dict[str, dict]) -> None:
    """The session's rows for every file side by side, each target beside its figure."""
    names = list(results)
    print("\n| edit (ms) | " + " | ".join(names) + " | target |")
    print("| --- | " + " | ".join("---:" for _ in names) + " | --- |")
    timed = [key for key, value in next(iter(results.values())).items() if isinstance(value, list)]
    for key in timed:
        targets = SESSION_TARGETS.get(key)
        wanted = ", ".join(f"<= {t} {n}" for t, n in zip(targets, SESSION_FILES) if t is not None) if targets else ""
        print(f"| {key} | " + " | ".join(spread(results[name][key]) for name in names) + f" | {wanted} |")
    print("| preview error, mean / p99 (1/255) | " + " | ".join(
        "{:.3f} / {:.3f}".format(*results[name]["preview error"]) for name in names) + " | <= 1 / 4 |")
    print("| previews showing the last exact picture | " + " | ".join(
        "{} of {}".format(*results[name]["stale"]) for name in names) + " | |")
    print("| factorisations after opening | " + " | ".join(str(results[name]["factorisations"]) for name in names)
          + " | 0 |")
    print("| final image vs a fresh build (1/255) | " + " | ".join(f"{results[name]['final']:.4f}" for name in names)
          + " | exact |")


def geometry_step(path: Path, repeat: int) -> None:
    """The geometry step of ``repeat`` anchor moves of the edited curve, best of them (see the module)."""
    settings, document = Settings(), load_document(path)
    cache = CurveSegments(settings.tolerance, settings.max_length)
    curves = cache.segments(document)
    side = float(max(document.width, document.height))
    cell = Lattice(affordable_levels(choose_levels(curves, side), settings.propagation_order + 1), side).cell_size
    cuts = discretise.BoundaryCuts()
    held = curves, cuts(curves, document, cell, settings.border_spacing)
    k = edited_curve(document)
    anchor = document.curves[k].control_points[3]
    step, plain, exact = [], [], True
    for run in range(repeat):
        moved = edits.move_control_point(document, document.curves[k].id, 3, tuple(anchor + (0.5 * (run + 1), 0.25)))
        start = time.perf_counter()
        curves = cache.segments(moved)
        boundary = cuts(curves, moved, cell, settings.border_spacing)
        step.append(time.perf_counter() - start)
        cache.forget(document.curves + moved.curves)
        start = time.perf_counter()
        expected = discretise.curve_segments(moved, settings.tolerance, settings.max_length)
        expected_boundary = discretise.boundary_segments(expected, moved, cell, settings.border_spacing)
        plain.append(time.perf_counter() - start)
        exact &= all(getattr(a, name).tobytes() == getattr(b, name).tobytes() for a, b in
                     ((curves, expected), (boundary, expected_boundary)) for name in ("p", "q", "jump", "mean",
                                                                                       "on_border", "flux", "origin"))
        document, held = moved, (curves, boundary)
    print(f"| {path.stem} | {len(document.curves):,} | {len(held[0]):,} | {len(held[1]):,} | {spread(step)} | "
          f"{spread(plain)} | {'yes' if exact else 'NO'} |", flush=True)


def main() -> None:
    setup_process()  # the engine's thread and memory policy, as the editor's
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="updates per edit (best of)")
    parser.add_argument("--rebuilds", type=int, default=3, help="rebuilds of lady_bug (best of); fruits: 2")
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--session", nargs="*", metavar="FILE",
                        help="the editing session (issues 11, 25) on these files (default: lady_bug fruits roses) "
                             "instead")
    parser.add_argument("--geometry", nargs="*", metavar="FILE",
                        help="the geometry step of an anchor move on these files (default: lady_bug fruits roses) "
                             "instead")
    args = parser.parse_args()
    if args.geometry is not None:
        print(f"# Geometry step of an anchor move\n\n{machine()}\n\nBest of {args.repeat} (slowest in brackets).\n")
        print("| file | curves | curve segments | boundary segments | step ms | plain pipeline ms | equal |")
        print("| --- | ---: | ---: | ---: | ---: | ---: | --- |")
        for name in args.geometry or ["lady_bug", "fruits", "roses"]:
            geometry_step(args.data / f"{name}.xml", args.repeat)
        return
    if args.session is not None:
        print(f"# Editing session\n\n{machine()}\n\nBest of {args.repeat} (slowest in brackets).\n")
        session_table({name: session(args.data / f"{name}.xml", args.repeat) for name in args.session or SESSION_FILES})
        return
    warm = LiveRepresentation(load_document(args.data / "lady_bug.xml"))  # numba cache loads
    warm.update(edits.set_stop_color(warm.document, warm.document.curves[edited_curve(warm.document)].id, "left", 0,
                                     (1, 1, 1)))
    print(f"# Edits\n\n{machine()}\n\nBest of {args.repeat} updates and of {args.rebuilds} rebuilds (fruits: 2, "
          "points: 1).\n")
    print("| edit | update | time | rebuild | speed-up | pixels (1/255) | target |")
    print("| --- | --- | ---: | ---: | ---: | ---: | --- |")
    curve_edits(args.data / "lady_bug.xml", args.repeat, args.rebuilds, move=True)
    curve_edits(args.data / "fruits.xml", max(2, args.repeat // 2), 2, move=False)
    dab(args.repeat * 4)


if __name__ == "__main__":
    main()
