"""SVG export: the picture as an embedded PNG, the document's curves and points kept as hidden vector data.

Any SVG viewer shows the picture: the raster of the chosen size, laid over the whole ``viewBox`` (the
canvas, in document pixels).  Vector tools find, in a hidden group (``display="none"``), one group per
layer (bottom first, as SVG paints) holding each curve as a ``<path>`` of its cubic Bezier pieces in
document pixels, its colour stops in ``data-left`` / ``data-right`` (JSON ``[[position, [r, g, b],
alpha], ...]``) and blur stops in ``data-blur``, and each diffusion point as a ``<circle>`` of its radius
with ``data-color`` and ``data-amplitude``; a mask's items sit in a group of their own
(``data-role="mask"``).  Numbers are written as Python's ``repr``, so a path parses back to the very
control points.
"""

from __future__ import annotations

import base64
import json
import os
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

from ..model import DiffusionCurve, DiffusionPoint, Document
from .atomic import write_atomically
from .png import png_bytes

SVG = "http://www.w3.org/2000/svg"
XLINK = "http://www.w3.org/1999/xlink"


def _number(value: float) -> str:
    return repr(float(value) + 0.0)  # round-trips; + 0.0 drops a negative zero


def curve_path(curve: DiffusionCurve) -> str:
    """The SVG path data of ``curve``'s cubic pieces: ``M p0 C p1 p2 p3 C ...``."""
    points = [f"{_number(x)} {_number(y)}" for x, y in curve.control_points]
    pieces = (" ".join(points[i : i + 3]) for i in range(1, len(points), 3))
    return f"M {points[0]} " + " ".join(f"C {piece}" for piece in pieces)


def _hex(color) -> str:
    return "#" + "".join(f"{round(min(max(float(v), 0.0), 1.0) * 255):02x}" for v in color)


def _curve_element(parent: ElementTree.Element, curve: DiffusionCurve) -> None:
    stops = curve.left or curve.right
    attributes = {
        "d": curve_path(curve), "fill": "none", "stroke": _hex(stops[0].color) if stops else "#000000",
        "data-left": json.dumps([[stop.position, list(stop.color), stop.alpha] for stop in curve.left]),
        "data-right": json.dumps([[stop.position, list(stop.color), stop.alpha] for stop in curve.right]),
    }
    if curve.blur:
        attributes["data-blur"] = json.dumps([[stop.position, stop.blur] for stop in curve.blur])
    ElementTree.SubElement(parent, f"{{{SVG}}}path", attributes)


def _point_element(parent: ElementTree.Element, point: DiffusionPoint) -> None:
    x, y = point.position
    ElementTree.SubElement(parent, f"{{{SVG}}}circle", {
        "cx": _number(x), "cy": _number(y), "r": _number(point.radius), "fill": _hex(point.color),
        "data-color": json.dumps(list(point.color)), "data-amplitude": _number(point.amplitude)})


def _items(parent: ElementTree.Element, curves, points) -> None:
    for curve in curves:
        _curve_element(parent, curve)
    for point in points:
        _point_element(parent, point)


def svg_bytes(document: Document, png: bytes, size: tuple[int, int], title: str = "") -> bytes:
    """The SVG of ``document`` showing ``png`` (its picture, ``size`` = (width, height) pixels)."""
    ElementTree.register_namespace("", SVG)
    ElementTree.register_namespace("xlink", XLINK)
    width, height = document.width, document.height
    root = ElementTree.Element(f"{{{SVG}}}svg", {
        "version": "1.1", "width": str(size[0]), "height": str(size[1]), "viewBox": f"0 0 {width} {height}"})
    if title:
        ElementTree.SubElement(root, f"{{{SVG}}}title").text = title
    ElementTree.SubElement(root, f"{{{SVG}}}image", {
        "x": "0", "y": "0", "width": str(width), "height": str(height), "preserveAspectRatio": "none",
        f"{{{XLINK}}}href": "data:image/png;base64," + base64.b64encode(png).decode("ascii")})
    vectors = ElementTree.SubElement(root, f"{{{SVG}}}g", {"id": "fmr-editor-curves", "display": "none"})
    for index, layer in enumerate(document.layers):
        group = ElementTree.SubElement(vectors, f"{{{SVG}}}g", {
            "id": f"layer-{index}", "data-name": layer.name, "data-opacity": _number(layer.opacity),
            "data-visible": "true" if layer.visible else "false"})
        _items(group, layer.curves, layer.points)
        if layer.mask is not None:
            mask = ElementTree.SubElement(group, f"{{{SVG}}}g", {
                "data-role": "mask", "data-base": _number(layer.mask.base),
                "data-inverted": "true" if layer.mask.inverted else "false"})
            _items(mask, layer.mask.curves, layer.mask.points)
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ElementTree.tostring(root, encoding="unicode").encode()


def save_svg(document: Document, image: np.ndarray, path: str | os.PathLike) -> Path:
    """Write ``document``'s SVG with ``image`` (as ``png.save_png`` takes it) as its picture, atomically.

    Returns
    -------
    pathlib.Path
        The absolute path written.
    """
    path = Path(path).absolute()
    path.parent.mkdir(parents=True, exist_ok=True)
    data = svg_bytes(document, png_bytes(image), (image.shape[1], image.shape[0]), title=path.stem)
    return write_atomically(path, lambda stream: stream.write(data))
