"""Rasterising a representation to an RGB image.

Pixel (row i, column j) of the output covers ``[j, j+1] x [i, i+1]`` in
output pixels; the canvas is scaled onto the output.  With ``samples = s``
each pixel averages ``s x s`` samples at ``(j + (a + 1/2)/s, i + (b + 1/2)/s)``,
so ``s = 1`` samples the pixel centre.

Samples lie on a tensor grid (sorted ``xs`` by ``ys``), so each fine cell
holds a run of columns times a run of rows, and both fields are computed cell
by cell in compiled kernels that write into the output.  The segments' field
comes from ``subcells.subcell_field_grid``: each sample's cell local expansion
by Horner's rule (``local_grid``; no polynomial tensor is formed) plus the
closed-form integrals over the 3x3 block's segments (``grid.near_field_grid``);
cells holding many samples with segments near are cut into sub-cells
(``split_for``), each taking the block segments far from it into its
expansion and summing only the others per sample.  Diffusion points add their polynomials by Horner's rule
(``grid.far_field_grid``) and their near sum.  ``far_field_reference``
here is the numpy form of a polynomial far field (two small matrix products
per cell, batched), kept as a reference.  Of a layered picture, each layer's image is
evaluated only in the cells where it shows (``composite.hidden``): not where its mask hides it nor where
a layer above covers it; a translucent layer's image is evaluated with its alpha field as a fourth channel
(``LayerFields.carries_alpha``).  Work proceeds in bands of rows;
with one sample a pixel the bands are written into the image directly, with
more each band's samples go through one buffer and are averaged into it.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable

import numpy as np

from ..model.layer import MASK_LUMA
from .composite import Composite, LayerFields, Role, compose, hidden, scalar_reads
from .fmm.lattice import Lattice
from .fmm.orders import sample_degrees
from .kernels.grid import cells_all, fill_cells, grid_cell_runs
from .kernels.local_grid import largest_offsets
from .kernels.segment_sums import direct_sum, near_sum
from .kernels.subcells import SEPARATION, subcell_field_grid
from .points.gauss import gaussian_sum_reference
from .points.near import near_at
from .representation import Representation

#: Samples per band: bounds the memory of one step (some 50 bytes a sample).
BAND_SAMPLES = 1 << 20
#: Sub-cells of a fine cell span at least this many samples a side (``split_for``).
SUB_CELL_SAMPLES = 8
#: Precision of the near field of cells not split (``grid.near_field_grid``): float32 where its error bound
#: allows (``kernels.single``), 1.6-2x faster at 1024^2 on the Hilbert benchmark at levels 7 and 8.
NEAR_PRECISION = "single"
#: A mask is left out where its bounds settle its layers' weights (``_mask_values``) in a raster of at least this
#: many samples a cell of its lattice; in sparser ones making the bounds costs more than they save (lady_bug's
#: layered masks at 512^2, 64 samples a cell: a first raster 0.2-0.3 ms faster than without, later ones, the
#: bounds kept, 0.9 ms; at 1024^2, 256 a cell, 2.2-3.6 ms).
BOUNDED_SAMPLES = 64


def split_for(samples_per_cell: float) -> tuple[int, float]:
    """Sub-cells per side and separation for ``subcell_field_grid`` at ``samples_per_cell`` samples a cell side.

    The largest power of two leaving sub-cells of at least ``SUB_CELL_SAMPLES``
    samples a side (each expanded segment costs about as much as a few dozen
    sample pairs); without a split no segment is expanded.  Measured on the
    Hilbert benchmark at 1024^2: 32 samples a cell 4 x 4 sub-cells, 16 two.
    """
    split = 1
    while samples_per_cell / (2 * split) >= SUB_CELL_SAMPLES:
        split *= 2
    return split, (SEPARATION if split > 1 else float("inf"))


def sample_coordinates(output: int, canvas: int, samples: int) -> np.ndarray:
    """Document coordinates of the samples along one axis, ``(output * samples,)``."""
    offsets = (np.arange(samples) + 0.5) / samples
    return ((np.arange(output)[:, None] + offsets[None, :]).ravel()) * (canvas / output)


def _grouped_powers(coords: np.ndarray, cell_size: float, cells: int, order: int):
    """Powers of cell-normalised coordinates grouped by cell, padded.

    Returns
    -------
    first_cell : int
        Index of the first cell the (sorted) coordinates touch.
    powers : numpy.ndarray
        ``(cells touched, longest run, order + 1)``; padding rows are zero.
    valid : numpy.ndarray
        ``(cells touched, longest run)`` bool.
    """
    cell = np.clip(np.floor(coords / cell_size).astype(np.int64), 0, cells - 1)
    first = int(cell[0])
    cell -= first
    counts = np.bincount(cell)
    longest = int(counts.max())
    slot = np.arange(len(coords)) - np.repeat(np.cumsum(counts) - counts, counts)
    local = coords / cell_size - (cell + first + 0.5)
    powers = np.zeros((len(counts), longest, order + 1))
    powers[cell, slot] = local[:, None] ** np.arange(order + 1)
    valid = np.zeros((len(counts), longest), bool)
    valid[cell, slot] = True
    return first, powers, valid


def far_field_reference(poly: np.ndarray, xs: np.ndarray, ys: np.ndarray, cell_size: float) -> np.ndarray:
    """Cell polynomials evaluated on the tensor grid ``ys x xs``, ``(len(ys), len(xs), 3)``.

    Plain numpy; ``rasterise`` uses the compiled ``grid.far_field_grid``.

    Parameters
    ----------
    poly : numpy.ndarray
        ``(n, n, 3, p + 1, p + 1)`` coefficients of ``xi^i eta^j``.
    xs, ys : numpy.ndarray
        Sorted sample coordinates.
    """
    n, order = poly.shape[0], poly.shape[-1] - 1
    x0, px, vx = _grouped_powers(xs, cell_size, n, order)
    y0, py, vy = _grouped_powers(ys, cell_size, n, order)
    coeffs = poly[y0 : y0 + len(py), x0 : x0 + len(px)]
    # partial[Y, X, c, i, b] = sum_j coeffs[Y, X, c, i, j] eta[Y, b]^j
    partial = coeffs @ py[:, None, None].swapaxes(-1, -2)
    # values[Y, X, c, a, b] = sum_i xi[X, a]^i partial[Y, X, c, i, b]
    values = px[None, :, None] @ partial
    grid = values.transpose(0, 4, 1, 3, 2).reshape(len(py) * py.shape[1], len(px) * px.shape[1], 3)
    return grid[vy.ravel()][:, vx.ravel()]


def _average_blocks(values: np.ndarray, samples: int) -> np.ndarray:
    """Means of ``samples x samples`` blocks, by whole-row additions (``mean`` over two axes is slow)."""
    rows, cols, channels = values.shape[0] // samples, values.shape[1] // samples, values.shape[2]
    by_rows = values.reshape(rows, samples, cols * samples * channels)
    row_sum = by_rows[:, 0].copy()
    for a in range(1, samples):
        row_sum += by_rows[:, a]
    by_columns = row_sum.reshape(rows, cols, samples, channels)
    total = by_columns[:, :, 0].copy()
    for b in range(1, samples):
        total += by_columns[:, :, b]
    total *= 1.0 / samples**2
    return total


def rasterise(
    rep: Representation | Composite,
    width: int | None = None,
    height: int | None = None,
    samples: int = 3,
    method: str = "fmr",
    order: int | None = None,
    progress: Callable[[str, float], None] | None = None,
    coverage: bool = False,
) -> np.ndarray:
    """Render ``rep`` to an image.

    Parameters
    ----------
    rep : Representation or Composite
        One diffusion image, or layers composed sample by sample (``composite.compose``), each carrying a
        blur field blurred by it (``blur.rasterise_blurred``).
    width, height : int, optional
        Output size; defaults to the canvas size.  One alone keeps the aspect ratio.
    samples : int
        ``samples x samples`` supersampling per pixel.
    method : {"fmr", "direct"}
        ``"direct"`` sums the boundary integral over every segment and every
        diffusion point's Gaussian (slow; the reference for checking the FMR).
    order : int, optional
        Polynomial degree for the far field; defaults to ``rep.order``.
    progress : callable, optional
        Called as ``progress("rasterise", fraction)``.
    coverage : bool
        Add a fourth channel: the picture's coverage (``composite.compose``; 1 for a representation).

    Returns
    -------
    numpy.ndarray
        ``(height, width, 3)`` float64: a representation's values not clamped, a composite's in [0, 1] (its
        colour over black); ``(height, width, 4)`` with ``coverage``.
    """
    if isinstance(rep, Composite) and any(layer.blur is not None for layer in rep.shown):
        from .blur import rasterise_blurred

        return rasterise_blurred(rep, width, height, samples, method, order, coverage, progress)
    width, height = output_size(rep.width, rep.height, width, height)
    if samples < 1:
        raise ValueError("samples must be at least 1")
    if method not in ("fmr", "direct"):
        raise ValueError(f"unknown method {method!r}; use 'fmr' or 'direct'")
    xs = sample_coordinates(width, rep.width, samples)
    ys = sample_coordinates(height, rep.height, samples)
    density = min(len(xs) / rep.width, len(ys) / rep.height)  # samples a document pixel
    channels = 4 if coverage else 3
    image = np.empty((height, width, channels))
    held = 1 + (len(_weighing(rep)) if isinstance(rep, Composite) else 0)  # fields of a band held at once
    band = max(1, BAND_SAMPLES // (len(xs) * samples * held))
    buffer = None if samples == 1 else np.empty((band * samples, len(xs), channels))
    for row in range(0, height, band):
        rows = slice(row, min(row + band, height))
        band_ys = ys[rows.start * samples : rows.stop * samples]
        target = image[rows] if samples == 1 else buffer[: len(band_ys)]

        def field(source: Representation, out: np.ndarray | None = None, skip: np.ndarray | None = None,
                  alpha: Representation | None = None, scalar: np.ndarray | None = None) -> np.ndarray:
            if scalar is not None and method == "fmr" and not len(source.near[0].p):
                return _scalar_points(source, order, xs, band_ys, scalar, skip)
            out = np.empty((len(band_ys), len(xs), 3 if alpha is None else 4)) if out is None else out
            if method == "direct":
                out[..., :3] = _direct_samples(source, xs, band_ys)
                if alpha is not None:
                    out[..., 3] = _direct_samples(alpha, xs, band_ys)[..., 0]
                return out
            _fmr_samples(source, order, xs, band_ys, ys, density, out, skip, alpha)
            return out

        if isinstance(rep, Composite):
            composed = _composed(rep, field, xs, band_ys, coverage, bounded=method == "fmr" and order is None,
                                 out=None if coverage else target)
            if coverage:
                target[...] = composed
        elif coverage:
            target[..., :3] = field(rep)
            target[..., 3] = 1.0
        else:
            field(rep, target)
        if samples > 1:
            image[rows] = _average_blocks(target, samples)
        if progress:
            progress("rasterise", rows.stop / height)
    return image


def _composed(composite: Composite, field: Callable, xs: np.ndarray, ys: np.ndarray, coverage: bool,
              bounded: bool = True, out: np.ndarray | None = None) -> np.ndarray:
    """``compose`` of the grid ``ys x xs``, each layer's image evaluated only in the cells where it can show
    (``composite.hidden``): a layer under a mask that hides it there, or under a layer that covers it, costs
    nothing there.  ``field(rep, skip=cells, alpha=alpha, scalar=w)`` evaluates a representation but in ``cells``,
    an alpha field of its segments as its fourth channel, and, of diffusion points alone, ``w . colour`` only.

    The masks and alpha fields (``_weighing``) are evaluated once and held to the end; each other image when
    ``compose`` reads it.  A translucent layer's alpha field made of its image's segments
    (``LayerFields.carries_alpha``) is evaluated with its image, in one pass of four channels (the segments'
    integrals shared), which ``compose`` reads for both; not where another layer shows the same image, which
    would read that image's values too.  A mask or alpha field of diffusion points alone (a soft mask) is
    evaluated in the one channel it is read through (``composite.scalar_reads``), a third of its work.  With
    ``bounded`` (``field`` the FMR's), a mask is not evaluated in the cells where its bounds settle the weights of
    the layers it masks (``_mask_values``), in rasters of ``BOUNDED_SAMPLES`` a cell of it.  ``out``: where
    ``compose`` writes the colours, and where the bottom layer's image is evaluated, to be blended in place (a
    flat picture at 1024^2: no second 24 MB image and its pages); not where another layer shows the same image,
    nor where it is held (a mask or alpha field of another layer, or evaluated with its alpha as a fourth channel).
    """
    held: dict[int, np.ndarray] = {}
    shows = Counter(id(layer.image) for layer in composite.shown)
    carried = {id(layer.alpha): layer.image for layer in composite.shown
               if shows[id(layer.image)] == 1 and layer.carries_alpha}
    scalars = scalar_reads(composite)
    masking: dict[int, list[LayerFields]] = {}  # the layers each mask read as one is the mask of
    per_pixel = len(xs) / composite.width
    for layer in composite.shown:
        if (bounded and layer.masked and scalars.get(id(layer.mask)) is MASK_LUMA
                and (layer.mask.lattice.cell_size * per_pixel) ** 2 >= BOUNDED_SAMPLES):
            masking.setdefault(id(layer.mask), []).append(layer)

    def weights_of(source: Representation) -> np.ndarray:
        if id(source) not in held:
            image = carried.get(id(source))
            if image is not None:
                held[id(source)] = field(image, alpha=source)
            elif id(source) in masking:
                held[id(source)] = _mask_values(source, masking[id(source)], field, xs, ys)
            else:
                held[id(source)] = field(source, scalar=scalars.get(id(source)))
            if image is not None:
                held[id(image)] = held[id(source)]
        return held[id(source)]

    shape = (len(ys), len(xs))
    unseen: dict[int, tuple[Representation, np.ndarray]] = {}  # an image two layers show: where neither does
    for layer, where in zip(composite.shown, hidden(composite, weights_of, len(ys) * len(xs))):
        image = layer.image
        unseen[id(image)] = image, where & unseen[id(image)][1] if id(image) in unseen else where
    skips = {key: hidden_cells(where.reshape(shape), xs, ys, image.lattice) for key, (image, where) in unseen.items()
             if where.any()}

    weighing = {id(rep) for rep in _weighing(composite)}
    bottom = composite.shown[0].image if out is not None and composite.shown else None

    def values(source: Representation) -> np.ndarray:
        if id(source) in held:  # a mask or alpha field two layers read stays for the second
            return held[id(source)] if id(source) in weighing else held.pop(id(source))
        if source is bottom and shows[id(source)] == 1:
            return field(source, out=out, skip=skips.get(id(source)))
        return field(source, skip=skips.get(id(source)))

    return compose(composite, values, shape + (3,), coverage, out)


def _mask_values(mask: Representation, layers: list[LayerFields], field: Callable, xs: np.ndarray,
                 ys: np.ndarray) -> np.ndarray:
    """``field(mask, scalar=MASK_LUMA)`` on the grid ``ys x xs``, but in the cells where the mask's bounds settle
    the weight of each of ``layers`` (``LayerFields.settled``): there its luminance at the cell's centre, which
    ``compose`` and ``hidden`` weigh as its values.  Away from its edges a mask is 0 or 1 to within 1e-7, so
    most of a sharp mask is settled by its expansions' sizes alone."""
    cells = np.logical_and.reduce([layer.settled for layer in layers])
    values = field(mask, skip=cells, scalar=MASK_LUMA)
    centre = mask.scalar_bounds(MASK_LUMA)[0]
    fill_cells(values, cells, centre, xs, ys, mask.lattice.cell_size)  # every channel: the luminance weights sum to 1
    return values


def _weighing(composite: Composite) -> tuple[Representation, ...]:
    """The masks and alpha fields that weigh the layers ``composite`` shows (read twice: ``_composed``)."""
    return tuple(rep for layer in composite.shown for role, rep in layer.read if role is not Role.IMAGE)


def hidden_cells(hidden_samples: np.ndarray, xs: np.ndarray, ys: np.ndarray, lattice: Lattice) -> np.ndarray:
    """``(2^L, 2^L)`` bool: the cells of ``lattice`` all of whose samples of the grid ``ys x xs`` are
    ``hidden_samples (len(ys), len(xs))`` (and those with none)."""
    n, size = lattice.cells_per_side, lattice.cell_size
    return cells_all(hidden_samples, grid_cell_runs(xs, size, n), grid_cell_runs(ys, size, n))


def _fmr_samples(rep: Representation, order: int | None, xs: np.ndarray, ys: np.ndarray, whole_ys: np.ndarray,
                 density: float, out: np.ndarray, skip: np.ndarray | None = None,
                 alpha: Representation | None = None) -> None:
    """The FMR on the grid ``ys x xs`` into ``out (len(ys), len(xs), 3 or 4)``: far field, near segments and points.

    ``whole_ys`` and ``density``: the rows and the samples a document pixel of the whole raster, of which this
    is a band (its sub-cells and its cells' far-field degrees are the whole's).  ``skip``: cells whose samples
    are not needed (``subcell_field_grid``'s: finite, not their field).  ``alpha``: an alpha field of ``rep``'s
    segments (``LayerFields.carries_alpha``), evaluated with it as a fourth channel of ``out``.
    """
    (seg, cell_start), lattice = rep.near, rep.lattice
    order = rep.order if order is None else order
    split, separation = split_for(lattice.cell_size * density)
    n, size = lattice.cells_per_side, lattice.cell_size
    offsets = largest_offsets(xs, size, n), largest_offsets(whole_ys, size, n)
    centred = rep.centres is not None or all(np.any(axis == 0.0) for axis in offsets)  # samples on cell centres
    centres = rep.centre_values if centred else None
    if alpha is None:
        flux, jump, tables, fourth = seg.flux, seg.jump, rep.near_tables, None
        bounds = rep.near_bounds if split == 1 else None
    else:
        flux, jump, tables, bounds = rep.joined_with(alpha)
        fourth = alpha.local, alpha.centre_values if centred else None
    if len(seg.p):
        subcell_field_grid(rep.local, order, xs, ys, size, cell_start, seg.p, seg.q, flux, jump, split=split,
                           separation=separation, out=out, tables=tables, precision=NEAR_PRECISION,
                           degrees=sample_degrees(order), offsets=offsets, centres=centres, skip=skip,
                           bounds=bounds, fourth=fourth)
    else:  # no segment carries anything (``Representation.near``): nor do the expansions they make
        out[...] = 0.0
    if rep.points is not None and alpha is None:
        rep.points.add_grid(order, xs, ys, out)
    elif rep.points is not None:  # the points' kernels are of three channels; the alpha has none of its own
        colour = np.zeros(out.shape[:2] + (3,))
        rep.points.add_grid(order, xs, ys, colour)
        out[..., :3] += colour


def _scalar_points(rep: Representation, order: int | None, xs: np.ndarray, ys: np.ndarray,
                   scalar: np.ndarray, skip: np.ndarray | None = None) -> np.ndarray:
    """``(len(ys), len(xs), 1)``: ``scalar . colour`` of a field of diffusion points alone (no ``near`` segments) on
    the grid ``ys x xs``, a third of the work of its colour; 0 in the cells where ``skip``."""
    out = np.zeros((len(ys), len(xs), 1))
    if rep.points is not None:
        rep.points.add_grid(rep.order if order is None else order, xs, ys, out, scalar, skip)
    return out


def _direct_samples(rep: Representation, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """The direct sums over every segment and point on the grid ``ys x xs`` (the reference)."""
    seg = rep.segments
    targets = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1).reshape(-1, 2)
    values = direct_sum(targets, seg.p, seg.q, seg.flux, seg.jump)
    if rep.points is not None:
        p = rep.points.points
        values += gaussian_sum_reference(targets, p.positions, p.radii, p.weights)
    return values.reshape(len(ys), len(xs), 3)


def output_size(canvas_width: int, canvas_height: int, width: int | None, height: int | None) -> tuple[int, int]:
    """Output size: the canvas size, or scaled to keep the aspect ratio when one side is given."""
    if width is None and height is None:
        return canvas_width, canvas_height
    if width is None:
        width = max(1, round(height * canvas_width / canvas_height))
    elif height is None:
        height = max(1, round(width * canvas_height / canvas_width))
    if width < 1 or height < 1:
        raise ValueError("output width and height must be positive")
    return int(width), int(height)


def evaluate_points(rep: Representation | Composite, points: np.ndarray, order: int | None = None,
                    coverage: bool = False) -> np.ndarray:
    """The FMR colour at arbitrary ``points (m, 2)``, ``(m, 3)`` (not clamped); of a composite, its layers composed
    (``composite.compose``: in [0, 1]); with ``coverage``, ``(m, 4)``, the picture's coverage after the colour.

    Zero outside the canvas.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if isinstance(rep, Composite):
        values = compose(rep, lambda source: evaluate_points(source, points, order), (len(points), 3), coverage)
        inside = (points >= 0).all(axis=1) & (points[:, 0] <= rep.width) & (points[:, 1] <= rep.height)
        return np.where(inside[:, None], values, 0.0)  # transforms and mask bases make no colour out there
    lattice, (seg, cell_start) = rep.lattice, rep.near
    cells = lattice.cell_of(points)
    occupied, which = np.unique(cells[:, 0] * lattice.cells_per_side + cells[:, 1], return_inverse=True)
    poly = rep.polynomials(order, np.divmod(occupied, lattice.cells_per_side))[which]  # the points' cells only
    local = points / lattice.cell_size - (cells[:, ::-1] + 0.5)
    degrees = np.arange(poly.shape[-1])
    xi, eta = local[:, 0:1] ** degrees, local[:, 1:2] ** degrees
    far = np.einsum("mcij,mi,mj->mc", poly, xi, eta)
    near = near_sum(points, lattice.cells_per_side, lattice.cell_size, cell_start, seg.p, seg.q, seg.flux, seg.jump,
                    tables=rep.near_tables)
    if rep.points is not None:
        near += near_at(rep.points.near, points)
    inside = (points >= 0).all(axis=1) & (points[:, 0] <= rep.width) & (points[:, 1] <= rep.height)
    values = np.concatenate([far + near, np.ones((len(points), 1))], axis=1) if coverage else far + near
    return np.where(inside[:, None], values, 0.0)
