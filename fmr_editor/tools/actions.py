"""Commands on the selection, shared by the tools and the ui's menus and panels.

Each is one undo step (or none when it changes nothing) and returns whether
it did anything.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Hashable

from ..model import Document, edits
from ..model.curve import Color
from .context import Selection, ToolContext
from .moving import move_label, translate_selection


def _plural(n: int, noun: str) -> str:
    return noun + ("s" if n > 1 else "")


def delete_label(selection: Selection) -> str:
    """"Delete Stop", "Delete Curves", ... or "Delete" for a mix."""
    anchors = [p for p in selection.control_points if p[1] % 3 == 0]
    kinds = [(n, noun) for n, noun in ((len(selection.curves), "Curve"), (len(selection.stops), "Stop"),
                                       (len(selection.points), "Point"), (len(anchors), "Anchor")) if n]
    return "Delete " + _plural(*kinds[0]) if len(kinds) == 1 else "Delete"


def delete_selection(context: ToolContext) -> bool:
    """Remove the selected curves, stops, anchors and points as one step.

    Removing inner anchors joins their pieces; a curve left with fewer than
    two anchors goes.  Selected handles alone are not deleted.  Afterwards a
    stop next to the removed ones of each side that keeps some is selected (the
    one that took the first removed one's place, or the last), so that the
    curve stays in the stops panel and the next removal is one key away.
    """
    document, selection = context.document, context.selection
    doomed = set(selection.curves)
    anchors: dict[int, set[int]] = defaultdict(set)
    for c, i in selection.control_points:
        if i % 3 == 0 and c not in doomed:
            anchors[c].add(i)
    for c, chosen in anchors.items():
        if document.curve(c).piece_count + 1 - len(chosen) < 2:
            doomed.add(c)
    stops: dict[tuple[int, str], list[int]] = defaultdict(list)
    for c, side, i in selection.stops:
        if c not in doomed:
            stops[c, side].append(i)
    edited = document
    for (c, side), indices in stops.items():
        for i in sorted(indices, reverse=True):
            edited = edits.remove_stop(edited, c, side, i)
    for c, chosen in anchors.items():
        if c not in doomed:
            edited = edits.remove_anchors(edited, c, chosen)
    edited = edits.remove_curves(edited, doomed)
    edited = edits.remove_points(edited, selection.points)
    if edited == document:
        return False
    context.history.apply(edited, delete_label(selection))
    context.selection = Selection.of(stops=_neighbours(edited, stops))
    return True


def _neighbours(document: Document, removed: dict[tuple[int, str], list[int]]) -> list[tuple[int, str, int]]:
    """``(curve, side, index)``: of each side ``removed`` names (indices of stops removed from it), the stop now at
    the first removed index, or the last stop; none of a side left without stops."""
    chosen = []
    for (curve, side), indices in removed.items():
        count = len(getattr(document.curve(curve), side))
        if count:
            chosen.append((curve, side, min(min(indices), count - 1)))
    return chosen


def nudge(context: ToolContext, delta: tuple[float, float]) -> bool:
    """Move the selection by ``delta`` document pixels (arrow keys) as one step."""
    document = context.document
    moved = translate_selection(document, context.selection, delta)
    if moved is document or moved == document:
        return False
    context.history.apply(moved, move_label(document, context.selection))
    return True


def recolor_stops(context: ToolContext, color: Color, merge_key: Hashable | None = None,
                  alpha: float | None = None) -> bool:
    """Give every selected stop ``color`` (and ``alpha``, when given) as one step "Change Stop Colour".

    Parameters
    ----------
    merge_key : hashable, optional
        Pass the same key for each change of a colour slider's drag, so that
        the drag stays one step (see ``History.apply``).
    alpha : float, optional
        The stops' alpha in [0, 1]; None keeps each stop's.
    """
    document = context.document
    edited = document
    for c, side, i in sorted(context.selection.stops):
        edited = edits.set_stop_color(edited, c, side, i, tuple(float(v) for v in color))
        if alpha is not None:
            edited = edits.set_stop_alpha(edited, c, side, i, alpha)
    if edited == document:
        return False
    n = len(context.selection.stops)
    context.history.apply(edited, "Change " + _plural(n, "Stop") + " Colour", merge_key)
    return True


def set_blur_stops(context: ToolContext, blur: float, merge_key: Hashable | None = None) -> bool:
    """Give every selected blur stop ``blur`` (document pixels of deviation) as one step "Change Blur"
    (``merge_key`` as ``recolor_stops``'s)."""
    document = context.document
    edited = document
    for c, side, i in sorted(context.selection.stops):
        if side == "blur":
            edited = edits.set_stop_blur(edited, c, i, blur)
    if edited == document:
        return False
    context.history.apply(edited, "Change Blur", merge_key)
    return True
