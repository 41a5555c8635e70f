"""PNG export."""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
from PIL import Image

from .atomic import write_atomically


def to_rgb8(image: np.ndarray) -> np.ndarray:
    """Float RGB in [0, 1] (clamped) to rounded 8-bit, ``(H, W, 3)`` uint8."""
    return np.round(np.clip(image, 0.0, 1.0) * 255.0).astype(np.uint8)


def to_rgba8(image: np.ndarray) -> np.ndarray:
    """Float colour over black with its coverage, ``(H, W, 4)`` in [0, 1], to 8-bit RGBA of straight alpha
    (the colour divided by the coverage; black where nothing covers)."""
    image = np.clip(image, 0.0, 1.0)
    colour, alpha = image[..., :3], image[..., 3:]
    straight = np.divide(colour, alpha, out=np.zeros_like(colour), where=alpha > 0)
    return np.round(np.concatenate([np.clip(straight, 0.0, 1.0), alpha], axis=-1) * 255.0).astype(np.uint8)


def flattened(image: np.ndarray, background: tuple[float, float, float]) -> np.ndarray:
    """The picture over black with its coverage ``(H, W, 4)`` laid on the opaque ``background``, ``(H, W, 3)``."""
    return image[..., :3] + (1.0 - image[..., 3:]) * np.asarray(background, dtype=np.float64)


def parse_hex_colour(text: str) -> tuple[float, float, float]:
    """``"rrggbb"`` or ``"#rrggbb"`` as sRGB floats; ``ValueError`` for anything else."""
    digits = text.strip().removeprefix("#")
    if len(digits) != 6 or any(c not in "0123456789abcdefABCDEF" for c in digits):
        raise ValueError(f"a colour is six hexadecimal digits, as ffffff or #ff8800, not {text!r:.40}")
    return tuple(int(digits[i : i + 2], 16) / 255.0 for i in (0, 2, 4))


def png_bytes(image: np.ndarray) -> bytes:
    """``image`` (float RGB, or RGB over black with its coverage) as an 8-bit PNG: RGBA when the coverage is below
    1 somewhere (in 8 bits), else RGB."""
    if image.ndim != 3 or image.shape[-1] not in (3, 4):
        raise ValueError(f"a PNG is written from an (H, W, 3) or (H, W, 4) image, not one of shape {image.shape}")
    pixels = to_rgba8(image) if image.shape[-1] == 4 else to_rgb8(image)
    if pixels.shape[-1] == 4 and (pixels[..., 3] == 255).all():
        pixels = pixels[..., :3]  # opaque: the colour over black is the colour
    stream = io.BytesIO()
    Image.fromarray(pixels, mode="RGBA" if pixels.shape[-1] == 4 else "RGB").save(stream, format="PNG")
    return stream.getvalue()


def save_png(image: np.ndarray, path: str | os.PathLike) -> Path:
    """Write ``image`` to ``path`` as ``png_bytes`` makes it.

    The file is written beside the target and renamed into place, so a
    failure never leaves a half-written PNG.

    Returns
    -------
    pathlib.Path
        The absolute path written.
    """
    data = png_bytes(image)
    path = Path(path).absolute()
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_atomically(path, lambda stream: stream.write(data))
