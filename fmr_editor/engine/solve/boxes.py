"""The boxes of the compressed factorisation: the quadtree of the unknowns' midpoints, level by level."""

from __future__ import annotations

import numpy as np


def box_keys(points: np.ndarray, origin: np.ndarray, side: float, level: int) -> np.ndarray:
    """``(n, 2)`` box of each point at ``level`` (``2^level`` boxes a side of the square at ``origin``)."""
    count = 2**level
    return np.clip(np.floor((points - origin) / (side / count)).astype(np.int64), 0, count - 1)


def leaf_levels(points: np.ndarray, origin: np.ndarray, side: float, leaf_size: int) -> int:
    """Coarsest depth whose occupied boxes hold at most ``leaf_size`` points on average (at least 2)."""
    for level in range(2, 30):
        keys = box_keys(points, origin, side, level)
        occupied = len(np.unique(keys[:, 0] * 2**level + keys[:, 1]))
        if len(points) <= leaf_size * occupied:
            return level
    return 30


def group(points: np.ndarray, origin: np.ndarray, side: float, level: int):
    """``(key, indices)`` of each occupied box at ``level``."""
    keys = box_keys(points, origin, side, level)
    flat = keys[:, 0] * 2**level + keys[:, 1]
    order = np.argsort(flat, kind="stable")
    unique, start = np.unique(flat[order], return_index=True)
    for box, indices in zip(unique, np.split(order, start[1:])):
        yield (int(box) // 2**level, int(box) % 2**level), indices
