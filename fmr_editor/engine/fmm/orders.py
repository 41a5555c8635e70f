"""How many terms each translation of a build's passes carries, from a measured error bound.

A multipole-to-local translation between cells of one size at offset ``d``
truncates twice: the source's multipole after term ``m`` and the target's
local expansion after term ``q``.  ``truncation_errors`` measures both, for
unit sources (a logarithm and a dipole) on the boundary of the source cell
and targets on the boundary of the target cell (the errors are harmonic in
both, so the boundaries hold the maxima), in cell-size units.  The nearest
offsets (two cells apart) need the most terms; the farthest (three cells
apart diagonally) about half as many.

The error a translation makes in colour is its unit error times the strength
of the source cell, the sum of ``|E| h`` and ``|C| h / r`` over its segments
(``r`` the cell size).  A cell holds four children, each at most as strong as
the strongest fine cell once the dipoles' ``1 / r`` halves: a cell ``j``
levels above the fine one is at most ``4^j`` times as strong as the
strongest fine cell, whatever the data.  The pixels themselves truncate each
fine cell's local expansion after their degree ``N``: from the nearest source
cell that is an error ``e_N`` (``pixel_error``) times the fine strength.
``pass_orders`` gives every translation of a level ``j`` above the fine one
the fewest terms whose measured error, times ``4^j``, stays within
``ERROR_SHARE`` of ``e_N``: the passes add at most about what the pixels
already make, so the error still falls with ``N`` as it did with one high
order everywhere (measured on the Hilbert benchmark scenes against the direct
sum: ``tests/test_passes.py``).  The orders depend on ``L``, ``N`` and the
width only, so an edit's change (``sparse_downward.delta_local``) is carried
with the build's own orders and equals a rebuild's.
At the fine level no local term past ``N`` is kept (pixels never read one).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..kernels.local_grid import CORNER_RADIUS
from .expansions import m2l_matrix
from .lattice import offset_parities

#: Terms of the measured error tables (more than any pass needs).
TABLE_ORDER = 24
#: Boundary points per cell side where ``truncation_errors`` samples sources and targets.
SAMPLES_PER_SIDE = 16
#: ``truncation_errors`` of every offset the passes use, as ``scripts/generate_tables.py`` measured them: arrays
#: ``offsets (k, 2)``, ``errors (k, TABLE_ORDER + 1, TABLE_ORDER + 1)`` and the ``table_order`` and
#: ``samples_per_side`` they were measured with (measuring them took 1.2-1.9 s of every process).
SHIPPED_TABLES = Path(__file__).with_name("truncation_errors.npz")
#: Share of the pixels' own truncation error (nearest offset, degree N, the fine level's strength) each
#: translation may add.  Measured on the Hilbert scenes against the direct sum at N = 8 (max over 1,500
#: to 2,048 pixels, /255): order 16 everywhere 0.022, 0.004, 0.091; share 1: 0.67 (27 offsets a level
#: each add it), 0.25: 0.064, 0.14; 0.1: 0.031, 0.08 (``tests/test_passes.py`` holds it within 2x).
ERROR_SHARE = 0.1
#: The same for the fine level's translations (no larger: measured at 4:4, 3:4, 4:6, 5:7 with N = 8, order 16
#: everywhere 0.022, 0.025, 0.0044, 0.0037 /255; fine share 1: 0.37, 0.27, 0.045, 0.035; 0.25: 0.056, 0.062,
#: 0.0075, 0.0056, for 2,600 multipole-local term pairs summed over the 40 offsets against 2,868 at 0.1).
FINE_SHARE = 0.1


def _cell_boundary(centre: complex) -> np.ndarray:
    """Points on the boundary of the unit cell around ``centre``, as complex numbers."""
    t = (np.arange(SAMPLES_PER_SIDE) + 0.5) / SAMPLES_PER_SIDE - 0.5
    half = np.full(SAMPLES_PER_SIDE, 0.5)
    sides = [t - 0.5j, half + 1j * t, -t + 0.5j, -half - 1j * t]
    return centre + np.concatenate(sides)


@lru_cache(maxsize=None)
def truncation_errors(dx: int, dy: int) -> np.ndarray:
    """``measured_truncation_errors(dx, dy)``, from ``SHIPPED_TABLES`` when it holds the offset (read-only)."""
    shipped = _shipped_tables()
    errors = shipped.get((dx, dy))
    if errors is None:
        errors = measured_truncation_errors(dx, dy)
    errors.flags.writeable = False
    return errors


@lru_cache(maxsize=1)
def _shipped_tables() -> dict[tuple[int, int], np.ndarray]:
    """``SHIPPED_TABLES`` by offset; empty when the file is missing or was measured with other constants."""
    try:
        with np.load(SHIPPED_TABLES) as data:
            if int(data["table_order"]) != TABLE_ORDER or int(data["samples_per_side"]) != SAMPLES_PER_SIDE:
                return {}
            return {(int(dx), int(dy)): errors for (dx, dy), errors in zip(data["offsets"], data["errors"])}
    except (OSError, KeyError, ValueError):
        return {}


def measured_truncation_errors(dx: int, dy: int) -> np.ndarray:
    """Largest M2L error ``e[m, q]`` at offset ``(dx, dy)`` keeping multipole terms ``<= m`` and local ``<= q``.

    In cell-size units, for a unit logarithmic source (its real part, the
    colour) and a unit dipole, over sources on the source cell's boundary and
    targets on the target cell's boundary.  ``e[m, TABLE_ORDER]`` is the
    multipole truncation alone, ``e[TABLE_ORDER, q]`` the local one.
    """
    d = complex(dx, dy)
    sources, targets = _cell_boundary(d), _cell_boundary(0j)
    k = np.arange(TABLE_ORDER + 1)
    relative = (sources - d)[:, None]
    dipole = np.where(k > 0, relative ** np.maximum(k - 1, 0), 0.0)
    logarithm = np.where(k > 0, -(relative**k) / np.maximum(k, 1), 1.0)
    exact_dipole = 1.0 / (targets[None, :] - sources[:, None])
    exact_log = np.log(targets[None, :] - sources[:, None]).real
    powers = targets[:, None] ** k
    matrix = np.asarray(m2l_matrix(d, TABLE_ORDER, 0.0))
    errors = np.empty((TABLE_ORDER + 1, TABLE_ORDER + 1))
    for m in range(TABLE_ORDER + 1):
        dipole_sums = np.cumsum((dipole[:, : m + 1] @ matrix[: m + 1])[:, None, :] * powers[None], axis=2)
        log_sums = np.cumsum((logarithm[:, : m + 1] @ matrix[: m + 1])[:, None, :] * powers[None], axis=2).real
        errors[m] = np.maximum(np.abs(dipole_sums - exact_dipole[:, :, None]).max(axis=(0, 1)),
                               np.abs(log_sums - exact_log[:, :, None]).max(axis=(0, 1)))
    return errors


def table_offsets() -> list[tuple[int, int]]:
    """The offsets ``truncation_errors`` is asked for: ``(|dx|, |dy|)`` of the passes' offsets, larger first."""
    return sorted({tuple(sorted((abs(int(dx)), abs(int(dy))), reverse=True)) for dx, dy in offset_parities()[0]})


def pixel_error(pixel_order: int) -> float:
    """Error of a unit source in the nearest member of a fine cell's list, from its local expansion of degree
    ``pixel_order`` (what the pixels make before any pass truncates)."""
    return float(truncation_errors(2, 0)[TABLE_ORDER, pixel_order])


#: Bins of a cell's sample radius (its samples' largest distance from its centre, in cell sizes) over
#: ``[0, sqrt(1/2)]``, the radii ``sample_degrees`` gives a degree for.
RADIUS_BINS = 32


@lru_cache(maxsize=None)
def sample_degrees(pixel_order: int) -> np.ndarray:
    """``(RADIUS_BINS,)``: the degree a cell's samples need when they lie within bin ``b``'s radius of its centre,
    ``(b + 1) / RADIUS_BINS * CORNER_RADIUS``, for no more error than degree ``pixel_order`` makes on its boundary.

    A cell's local expansion holds only sources outside the 3x3 cells around it, at least ``R = 1.5`` cells
    from its centre.  Within radius ``r`` of the centre its tail after degree ``k`` is at most
    ``rho^(k + 1) / ((k + 1) (1 - rho))`` for a unit logarithm and ``rho^(k + 1) / (R (1 - rho))`` for a unit
    dipole, ``rho = r / R``; each bin gets the fewest terms whose bound is within ``ERROR_SHARE`` of
    ``pixel_error(pixel_order)``, the nearest source's error on the boundary (and at most ``pixel_order``): the
    terms left out add at most what one translation of the passes may.  (Within all of it, the largest error of
    the raster against the direct sum fell only 2.6x from degree 6 to 8 on zephyr, where it had fallen 3x.)
    Samples at the cells' centres (one a cell of a raster matching the lattice) take the constant term alone.
    """
    nearest = 1.5
    rho = (np.arange(1, RADIUS_BINS + 1) / RADIUS_BINS * CORNER_RADIUS / nearest)[:, None]
    k = np.arange(pixel_order + 1)
    bound = rho ** (k + 1) / (1 - rho) * np.maximum(1 / (k + 1), 1 / nearest)
    within = bound <= ERROR_SHARE * pixel_error(pixel_order)
    degrees = np.where(within.any(axis=1), within.argmax(axis=1), pixel_order)
    degrees.flags.writeable = False
    return degrees


def tolerance(pixel_order: int, excess: int = 0) -> float:
    """Unit error each translation of a level may make for pixels of degree ``pixel_order``.

    ``excess``: the level's cells are at most ``2^excess`` times as strong as the fine level's.
    """
    return ERROR_SHARE * pixel_error(pixel_order) * 2.0**-excess


def _fewest_terms(errors: np.ndarray, limit: float) -> int:
    """The smallest index whose error is at most ``limit`` (the last if none is)."""
    below = np.flatnonzero(errors <= limit)
    return int(below[0]) if len(below) else len(errors) - 1


@lru_cache(maxsize=None)
def offset_orders(dx: int, dy: int, limit: float) -> tuple[int, int]:
    """``(m, q)``: the fewest multipole and local terms whose truncations each stay within ``limit``."""
    errors = truncation_errors(*sorted((abs(dx), abs(dy)), reverse=True))
    return _fewest_terms(errors[:, TABLE_ORDER], limit), _fewest_terms(errors[TABLE_ORDER], limit)


@dataclass(frozen=True, eq=False)
class PassOrders:
    """The highest term each M2L translation of a pass reads (multipole) and writes (local), per level.

    Attributes
    ----------
    width : int
        Highest term of the stored expansions (``Settings.propagation_order``); every order is at most this.
    multipole, local : tuple of numpy.ndarray
        Indexed by level (``None`` below 2): ``(len(offsets),)`` int, one per entry of ``offsets``.
    offsets : numpy.ndarray
        ``(k, 2)`` the offsets ``(dx, dy)`` the orders are given for (``lattice.offset_parities``).
    """

    width: int
    multipole: tuple
    local: tuple
    offsets: np.ndarray

    @property
    def levels(self) -> int:
        return len(self.multipole) - 1

    def of(self, level: int, offset: tuple[int, int]) -> tuple[int, int]:
        """``(m, q)`` of the translation at ``offset`` on ``level``."""
        row = int(np.flatnonzero((self.offsets == offset).all(axis=1))[0])
        return int(self.multipole[level][row]), int(self.local[level][row])

    def kept(self, level: int) -> int:
        """Highest term of the local expansions of ``level`` (what its translations write, and what L2L keeps)."""
        return int(self.local[level].max())

    def carried(self, level: int) -> int:
        """Highest multipole term ``level``'s cells carry: what it and every coarser level read (M2M needs it)."""
        return max(int(self.multipole[above].max()) for above in range(2, level + 1))


@lru_cache(maxsize=64)
def uniform_orders(levels: int, order: int) -> PassOrders:
    """Every translation at ``order``: the passes as they were before orders were chosen.

    Cached: the passes cache their tables by the orders' identity (47 ms of a lady_bug build when
    every build made new ones).
    """
    offsets = offset_parities()[0]
    full = np.full(len(offsets), order)
    per_level = (None, None) + (full,) * (levels - 1)
    return PassOrders(order, per_level, per_level, offsets)


@lru_cache(maxsize=64)
def pass_orders(levels: int, pixel_order: int, width: int) -> PassOrders:
    """The orders of a build for pixels of degree ``pixel_order``, capped at ``width``.

    Every coarser level gets the terms its offsets need for ``tolerance(pixel_order, 2 (levels - level))``
    (its cells at most ``4^(levels - level)`` times as strong as a fine one).  The fine level keeps the local
    terms up to ``pixel_order`` (the pixels read no more) and the multipole terms of ``fine_multipole_order``.
    """
    offsets = offset_parities()[0]
    multipole, local = [None, None], [None, None]
    for level in range(2, levels):
        limit = tolerance(pixel_order, 2 * (levels - level))
        chosen = np.array([offset_orders(int(dx), int(dy), limit) for dx, dy in offsets])
        multipole.append(np.minimum(chosen[:, 0], width))
        local.append(np.minimum(chosen[:, 1], width))
    chosen = np.array([offset_orders(int(dx), int(dy), FINE_SHARE * pixel_error(pixel_order)) for dx, dy in offsets])
    multipole.append(np.minimum(chosen[:, 0], width))
    local.append(np.minimum(chosen[:, 1], min(pixel_order, width)))
    return PassOrders(width, tuple(multipole), tuple(local), offsets)
