"""Straight segments: what the boundary integral form is discretised into (``discretise`` makes them).

Each segment carries its colour jump ``C = u_left - u_right`` and the mean of
both sides ``(u_left + u_right) / 2`` per channel, both constant along it; the
solve adds the normal-derivative jump ``E``.  The canvas border is one closed
chain of segments with the canvas on its left (docs/design.md section 2).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Segments:
    """A set of straight segments with their boundary data.

    Parameters
    ----------
    p, q : numpy.ndarray
        ``(n, 2)`` start and end points in document pixels.
    jump : numpy.ndarray
        ``(n, 3)`` colour jump ``C`` (left minus right); for border segments
        the unknown colour just inside the canvas (zero until solved).
    mean : numpy.ndarray
        ``(n, 3)`` mean of both sides' colours (curve segments only).
    on_border : numpy.ndarray
        ``(n,)`` bool, True for canvas-border segments.
    flux : numpy.ndarray
        ``(n, 3)`` normal-derivative jump ``E`` (zero until solved; always
        zero on the border).
    origin : numpy.ndarray, optional
        ``(n, 2)`` where each segment's colours come from: the id of its
        curve (``DiffusionCurve.id``) and the position (piece units) its
        colours were taken at; ``(-1, nan)`` for the border and unknown origins.
    """

    p: np.ndarray
    q: np.ndarray
    jump: np.ndarray
    mean: np.ndarray
    on_border: np.ndarray
    flux: np.ndarray
    origin: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.origin is None:
            object.__setattr__(self, "origin", np.tile([-1.0, np.nan], (len(self.p), 1)))

    def __len__(self) -> int:
        return len(self.p)

    @property
    def midpoints(self) -> np.ndarray:
        return 0.5 * (self.p + self.q)

    @property
    def lengths(self) -> np.ndarray:
        return np.hypot(*(self.q - self.p).T)

    @property
    def nbytes(self) -> int:
        """Bytes of the arrays held."""
        return sum(getattr(self, name).nbytes for name in _FIELDS)

    def unknowns(self) -> np.ndarray:
        """The solve's unknowns ``(n, 3)``: ``E`` on curve segments, ``C`` on border segments."""
        return np.where(self.on_border[:, None], self.jump, self.flux)

    def with_unknowns(self, unknown: np.ndarray) -> "Segments":
        """A copy with ``E`` (curves) and ``C`` (border) taken from ``unknown (n, 3)``."""
        border = self.on_border[:, None]
        return replace(self, jump=np.where(border, unknown, self.jump), flux=np.where(border, 0.0, unknown))

    def take(self, index: np.ndarray) -> "Segments":
        """The segments at ``index`` (an integer or boolean array)."""
        index = np.asarray(index)
        index = np.flatnonzero(index) if index.dtype == bool else index.astype(np.intp, copy=False)
        return Segments(*(np.take(getattr(self, name), index, axis=0) for name in _FIELDS))  # 3-10x [index] on 2-D

    def split(self, owner: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> "Segments":
        """Sub-segments ``[t0, t1]`` (parameters along ``owner``'s segments)."""
        pieces = self.take(owner)
        d = pieces.q - pieces.p
        return replace(pieces, p=pieces.p + t0[:, None] * d, q=pieces.p + t1[:, None] * d)


_FIELDS = ("p", "q", "jump", "mean", "on_border", "flux", "origin")


def concatenate(parts: list[Segments]) -> Segments:
    """All segments of ``parts`` in one set, in order."""
    return Segments(*(np.concatenate([getattr(part, name) for part in parts]) for name in _FIELDS))


def empty_segments() -> Segments:
    z = np.zeros((0, 2)), np.zeros((0, 3))
    return Segments(z[0], z[0], z[1], z[1], np.zeros(0, bool), z[1])
