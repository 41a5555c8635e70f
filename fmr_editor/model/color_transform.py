"""Affine colour transforms of a layer: ``T(v) = A v + b`` on RGB, with the presets artists expect.

A diffusion image is linear in its colours, so a transform applies exactly to
every cell coefficient of a layer (``A`` to each coefficient vector, ``b`` to
the constant term) and to its segments' colours (docs/design.md section 5).  The
presets are the W3C filter-effects matrices (``hueRotate``, ``saturate``)
and component transfers (brightness, contrast, invert), in sRGB values as
the editor diffuses them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: Luminance weights of the W3C filter-effects matrices.
LUMA = np.array([0.213, 0.715, 0.072])
#: Largest magnitude of a matrix or offset entry: far beyond any adjustment, and safe in the shader's float32.
LIMIT = 1e6


@dataclass(frozen=True, eq=False)
class ColorTransform:
    """``T(v) = matrix @ v + offset`` for RGB colours ``v``.

    Parameters
    ----------
    matrix : numpy.ndarray
        ``(3, 3)``; stored as a read-only float64 copy.
    offset : numpy.ndarray
        ``(3,)``.
    """

    matrix: np.ndarray = field(default_factory=lambda: np.eye(3))
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        for name, shape in (("matrix", (3, 3)), ("offset", (3,))):
            value = np.array(getattr(self, name), dtype=np.float64, copy=True)
            if value.shape != shape or not np.all(np.abs(value) <= LIMIT):  # NaN fails too
                raise ValueError(f"a colour transform's {name} must be {shape} numbers within +-{LIMIT:g}")
            value.flags.writeable = False
            object.__setattr__(self, name, value)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ColorTransform):
            return NotImplemented
        return np.array_equal(self.matrix, other.matrix) and np.array_equal(self.offset, other.offset)

    def __hash__(self) -> int:
        return hash((self.matrix.tobytes(), self.offset.tobytes()))

    @property
    def is_identity(self) -> bool:
        return self == IDENTITY

    def apply(self, colors: np.ndarray) -> np.ndarray:
        """``T`` of colours ``(..., 3)``."""
        return np.asarray(colors, dtype=np.float64) @ self.matrix.T + self.offset

    def then(self, other: ColorTransform) -> ColorTransform:
        """The transform that applies ``self``, then ``other``."""
        return ColorTransform(other.matrix @ self.matrix, other.matrix @ self.offset + other.offset)


IDENTITY = ColorTransform()


def hue_rotation(degrees: float) -> ColorTransform:
    """The W3C ``hueRotate`` matrix: turns hues by ``degrees`` and keeps greys."""
    theta = math.radians(float(degrees))
    grey = np.tile(LUMA, (3, 1))
    cos_part = np.array([[0.787, -0.715, -0.072], [-0.213, 0.285, -0.072], [-0.213, -0.715, 0.928]])
    sin_part = np.array([[-0.213, -0.715, 0.928], [0.143, 0.140, -0.283], [-0.787, 0.715, 0.072]])
    return ColorTransform(grey + math.cos(theta) * cos_part + math.sin(theta) * sin_part)


def saturation(amount: float) -> ColorTransform:
    """The W3C ``saturate`` matrix: 0 gives grey (luminance), 1 changes nothing, above 1 saturates."""
    s = float(amount)
    grey = np.tile(LUMA, (3, 1))
    return ColorTransform(grey + s * (np.eye(3) - grey))


def brightness_contrast(brightness: float = 1.0, contrast: float = 1.0) -> ColorTransform:
    """W3C ``brightness`` (a factor) followed by ``contrast`` (a slope about mid-grey 0.5)."""
    b, c = float(brightness), float(contrast)
    return ColorTransform(c * b * np.eye(3), np.full(3, 0.5 - 0.5 * c))


def inversion() -> ColorTransform:
    """``1 - v``: the W3C ``invert`` at full amount."""
    return ColorTransform(-np.eye(3), np.ones(3))
