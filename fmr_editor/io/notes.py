"""What the readers say of what a file held that they did not read (``load_document``'s ``notes``)."""

from __future__ import annotations

from collections.abc import Iterable


def listed(kinds: Iterable[tuple[int, str, str | None]]) -> str:
    """``"1 text element, 2 gradient meshes"`` of ``(count, singular, plural)`` (``plural`` None: the singular and
    an "s"), those of count 0 left out."""
    return ", ".join(f"{count} {singular if count == 1 else plural or singular + 's'}"
                     for count, singular, plural in kinds if count)
