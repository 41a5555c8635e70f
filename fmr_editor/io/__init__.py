"""Reading and writing documents.  No Qt, no OpenGL."""

from __future__ import annotations

import os
from pathlib import Path

from ..model import Document
from .errors import DocumentLoadError
from .fmr_file import FmrFile, load_fmr, save_fmr
from .orzan import load_orzan, parse_orzan

__all__ = ["DocumentLoadError", "FmrFile", "load_document", "load_fmr", "load_orzan", "parse_orzan", "save_fmr"]


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
