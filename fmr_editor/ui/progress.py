"""What the progress bar says: the engine's stages in the user's words, short enough for the bar."""

from __future__ import annotations

#: The engine's and the jobs' stage names (``progress(stage, fraction)``), as the bar shows them.
STAGE_WORDS = {
    "discretise": "Preparing curves",
    "solve": "Solving curves",
    "upward": "Building",
    "downward": "Building",
    "points": "Building points",
    "rasterise": "Rendering",
    "write": "Saving",
}


def progress_text(stage: str) -> str:
    """The bar's text for ``stage``, with Qt's percentage (``%p%``); a stage not listed is shown as it comes."""
    return f"{STAGE_WORDS.get(stage, stage)} %p%"
