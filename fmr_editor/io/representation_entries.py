"""A representation as ``representation.json`` plus ``.npy`` arrays, and back.

Saving keeps what :class:`Representation` needs to render without the
boundary solve: the lattice (levels, side), the polynomial and propagation
orders, the solved segments sorted by cell (``p, q, jump, mean, on_border,
flux``), their CSR offsets ``cell_start`` and the local expansions
``local``.  Diffusion points are not stored: opening rebuilds their field
from the document with ``PointField.build`` (no solve; measured 0.1 s for
lady_bug's 64x64 lattice, 0.9 s with 100,000 points, against 8 MB more per
file at that lattice, growing fourfold per level).

Opening checks every array against the manifest before reading it (dtype,
shape, size limits relative to the canvas) and their consistency after:
finite values, booleans that are 0 or 1, ``cell_start`` starting at 0,
non-decreasing and ending at the segment count, and every segment listed in
the fine cell that holds its midpoint.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..engine import MAX_LEVELS, GaussPoints, Lattice, PointField, Representation, Segments, Settings, available_memory
from ..model import Document
from .json_checks import SchemaError, as_object, check_version, finite, required, whole

FORMAT_NAME = "fmr-editor representation"
"""Value of the ``format`` key of ``representation.json``."""

REPRESENTATION_VERSION = 1
"""The version written, and the newest one read."""

MAX_SEGMENTS_PER_PIXEL = 64
"""Segment counts above ``MAX_SEGMENTS_PER_PIXEL * width * height + MIN_SEGMENT_ALLOWANCE`` are refused."""

MIN_SEGMENT_ALLOWANCE = 1 << 16

MAX_PROPAGATION_ORDER = 60
"""As ``Settings`` allows."""

MAX_ARRAY_BYTES = 4 << 30
"""No array entry may unpack to more than this."""

MEMORY_SHARE = 0.25
"""A representation's arrays may take at most this share of the memory available (``engine.available_memory``)."""

SEGMENT_FIELDS = ("p", "q", "jump", "mean", "on_border", "flux")


class RepresentationError(ValueError):
    """Arrays that do not make a consistent representation; the message names the entry."""


@dataclass(frozen=True)
class ArrayLayout:
    """What ``representation.json`` says the arrays are.

    Attributes
    ----------
    levels : int
        Lattice depth L.
    side : float
        Side of the lattice's square, in pixels.
    order : int
        Polynomial degree used for pixels.
    propagation_order : int
        Terms of the local expansions, minus one.
    segment_count : int
        Number of solved segments.
    settings : Settings or None
        The build settings, when the saver gave them.
    """

    levels: int
    side: float
    order: int
    propagation_order: int
    segment_count: int
    settings: Settings | None

    def arrays(self) -> dict[str, tuple[str, tuple[int, ...]]]:
        """``{name: (dtype, shape)}`` of every array entry."""
        n, cells = self.segment_count, 2**self.levels
        shapes = {"p": 2, "q": 2, "jump": 3, "mean": 3, "flux": 3}
        arrays = {name: ("<f8", (n, columns)) for name, columns in shapes.items()}
        arrays["on_border"] = ("|b1", (n,))
        arrays["cell_start"] = ("<i8", (cells * cells + 1,))
        arrays["local"] = ("<c16", (cells, cells, 3, self.propagation_order + 1))
        return arrays


def entry_name(array: str, prefix: str = "") -> str:
    """The archive entry holding ``array`` of the representation under ``prefix`` (``fmr_file.field_prefix``)."""
    return f"{prefix}representation/{array}.npy"


# --- saving --------------------------------------------------------------------------------------


def describe(rep: Representation, document: Document, settings: Settings | None = None) -> tuple[dict, dict]:
    """The manifest and the arrays to save for ``rep``.

    Returns
    -------
    manifest : dict
        The JSON-ready content of ``representation.json``.
    arrays : dict of numpy.ndarray
        Little-endian, C-ordered arrays by name (see ``ArrayLayout.arrays``).

    Raises
    ------
    ValueError
        If ``rep`` was not built for ``document`` (canvas, diffusion points)
        or ``settings`` disagree with it.
    """
    if (rep.width, rep.height) != (document.width, document.height):
        raise ValueError(
            f"the representation is {rep.width}x{rep.height} but the document is {document.width}x{document.height}"
        )
    _check_points(rep, document)
    local = rep.local
    if settings is not None and local.shape[-1] < settings.propagation_order + 1:
        # the editor keeps the pixels' terms only (``Cells.local``); the file holds the propagation order's
        local = np.pad(local, [(0, 0)] * 3 + [(0, settings.propagation_order + 1 - local.shape[-1])])
    propagation_order = local.shape[-1] - 1
    if settings is not None:
        _check_settings(settings, rep.lattice.levels, rep.order, propagation_order)
    layout = ArrayLayout(
        rep.lattice.levels, float(rep.lattice.side), rep.order, propagation_order, len(rep.segments), settings
    )
    arrays = {name: getattr(rep.segments, name) for name in SEGMENT_FIELDS}
    arrays.update(cell_start=rep.cell_start, local=local)
    out = {}
    for name, (dtype, shape) in layout.arrays().items():
        array = np.ascontiguousarray(arrays[name], dtype=dtype)
        if array.shape != shape:
            raise ValueError(f"the representation's {name} has shape {array.shape}, expected {shape}")
        out[name] = array
    manifest = {
        "format": FORMAT_NAME,
        "version": REPRESENTATION_VERSION,
        "lattice": {"levels": layout.levels, "side": layout.side},
        "order": layout.order,
        "propagation_order": layout.propagation_order,
        "segment_count": layout.segment_count,
        "settings": None if settings is None else dataclasses.asdict(settings),
    }
    return manifest, out


def _check_points(rep: Representation, document: Document) -> None:
    """The representation's point field must be the document's points (it is rebuilt from them on opening)."""
    if not document.points:
        if rep.points is not None and len(rep.points.points):
            raise ValueError("the representation holds diffusion points the document does not have")
        return
    if rep.points is None:
        raise ValueError("the document has diffusion points the representation lacks")
    if not np.array_equal(_sorted_rows(rep.points.points), _sorted_rows(GaussPoints.from_points(document.points))):
        raise ValueError("the representation's diffusion points differ from the document's")
    if rep.points.tensor.shape[-1] != rep.order + 1:
        raise ValueError("the representation's point polynomials are not of its order")


def _sorted_rows(points: GaussPoints) -> np.ndarray:
    rows = np.column_stack([points.positions, points.radii, points.weights])
    return rows[np.lexsort(rows.T[::-1])]


def _check_settings(settings: Settings, levels: int, order: int, propagation_order: int) -> None:
    if settings.order != order or settings.propagation_order != propagation_order:
        raise ValueError(
            f"settings say order {settings.order} and propagation order {settings.propagation_order}; "
            f"the representation has {order} and {propagation_order}"
        )
    if settings.levels is not None and settings.levels != levels:
        raise ValueError(f"settings say {settings.levels} levels; the representation has {levels}")


# --- opening -------------------------------------------------------------------------------------


def parse_manifest(data: object, document: Document) -> ArrayLayout:
    """The layout ``representation.json`` describes, checked against ``document``'s canvas.

    Raises
    ------
    SchemaError
        If the manifest is malformed, from a newer version
        (``NewerVersionError``) or asks for arrays absurdly large for the canvas.
    """
    root = as_object(data, "the top level")
    if root.get("format") != FORMAT_NAME:
        raise SchemaError(f"format is {root.get('format')!r:.60}, expected {FORMAT_NAME!r}")
    check_version(root, "version", REPRESENTATION_VERSION, "representation format")
    canvas_side = max(document.width, document.height)
    lattice = as_object(required(root, "lattice", ""), "lattice")
    side = finite(required(lattice, "side", "lattice"), "lattice.side")
    if not canvas_side <= side <= 2 * canvas_side:
        raise SchemaError(f"lattice.side is {side!r}; for a {document.width}x{document.height} canvas it must be "
                          f"from {canvas_side} to {2 * canvas_side}")
    finest = min(MAX_LEVELS, max(2, int(math.floor(math.log2(side)))))  # cells of at least one pixel
    levels = whole(required(lattice, "levels", "lattice"), "lattice.levels", 2, finest)
    propagation_order = whole(required(root, "propagation_order", ""), "propagation_order", 0, MAX_PROPAGATION_ORDER)
    order = whole(required(root, "order", ""), "order", 0, propagation_order)
    most = MAX_SEGMENTS_PER_PIXEL * document.width * document.height + MIN_SEGMENT_ALLOWANCE
    segment_count = whole(required(root, "segment_count", ""), "segment_count", 0, most)
    settings = _settings(root.get("settings"), levels, order, propagation_order)
    layout = ArrayLayout(levels, side, order, propagation_order, segment_count, settings)
    sizes = {name: np.dtype(dtype).itemsize * math.prod(shape) for name, (dtype, shape) in layout.arrays().items()}
    for name, size in sizes.items():
        if size > MAX_ARRAY_BYTES:
            raise SchemaError(f"{entry_name(name)} would be larger than {MAX_ARRAY_BYTES >> 30} GiB")
    budget = MEMORY_SHARE * available_memory()
    if sum(sizes.values()) > budget:  # before any of it is read: a small file may declare huge arrays
        raise SchemaError(f"its arrays would take {sum(sizes.values()) / 2**30:.1f} GiB, more than the "
                          f"{budget / 2**30:.1f} GiB this machine has to spare")
    return layout


def _settings(value: object, levels: int, order: int, propagation_order: int) -> Settings | None:
    """The stored build settings (null when the saver did not give them).

    Keys that are not fields of ``Settings`` are ignored; the others must be
    of their default's kind (finite numbers for all of today's fields), and
    ``Settings`` itself checks the values.
    """
    if value is None:
        return None
    item = as_object(value, "settings")
    known = {field.name: field for field in dataclasses.fields(Settings)}
    arguments = {}
    for key, stored in item.items():
        if key not in known or stored is None:
            continue
        default = known[key].default
        if isinstance(default, (str, bool)):  # a field of another kind than numbers: the same kind
            if type(stored) is not type(default):
                raise SchemaError(f"settings.{key} must be {'a boolean' if isinstance(default, bool) else 'a string'}")
            arguments[key] = stored
        else:
            number = finite(stored, f"settings.{key}")
            arguments[key] = int(number) if type(stored) is int else number
    try:
        settings = Settings(**arguments)
        _check_settings(settings, levels, order, propagation_order)
    except (TypeError, ValueError) as error:
        raise SchemaError(f"settings: {error}") from None
    return settings


def assemble(layout: ArrayLayout, arrays: dict[str, np.ndarray], document: Document) -> Representation:
    """The representation from checked-shape ``arrays``, after checking their content.

    The document's diffusion points are rebuilt on the lattice (no solve).

    Raises
    ------
    RepresentationError
        If values are not finite, segments leave the canvas, booleans are not 0
        or 1, or ``cell_start`` does not list every segment in the cell of its midpoint.
    """
    for name, array in arrays.items():
        if array.dtype.kind in "fc" and not np.isfinite(array).all():
            raise RepresentationError(f"{entry_name(name)} holds values that are not finite")
    if (arrays["on_border"].view(np.uint8) > 1).any():
        raise RepresentationError(f"{entry_name('on_border')} holds booleans other than 0 and 1")
    lattice = Lattice(layout.levels, layout.side)
    segments = Segments(*(arrays[name] for name in SEGMENT_FIELDS))
    for name in ("p", "q"):  # segments are clipped to the canvas (a huge coordinate overflows midpoints)
        if not ((arrays[name] >= 0) & (arrays[name] <= (document.width, document.height))).all():
            raise RepresentationError(f"{entry_name(name)} holds points outside the canvas")
    _check_cells(arrays["cell_start"], segments, lattice)
    points = None
    if document.points:
        try:
            points = PointField.build(document.points, lattice, layout.order)
        except ValueError as error:
            raise RepresentationError(f"cannot rebuild the diffusion points on the lattice ({error})") from None
    local = np.ascontiguousarray(arrays["local"][..., : layout.order + 1])  # the pixels read no more (Cells.local)
    return Representation(
        document.width, document.height, lattice, segments, arrays["cell_start"], local, layout.order, {}, points,
    )


def _check_cells(cell_start: np.ndarray, segments: Segments, lattice: Lattice) -> None:
    """``cell_start`` must be CSR offsets listing each segment in the fine cell of its midpoint."""
    name = entry_name("cell_start")
    counts = np.diff(cell_start)
    if cell_start[0] != 0 or cell_start[-1] != len(segments):
        raise RepresentationError(
            f"{name} runs from {cell_start[0]} to {cell_start[-1]}, expected 0 to {len(segments)}"
        )
    if (counts < 0).any():
        raise RepresentationError(f"{name} is not non-decreasing")
    cells = lattice.cell_of(segments.midpoints)
    found = cells[:, 0] * lattice.cells_per_side + cells[:, 1]
    listed = np.repeat(np.arange(len(counts)), counts)
    if not np.array_equal(found, listed):
        wrong = int(np.flatnonzero(found != listed)[0])
        raise RepresentationError(
            f"segment {wrong} lies in cell {int(found[wrong])} but {name} lists it in cell {int(listed[wrong])}"
        )
