"""PNG export."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from PIL import Image

from .atomic import write_atomically


def to_rgb8(image: np.ndarray) -> np.ndarray:
    """Float RGB in [0, 1] (clamped) to rounded 8-bit, ``(H, W, 3)`` uint8."""
    return np.round(np.clip(image, 0.0, 1.0) * 255.0).astype(np.uint8)


def save_png(image: np.ndarray, path: str | os.PathLike) -> Path:
    """Write ``image`` (float RGB) to ``path`` as an 8-bit PNG.

    The file is written beside the target and renamed into place, so a
    failure never leaves a half-written PNG.

    Returns
    -------
    pathlib.Path
        The absolute path written.
    """
    path = Path(path).absolute()
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_atomically(path, lambda stream: Image.fromarray(to_rgb8(image), mode="RGB").save(stream, format="PNG"))
