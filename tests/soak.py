"""A soak of the engine: random edits, undos and redos through ``Session``, checked against fresh builds.

``test_soak.py`` runs a short one; ``bench/soak.py`` the long one of issue 16 (10,000 steps on lady_bug).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fmr_editor.engine import LiveStack, rasterise
from fmr_editor.engine.memory import resident_bytes
from fmr_editor.model import DiffusionPoint, Document, edits
from fmr_editor.session import Session

#: Largest difference between the live picture and a fresh build's, as ``test_live`` allows an incremental solve.
PIXEL = 0.25 / 255
PIXELS = 48


def random_step(session: Session, rng: np.random.Generator) -> str:
    """One random step: an edit (move a control point, recolour a stop, move a curve, add or remove a point),
    an undo or a redo; returns its name."""
    document = session.document
    kind = rng.choice(["move point", "recolour", "translate", "add point", "remove point", "undo", "redo"],
                      p=[0.3, 0.2, 0.1, 0.1, 0.05, 0.15, 0.1])
    curve = document.curves[int(rng.integers(0, len(document.curves)))]
    size = np.array([document.width, document.height], float)
    if kind == "undo":
        session.undo()
    elif kind == "redo":
        session.redo()
    elif kind == "move point":
        index = int(rng.integers(0, len(curve.control_points)))
        target = np.clip(curve.control_points[index] + rng.normal(0, 3, 2), 1, size - 1)
        session.apply(lambda d: edits.move_control_point(d, curve.id, index, tuple(target)), kind)
    elif kind == "recolour":
        side = "left" if rng.random() < 0.5 else "right"
        stops = curve.left if side == "left" else curve.right
        if stops:
            colour = tuple(float(c) for c in rng.uniform(0, 1, 3))
            session.apply(lambda d: edits.set_stop_color(d, curve.id, side, int(rng.integers(0, len(stops))), colour),
                          kind)
    elif kind == "translate":
        session.apply(lambda d: edits.translate(d, tuple(rng.normal(0, 2, 2)), curves=[curve.id]), kind)
    elif kind == "add point":
        point = DiffusionPoint(tuple(rng.uniform(0, 1, 2) * size), float(rng.uniform(2, 12)),
                               tuple(float(c) for c in rng.uniform(0, 1, 3)))
        session.apply(lambda d: edits.add_points(d, [point]), kind)
    elif document.points:
        session.apply(lambda d: edits.remove_points(d, [min(d.point_ids())]), kind)
    return str(kind)


def live_difference(session: Session) -> float:
    """Largest difference between the live picture and a fresh build of the same document, both with the curves'
    blur (``Session.image`` draws it: a document with blur stops, as lady_bug, is compared blurred to blurred)."""
    fresh = LiveStack(session.document, blur=True).composite
    return float(np.abs(session.image(PIXELS, PIXELS, samples=1) - rasterise(fresh, PIXELS, PIXELS, samples=1)).max())


def soak(document: Document, steps: int, check_every: int, seed: int = 0,
         report: Callable[[int, float, int], None] = lambda step, difference, resident: None) -> list:
    """Run ``steps`` random steps on ``document``; every ``check_every`` steps compare with a fresh build.

    Returns
    -------
    list of (step, difference, resident bytes)
    """
    session, rng, checks = Session(document), np.random.default_rng(seed), []
    for step in range(1, steps + 1):
        random_step(session, rng)
        if step % check_every == 0:
            checks.append((step, live_difference(session), resident_bytes()))
            report(*checks[-1])
    return checks
