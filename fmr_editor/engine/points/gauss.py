"""Diffusion points as Gaussian sums: packed input, error rules and plain references (docs/design.md section 4).

A point ``i`` adds ``w_i exp(-|x - x_i|^2 / r_i^2)`` (``w_i`` = amplitude times
colour, three channels).  About a centre ``c`` with ``s = (x_i - c) / r`` and
``xi = (x - c) / l`` (``l`` the cell size, ``rho = l / r``), per axis

    exp(-(rho xi - s)^2) = sum_n u_n(s) xi^n,   u_n = h_n(s) rho^n / n!,
    u_0 = e^(-s^2),  u_1 = 2 s rho u_0,  u_(n+1) = (2 s rho u_n - 2 rho^2 u_(n-1)) / (n + 1),

the Hermite functions' recurrence with the scaling folded in.  A point's
polynomial in a cell is ``w u(s_x) (x) u(s_y)``: rank one per channel.

**Error budget, per point.**  Each point is represented to within ``tolerance``
(absolute) everywhere:

- *Cutoff*: a point reaches the cells whose row and column intervals both
  come nearer than ``R = r sqrt(ln(A / tolerance))`` (``A = max |w|``; a
  square of cells, separable, so the batch build is matrix products); beyond
  them it is below ``tolerance``.  They lie within ``ceil(R / l)`` cells of
  its own (docs/design.md section 4).
- *Truncation*: keeping degrees ``<= P`` in each of ``xi, eta`` on
  ``|xi|, |eta| <= 1/2`` errs by at most ``e1 (2 + e1)`` times ``A``, with ``e1``
  the 1-D error ``max |exp(-(t - s)^2) - sum_(n<=P) h_n(s) t^n / n!|`` over all
  ``s`` and ``|t| <= rho / 2``.  ``e1`` is *measured* (``truncation_error``: a
  dense sampling of ``s`` and ``t``), which gives the largest ``rho`` a point
  may use (``max_cell_ratio``).  Measured ``e1`` (P: at rho 0.5, 1, 1.5, 2):
  8: 7e-8, 3e-5, 1e-3, 2e-2; 12: 8e-12, 6e-8, 1e-5, 5e-4; 16: 8e-16, 6e-11,
  6e-8, 8e-6.
- *Grids*: a point is expanded on the coarsest grid (cells ``m`` fine cells
  wide, ``m`` = 1, 2, 3, 4, 6, 8, 12, ...) whose cells are at most
  ``max_cell_ratio * r`` wide, so it reaches a bounded number of cells
  whatever its radius (means measured per grid: 70-190 at P = 8, 25-50 at
  P = 12), and the polynomial is carried exactly (a change of variable)
  down to the fine cells.  *Near points*, for which even a fine cell is too wide,
  are evaluated exactly (``near``): with ``tolerance`` 1e-5 and
  ``A = 1``, radii below 1.27 fine cells at P = 8, 0.72 at P = 12, 0.52 at 16.

The error of a pixel is at most ``tolerance`` times the number of points
reaching it, and in practice far less: the cutoff tails add up (all of one
sign) to at most about ``tolerance / 5`` times the local value, the
truncation errors mostly cancel.  Measured: 1e5 points of radii 0.5-200 px
over 1024 px (values around 430, up to 520) err by 8.7e-4 = 0.22/255 at
``tolerance`` 1e-5 (P = 8 or 12), by 7.6e-5 at 1e-6 (P = 12); 1,000 points over
256 px (values up to 62) by 3.4e-5.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ...model.point import DiffusionPoint
from ..fmm.lattice import Lattice


@dataclass(frozen=True)
class PointSettings:
    """How diffusion points become cell polynomials.

    Parameters
    ----------
    order : int
        Degree ``P`` in each of ``xi, eta``: the tensor is ``(P + 1, P + 1)`` a
        cell and channel.  8 matches the curves' default; 12 builds about as
        fast, makes far fewer near points, and costs twice as much a sample.
    tolerance : float
        Largest error of one point anywhere (absolute, in colour units).  1e-5
        keeps 1e5 overlapping points within 0.22/255 (module docstring).
    """

    order: int = 8
    tolerance: float = 1e-5

    def __post_init__(self) -> None:
        if not 1 <= self.order <= 24:
            raise ValueError("order must be between 1 and 24")
        if not 0.0 < self.tolerance < 1.0:
            raise ValueError("tolerance must be in (0, 1)")


@dataclass(frozen=True, eq=False)
class GaussPoints:
    """Diffusion points packed as arrays: the engine's model-free input.

    Attributes
    ----------
    positions : numpy.ndarray
        ``(k, 2)`` centres (x, y) in pixels.
    radii : numpy.ndarray
        ``(k,)`` radii, positive.
    weights : numpy.ndarray
        ``(k, 3)`` amplitude times colour.
    """

    positions: np.ndarray
    radii: np.ndarray
    weights: np.ndarray

    def __post_init__(self) -> None:
        positions = np.ascontiguousarray(self.positions, dtype=np.float64).reshape(-1, 2)
        radii = np.ascontiguousarray(self.radii, dtype=np.float64).reshape(-1)
        weights = np.ascontiguousarray(self.weights, dtype=np.float64).reshape(-1, 3)
        if not len(positions) == len(radii) == len(weights):
            raise ValueError("positions, radii and weights must have the same length")
        if not (np.isfinite(positions).all() and np.isfinite(weights).all() and np.isfinite(radii).all()):
            raise ValueError("diffusion points must be finite")
        if (radii <= 0).any():
            raise ValueError("radii must be positive")
        for name, value in (("positions", positions), ("radii", radii), ("weights", weights)):
            object.__setattr__(self, name, value)

    @classmethod
    def from_points(cls, points: Iterable[DiffusionPoint]) -> GaussPoints:
        """Pack model points."""
        points = list(points)
        return cls(
            np.array([p.position for p in points], dtype=np.float64).reshape(-1, 2),
            np.array([p.radius for p in points], dtype=np.float64),
            np.array([np.multiply(p.amplitude, p.color) for p in points], dtype=np.float64).reshape(-1, 3),
        )

    def __len__(self) -> int:
        return len(self.radii)

    def take(self, index) -> GaussPoints:
        """The points at ``index`` (an index array or boolean mask)."""
        return GaussPoints(self.positions[index], self.radii[index], self.weights[index])

    def negated(self) -> GaussPoints:
        """The same points with opposite weights: adding them removes the originals."""
        return GaussPoints(self.positions, self.radii, -self.weights)

    @property
    def peaks(self) -> np.ndarray:
        """``(k,)`` largest absolute weight ``A`` of each point."""
        return np.abs(self.weights).max(axis=1) if len(self) else np.zeros(0)


def gaussian_sum_reference(targets: np.ndarray, positions: np.ndarray, radii: np.ndarray,
                           weights: np.ndarray, block: int = 1 << 17) -> np.ndarray:
    """The direct sum ``sum_i w_i exp(-|x - x_i|^2 / r_i^2)`` at ``targets (m, 2)``; ``(m, 3)``."""
    targets = np.asarray(targets, dtype=np.float64).reshape(-1, 2)
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 2)
    inverse = 1.0 / np.asarray(radii, dtype=np.float64) ** 2
    weights = np.asarray(weights, dtype=np.float64).reshape(-1, 3)
    out = np.zeros((len(targets), 3))
    step = max(1, block // max(1, len(positions)))
    for start in range(0, len(targets), step):
        t = targets[start : start + step]
        d2 = np.subtract.outer(t[:, 0], positions[:, 0])
        d2 *= d2
        dy = np.subtract.outer(t[:, 1], positions[:, 1])
        dy *= dy
        d2 += dy
        d2 *= -inverse
        np.maximum(d2, -700.0, out=d2)  # exp's underflow path is 10x slower; exp(-700) is 1e-304
        out[start : start + step] = np.exp(d2, out=d2) @ weights
    return out


def scaled_hermite(s: np.ndarray, rho: np.ndarray, order: int) -> np.ndarray:
    """``u_n(s) = h_n(s) rho^n / n!`` for ``n = 0..order`` by the recurrence; ``(..., order + 1)``."""
    s, rho = np.broadcast_arrays(np.asarray(s, dtype=np.float64), np.asarray(rho, dtype=np.float64))
    u = np.empty(s.shape + (order + 1,))
    u[..., 0] = np.exp(-s * s)
    if order >= 1:
        u[..., 1] = 2.0 * s * rho * u[..., 0]
    for n in range(1, order):
        u[..., n + 1] = (2.0 * s * rho * u[..., n] - 2.0 * rho * rho * u[..., n - 1]) / (n + 1)
    return u


#: Ratios ``rho = l / r`` at which ``truncation_error`` is measured (geometric, 3% apart).
RHO_GRID = np.geomspace(0.05, 8.0, 172)


@lru_cache(maxsize=None)
def truncation_error(order: int) -> np.ndarray:
    """Measured 1-D truncation error ``e1`` at each ``RHO_GRID`` ratio, made non-decreasing.

    ``s`` is sampled every 0.01 on ``[0, 12]`` (the error is unchanged when
    ``s`` and ``t`` both change sign, and it decays like ``exp(-s^2 / 2)``),
    ``t`` at 33 points of ``[-rho/2, rho/2]`` including both ends.  Cached;
    some 0.2 s the first call for an order.
    """
    s = np.arange(0.0, 12.0 + 1e-9, 0.01)
    xi = np.linspace(-0.5, 0.5, 33)  # t = rho xi
    powers = xi[None, :] ** np.arange(order + 1)[:, None]
    u = scaled_hermite(s[None, :], RHO_GRID[:, None], order)
    # einsum: OpenBLAS threads these thin products badly here (4 ms against 1 ms)
    series = np.einsum("rsn,nt->rst", u, powers)
    exact = np.exp(-(RHO_GRID[:, None, None] * xi[None, None, :] - s[None, :, None]) ** 2)
    return np.maximum.accumulate(np.abs(series - exact).max(axis=(1, 2)))


def max_cell_ratio(order: int, relative_tolerance: np.ndarray) -> np.ndarray:
    """Largest ``l / r`` whose 2-D truncation error ``e1 (2 + e1)`` is within ``relative_tolerance``.

    0 where no measured ratio qualifies.
    """
    e1 = truncation_error(order)
    e2 = e1 * (2.0 + e1)
    count = np.searchsorted(e2, np.asarray(relative_tolerance, dtype=np.float64), side="right")
    return np.where(count > 0, RHO_GRID[np.maximum(count - 1, 0)], 0.0)


def cutoff_radii(points: GaussPoints, tolerance: float) -> np.ndarray:
    """Reach ``R = r sqrt(ln(A / tolerance))`` of each point; 0 when ``A <= tolerance`` (it is dropped)."""
    ratio = points.peaks / tolerance
    return points.radii * np.sqrt(np.log(np.maximum(ratio, 1.0)))


def grid_ratios(cells_per_side: int) -> np.ndarray:
    """Cell ratios of the coarse grids points may be expanded on: ``2^a`` and ``3 * 2^a`` up to the lattice.

    A grid of ratio ``m`` has cells ``m`` fine cells wide, aligned with the
    lattice's origin, so each fine cell lies in exactly one of its cells.
    Ratios at most 1.5 apart waste less than powers of two alone (about 20%
    fewer cells a point, measured on radii spread over 8-200 px).
    """
    ratios = {1}
    m = 2
    while m <= cells_per_side:
        ratios.add(m)
        if 3 * m // 2 <= cells_per_side:
            ratios.add(3 * m // 2)
        m *= 2
    return np.array(sorted(ratios), dtype=np.int64)


def expansion_ratios(points: GaussPoints, lattice: Lattice, settings: PointSettings) -> np.ndarray:
    """Grid ratio of each point's expansion: the largest with cells ``<= max_cell_ratio * r`` wide.

    0 marks *near points* (even fine cells are too wide; evaluated exactly)
    and -1 *dropped points* (``A <= tolerance``: below tolerance everywhere).
    """
    peaks = points.peaks
    with np.errstate(divide="ignore", over="ignore"):  # a zero or subnormal peak: dropped below
        rho = max_cell_ratio(settings.order, settings.tolerance / peaks)
    widest = rho * points.radii / lattice.cell_size  # in fine cells
    ratios = grid_ratios(lattice.cells_per_side)
    index = np.searchsorted(ratios, widest, side="right") - 1
    chosen = np.where(index >= 0, ratios[np.maximum(index, 0)], 0)
    return np.where(peaks <= settings.tolerance, -1, chosen)


def cell_range(coordinate: np.ndarray, reach: np.ndarray, size: float, count: int) -> tuple[np.ndarray, np.ndarray]:
    """First and last cell (inclusive) along an axis whose interval ``[k size, (k+1) size]`` is nearer than ``reach``.

    Clipped to ``[0, count)``; empty (first > last) when none is.  A point's
    cells are the product of its row and column ranges (the square rule: the
    excluded cells are at least ``reach`` away along one axis).
    """
    first = np.floor((coordinate - reach) / size).astype(np.int64)
    last = np.ceil((coordinate + reach) / size).astype(np.int64) - 1
    return np.maximum(first, 0), np.minimum(last, count - 1)


def changed_cells(points: GaussPoints, lattice: Lattice, settings: PointSettings) -> np.ndarray:
    """Fine cells each point's contribution touches, as rectangles ``(k, 4)``: rows ``[a, b)``, columns ``[c, d)``.

    A polynomial point changes every fine cell below its grid cells (adding or
    removing it adds its delta exactly there); a near point joins the near
    lists of its own cells.  Dropped points change nothing (``a == b``).
    """
    n = lattice.cells_per_side
    ratios = expansion_ratios(points, lattice, settings)
    reach = cutoff_radii(points, settings.tolerance)
    m = np.maximum(ratios, 1)
    size = m * lattice.cell_size
    out = np.zeros((len(points), 4), np.int64)
    for axis, (lo, hi) in ((1, (0, 1)), (0, (2, 3))):
        first, last = cell_range(points.positions[:, axis], reach, size, -(-n // m))
        out[:, lo], out[:, hi] = np.minimum(first * m, n), np.minimum((last + 1) * m, n)
    out[:, 1] = np.maximum(out[:, 1], out[:, 0])
    out[:, 3] = np.maximum(out[:, 3], out[:, 2])
    out[ratios < 0] = 0
    return out


def shift_matrices(ratio: int, order: int) -> np.ndarray:
    """``S[a]`` maps coarse-cell coefficients to those of the ``a``-th of ``ratio`` fine cells along an axis.

    With ``d = (a + 1/2) / ratio - 1/2`` the coarse ``xi_c = xi_f / ratio + d``, so
    ``S[a][q, i] = binom(i, q) d^(i - q) ratio^(-q)``; ``(ratio, order + 1, order + 1)``.
    """
    n = np.arange(order + 1)
    binom = np.array([[math.comb(i, q) for i in n] for q in n], dtype=np.float64)
    d = (np.arange(ratio) + 0.5) / ratio - 0.5
    power = np.where(n[None, :] >= n[:, None], n[None, :] - n[:, None], 0)
    return binom[None] * d[:, None, None] ** power[None] * float(ratio) ** -n[None, :, None]
