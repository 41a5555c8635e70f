"""Reader for Orzan's CurveSetXML diffusion curves, also inside usvg SceneXML scenes.

Two kinds of file are read:

* an Orzan ``<curve_set image_width=.. image_height=..>`` root (DOCTYPE
  ``CurveSetXML``), as written by Orzan et al.'s diffusion-curve tools;
* a usvg ``<scene image_width=.. image_height=..>`` root (DOCTYPE
  ``SceneXML``) holding ``<curve_set>`` children.  Everything else in a scene
  (``poisson_curve_set``, ``mesh_set``) is left out, and ``notes`` says so.

Conventions of an Orzan ``<curve_set>`` root
--------------------------------------------
* ``x`` is the image row and ``y`` the column, so a control point becomes the
  document point ``(float(y), float(x))``.
* Attribute ``B`` holds red and ``R`` blue; ``G`` is green.  Channels are
  0..255 (fractions accepted) and become ``value / 255`` clamped to
  ``[0, 1]``.  An optional ``A`` is the stop's alpha on the same scale
  (absent: 255, opaque).
* ``left_colors`` is the viewer's left when walking along the curve on screen,
  i.e. the model's ``left``.  (In the file's own ``(x, y)`` frame the left side
  is the tangent rotated by +90 degrees; mapping ``(x, y)`` to
  ``(column, row) = (y, x)`` is a reflection, which makes it the viewer's left
  on a y-down screen.)

Conventions of a usvg ``<scene>`` root
--------------------------------------
usvg's own reader (tobguent/small-usvg, ``Scene::readXML``) applies the swaps
above only to CurveSetXML files.  Inside a scene, ``x`` is the column, ``y``
the row, ``R`` is red, and ``left_colors`` is the tangent rotated by +90
degrees in that ``(x, y)`` frame, which on a y-down screen is the viewer's
*right*: ``left_colors`` becomes the model's ``right`` and vice versa.  (The
usvg ``ladybug.xml`` scene is Orzan's ``lady_bug.xml`` moved and scaled, with
exactly these changes.)

Common to both
--------------
* ``globalID / 10`` is a stop's position in piece units (10 per cubic piece).
  Stops may be unsorted or lie outside ``[0, k]``: the model sorts them
  (stably, so ties keep file order) and clamps them to ``[0, k]``; this reader
  makes sure every position is a finite number, so that order is well defined.
* ``best_scale value=.. globalID=..`` becomes ``BlurStop(globalID / 10, BEST_SCALE_DEVIATION * value)``:
  Orzan's blur scale read as a Gaussian's deviation in pixels (see ``BEST_SCALE_DEVIATION``).
* The ``nb_*`` counts are ignored (hand-made files get them wrong): child
  elements are counted.  ``lifetime``, ``global_len``, the extension tags
  ``weight_set``, ``weight_degree_set``, ``connects``, ``use_endcap`` and
  usvg's ``boundary="Neumann"`` on a colour set are ignored (the model has no
  equivalent yet).
* Canvas size: ``image_width`` / ``image_height`` of the root; for a scene
  the ``<scene>`` attributes win over those of its ``<curve_set>``.  A missing
  dimension defaults to 512, so a file without any size is 512x512.  A size
  must be a whole number from 1 to 32768.

Decisions on damaged content
----------------------------
* **Control points that are not 3k+1.**  No real file we know of has one (all
  Orzan samples and usvg scenes in the project's shared data have exactly 3k+1
  points per curve), so a different count, including fewer than 4 points, means
  a damaged file: loading fails with a :class:`DocumentLoadError` naming the
  curve (counted from 1) rather than silently changing its geometry.
* **Empty or missing colour sides** load as a side without stops (black, as
  the model defines); a missing blur set gives no blur stops.
* Anything else malformed -- not XML, truncated, wrong root, missing or
  non-numeric or non-finite attributes, bad canvas size, XML entities (entity
  bombs, external entities), a file above 256 MiB or one that cannot be read --
  raises exactly one :class:`DocumentLoadError` naming the file.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import Element

from ..model import BlurStop, ColorStop, DiffusionCurve, Document, limits
from ..model.limits import shortened
from .errors import DocumentLoadError
from .notes import listed
from .safe_xml import XmlRefused, parse_xml, read_bounded

MAX_CANVAS_SIZE = limits.MAX_CANVAS_SIDE
"""Largest accepted ``image_width`` / ``image_height``."""

DEFAULT_CANVAS_SIZE = 512
"""Canvas width or height used when the file does not give one."""

GLOBAL_IDS_PER_PIECE = 10.0
"""``globalID`` units per cubic piece."""

BEST_SCALE_DEVIATION = 0.4
"""The deviation (pixels) of the Gaussian a ``best_scale`` of 1 stands for.  Fitted to the one blurred
reference there is (``reference_renders/blur-ex.jpg``, lady_bug ray-traced with blur, against
``no_blur_ex.jpg`` without): in the view of both (found by fitting, 2:1 from (7.9, 68.5)), what our blur
adds matches what the reference's adds best between 0.3 (their difference least, 0.96e-3 against 1.39e-3
unblurred) and 0.5 (most correlated, 0.65); 1 overshoots (2.14e-3)."""


@dataclass(frozen=True)
class _Convention:
    """How a file's curve tags map onto the model."""

    swap_axes: bool
    swap_red_blue: bool
    swap_sides: bool


_ORZAN = _Convention(swap_axes=True, swap_red_blue=True, swap_sides=False)
_USVG_SCENE = _Convention(swap_axes=False, swap_red_blue=False, swap_sides=True)


class _FormatError(Exception):
    """Internal: what is wrong with the content (the file name is added later)."""


def load_orzan(path: str | os.PathLike, notes: list[str] | None = None) -> Document:
    """Load an Orzan CurveSetXML file or a usvg SceneXML scene.

    Parameters
    ----------
    path : str or os.PathLike
        The file to read.
    notes : list, optional
        Gets a line for what the file held that was not read (a scene's gradient meshes and Poisson curves),
        and one when it holds no curve.

    Returns
    -------
    Document
        Canvas size from the file (512x512 when it gives none) and one
        :class:`DiffusionCurve` per ``<curve>`` element, in file order.

    Raises
    ------
    DocumentLoadError
        If the file is missing, unreadable, larger than ``MAX_FILE_BYTES`` or
        malformed; the message names the file.
    """
    name = Path(path).name or os.fspath(path)
    return parse_orzan(read_bounded(path, name), name, notes)


def parse_orzan(data: bytes, name: str, notes: list[str] | None = None) -> Document:
    """Parse the bytes of an Orzan CurveSetXML file or a usvg SceneXML scene.

    Parameters
    ----------
    data : bytes
        The whole file.
    name : str
        The file name, used in error messages.
    notes : list, optional
        As for :func:`load_orzan`.

    Returns
    -------
    Document
        See :func:`load_orzan`.

    Raises
    ------
    DocumentLoadError
        If ``data`` is malformed; see the module docstring.
    """
    try:
        root = parse_xml(data)
        document = _document_from_root(root)
    except (_FormatError, XmlRefused) as error:
        raise DocumentLoadError(name, str(error)) from None
    if notes is not None:
        notes.extend(_notes_of(root, document))
    return document


def _notes_of(root: Element, document: Document) -> list[str]:
    """Lines for ``notes``: what a scene holds that the model has no equivalent of, and a file without curves."""
    lines = []
    if root.tag == "scene":
        meshes = len(root.findall("mesh_set/mesh"))
        poisson = len(root.findall("poisson_curve_set/poisson_curve"))
        left = listed(((meshes, "gradient mesh", "gradient meshes"), (poisson, "Poisson curve", None)))
        if left:
            lines.append(f"not imported: {left} (the editor draws diffusion curves alone)")
    if not document.curves:
        lines.append("the file holds no diffusion curve")
    return lines


def _document_from_root(root: Element) -> Document:
    """Dispatch on the root element: Orzan ``<curve_set>`` or usvg ``<scene>``."""
    if root.tag == "curve_set":
        convention, curve_sets, size_holders = _ORZAN, [root], [root]
    elif root.tag == "scene":
        curve_sets = root.findall("curve_set")
        convention, size_holders = _USVG_SCENE, [root, *curve_sets]
    else:
        raise _FormatError(f"the root element is <{root.tag}>, expected <curve_set> or <scene>")
    width = _canvas_size(size_holders, "image_width")
    height = _canvas_size(size_holders, "image_height")
    elements = [curve for curve_set in curve_sets for curve in curve_set.findall("curve")]
    if len(elements) > limits.MAX_CURVES:
        raise _FormatError(f"at most {limits.MAX_CURVES:,} curves are read, got {len(elements):,}")
    curves = [_parse_curve(element, index, convention) for index, element in enumerate(elements, 1)]
    document = Document(width, height, tuple(curves))
    try:
        limits.check_document(document)
    except limits.LimitError as error:
        raise _FormatError(str(error)) from None
    return document


def _canvas_size(holders: list[Element], attribute: str) -> int:
    """The first ``attribute`` found on ``holders``, checked; ``DEFAULT_CANVAS_SIZE`` if none."""
    for element in holders:
        if element.get(attribute) is not None:
            value = _number(element, attribute, f"<{element.tag}>")
            if value != int(value) or not 1 <= value <= MAX_CANVAS_SIZE:
                raise _FormatError(
                    f"canvas {attribute}={shortened(element.get(attribute))} is not a whole number "
                    f"from 1 to {MAX_CANVAS_SIZE}"
                )
            return int(value)
    return DEFAULT_CANVAS_SIZE


def _parse_curve(element: Element, index: int, convention: _Convention) -> DiffusionCurve:
    """One ``<curve>`` element as a model curve."""
    where = f"curve {index}"
    points = _control_points(element, where, convention)
    left = _color_stops(element, "left_colors_set/left_color", where, convention)
    right = _color_stops(element, "right_colors_set/right_color", where, convention)
    if convention.swap_sides:
        left, right = right, left
    blur = _blur_stops(element, where)
    try:
        return DiffusionCurve(points, left, right, blur)
    except ValueError as error:  # a safety net: the checks above should leave nothing for the model
        raise _FormatError(f"{where}: {error}") from None


def _control_points(element: Element, where: str, convention: _Convention) -> list[tuple[float, float]]:
    """The control points as document ``(x, y)``; their count must be 3k+1 with k >= 1."""
    children = element.findall("control_points_set/control_point")
    count = len(children)
    if count > limits.MAX_CURVE_CONTROL_POINTS:
        raise _FormatError(f"{where} has {count:,} control points; at most {limits.MAX_CURVE_CONTROL_POINTS:,} "
                           "are read")
    if count < 4 or (count - 1) % 3:
        raise _FormatError(
            f"{where} has {count} control points; a chain of cubic Beziers needs 3k+1 (4, 7, 10, ...)"
        )
    points = []
    for number, child in enumerate(children, 1):
        label = f"{where}, control point {number}"
        x, y = _number(child, "x", label), _number(child, "y", label)
        points.append((y, x) if convention.swap_axes else (x, y))
    return points


def _color_stops(element: Element, path: str, where: str, convention: _Convention) -> list[ColorStop]:
    """The colour stops found at ``path`` (``left_colors_set/left_color`` or the right one)."""
    tag = path.rsplit("/", 1)[1]
    stops = []
    for number, child in enumerate(_stop_elements(element, path, where), 1):
        label = f"{where}, {tag} {number}"
        red, green, blue = (_channel(child, attribute, label) for attribute in ("R", "G", "B"))
        if convention.swap_red_blue:
            red, blue = blue, red
        alpha = _channel(child, "A", label) if child.get("A") is not None else 1.0
        stops.append(ColorStop(_position(child, label), (red, green, blue), alpha))
    return stops


def _blur_stops(element: Element, where: str) -> list[BlurStop]:
    """The ``best_scale`` blur stops."""
    stops = []
    for number, child in enumerate(_stop_elements(element, "blur_points_set/best_scale", where), 1):
        label = f"{where}, best_scale {number}"
        stops.append(BlurStop(_position(child, label), BEST_SCALE_DEVIATION * _number(child, "value", label)))
    return stops


def _stop_elements(element: Element, path: str, where: str) -> list[Element]:
    """The elements at ``path``, at most ``limits.MAX_CURVE_STOPS`` of them (counted before any is read)."""
    children = element.findall(path)
    if len(children) > limits.MAX_CURVE_STOPS:
        raise _FormatError(f"{where} has {len(children):,} {path.rsplit('/', 1)[1]} stops; at most "
                           f"{limits.MAX_CURVE_STOPS:,} are read")
    return children


def _position(element: Element, label: str) -> float:
    """A stop's position in piece units, from its ``globalID``."""
    return _number(element, "globalID", label) / GLOBAL_IDS_PER_PIECE


def _channel(element: Element, attribute: str, label: str) -> float:
    """A 0..255 colour channel as a fraction clamped to ``[0, 1]``."""
    return min(max(_number(element, attribute, label) / 255.0, 0.0), 1.0)


def _number(element: Element, attribute: str, label: str) -> float:
    """A required, finite numeric attribute."""
    text = element.get(attribute)
    if text is None:
        raise _FormatError(f"{label}: attribute {attribute} is missing")
    try:
        value = float(text)
    except ValueError:
        raise _FormatError(f"{label}: {attribute}={shortened(text)} is not a number") from None
    if not math.isfinite(value):
        raise _FormatError(f"{label}: {attribute}={shortened(text)} is not a finite number")
    return value
