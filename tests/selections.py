"""Selections written by position (the n-th curve, the n-th point), as tests read most easily.

``Selection`` names curves and points by id; ``by_index`` turns positions in
a document into those ids, so that a test can say "the first curve".
"""

from __future__ import annotations

from fmr_editor.model import Document
from fmr_editor.tools import Selection


def by_index(document: Document, curves=(), control_points=(), stops=(), points=()) -> Selection:
    """``Selection.of`` with curves and points given by their positions in ``document``."""
    curve = [c.id for c in document.curves]
    return Selection.of(
        [curve[c] for c in curves],
        [(curve[c], i) for c, i in control_points],
        [(curve[c], side, i) for c, side, i in stops],
        [document.points[p].id for p in points],
    )
