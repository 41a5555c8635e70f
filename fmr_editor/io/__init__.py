"""Reading and writing documents.  No Qt, no OpenGL."""

from __future__ import annotations

import os
from pathlib import Path

from ..engine import LiveStack, Progress, Role, Settings
from ..model import Document
from .errors import DocumentLoadError
from .fmr_file import FmrFile, load_fmr, save_fmr
from .orzan import load_orzan, parse_orzan
from .png import save_png
from .svg_export import save_svg
from .svg_import import load_svg

__all__ = [
    "DocumentLoadError", "FmrFile", "load_document", "load_fmr", "load_orzan", "load_svg", "open_live", "parse_orzan",
    "save_fmr", "save_picture",
]


def load_document(path: str | os.PathLike, notes: list[str] | None = None) -> Document:
    """Load a document, choosing the reader by the file's suffix.

    Parameters
    ----------
    path : str or os.PathLike
        ``.fmr`` (any case) is read as the native format (its document only;
        use :func:`load_fmr` for the representation too); ``.xml`` as Orzan
        CurveSetXML or usvg SceneXML; ``.svg`` as SVG (:func:`load_svg`: its
        paths and shapes become curves).
    notes : list, optional
        Gets a line for what the file held that was not imported (an SVG file's text and images, a usvg
        scene's gradient meshes and Poisson curves), and one when an Orzan or usvg file holds no curve.

    Returns
    -------
    Document
        The loaded document.

    Raises
    ------
    DocumentLoadError
        For an unsupported suffix, or when the reader fails.
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".fmr":
        return load_fmr(path, representation=False).document
    if suffix == ".xml":
        return load_orzan(path, notes)
    if suffix == ".svg":
        return load_svg(path, notes)
    name = Path(path).name or os.fspath(path)
    raise DocumentLoadError(name, f"unsupported file type {suffix or '(no suffix)'!r}; supported: .fmr, .xml, .svg")


def open_live(path: str | os.PathLike, settings: Settings | None = None, progress: Progress | None = None,
              notes: list[str] | None = None) -> LiveStack:
    """The document in ``path`` with the live representations of its layers and masks, ready to edit.

    A ``.fmr`` file's saved representations are taken as they are (no solve),
    with the settings they were built with, when they check out against the
    document; a representation that does not (damaged, of another document,
    of a newer engine) is rebuilt, and ``notes`` (a list, when given) gets a
    line saying so (as it gets one for what an SVG file held that was not
    imported).  Anything else is built with ``settings`` (default
    ``Settings()``).

    Raises
    ------
    DocumentLoadError
        When the file cannot be read.
    """
    settings = settings or Settings()
    if Path(path).suffix.lower() != ".fmr":
        return LiveStack(load_document(path, notes), settings, progress)
    saved = load_fmr(path)
    live = LiveStack(saved.document, saved.settings or settings, progress, saved.fields)
    found = list(saved.notes)
    for layer, reps in zip(saved.document.layers, saved.fields):
        for kind, rep in zip(Role, reps):
            field = live.fields.get((layer.id, kind))
            if rep is not None and field is not None and field.origin != "resumed":
                found.append(f"the saved {kind} of {layer.name} does not match the document; it was rebuilt")
    if notes is not None:
        notes.extend(found)
    return live


def save_picture(document: Document, image, path: str | os.PathLike) -> Path:
    """Write ``document``'s ``image`` (as ``png.save_png`` takes it) to ``path``: an SVG for an ``.svg`` path
    (``svg_export.save_svg``), else a PNG.  Returns the absolute path written."""
    if Path(path).suffix.lower() == ".svg":
        return save_svg(document, image, path)
    return save_png(image, path)
