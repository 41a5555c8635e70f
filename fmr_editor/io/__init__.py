"""Reading and writing documents.  No Qt, no OpenGL."""

from __future__ import annotations

import os
from pathlib import Path

from ..engine import LiveRepresentation, LiveStack, Progress, Settings
from ..model import Document
from .errors import DocumentLoadError
from .fmr_file import FmrFile, load_fmr, save_fmr
from .orzan import load_orzan, parse_orzan

__all__ = [
    "DocumentLoadError", "FmrFile", "load_document", "load_fmr", "load_orzan", "open_live", "open_stack",
    "parse_orzan", "save_fmr",
]


def load_document(path: str | os.PathLike) -> Document:
    """Load a document, choosing the reader by the file's suffix.

    Parameters
    ----------
    path : str or os.PathLike
        ``.fmr`` (any case) is read as the native format (its document only;
        use :func:`load_fmr` for the representation too); ``.xml`` as Orzan
        CurveSetXML or usvg SceneXML.

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
        return load_orzan(path)
    name = Path(path).name or os.fspath(path)
    raise DocumentLoadError(name, f"unsupported file type {suffix or '(no suffix)'!r}; supported: .fmr, .xml")


def open_live(path: str | os.PathLike, settings: Settings | None = None,
              progress: Progress | None = None) -> LiveRepresentation:
    """The one-image document in ``path`` with its live representation, ready to edit.

    A ``.fmr`` file's saved representation is taken as it is (no solve), with
    the settings it was built with; anything else is built with ``settings``
    (default ``Settings()``).

    Raises
    ------
    DocumentLoadError
        When the file cannot be read, or holds layers (``open_stack`` takes those).
    """
    settings = settings or Settings()
    if Path(path).suffix.lower() == ".fmr":
        saved = load_fmr(path)
        document, representation = saved.document, saved.representation
        settings = saved.settings or settings
    else:
        document, representation = load_document(path), None
    if not document.is_flat:
        raise DocumentLoadError(Path(path).name, f"has {len(document.layers)} layers or a layer with a mask, opacity "
                                "or colour transform, which this editor does not show yet; `fmr-editor render` draws it")
    return LiveRepresentation(document, settings, progress, representation)


def open_stack(path: str | os.PathLike, settings: Settings | None = None, progress: Progress | None = None) -> LiveStack:
    """The document in ``path`` with the live representations of its layers and masks.

    As ``open_live``, for documents of any number of layers.
    """
    settings = settings or Settings()
    if Path(path).suffix.lower() == ".fmr":
        saved = load_fmr(path)
        return LiveStack(saved.document, saved.settings or settings, progress, saved.fields)
    return LiveStack(load_document(path), settings, progress)
