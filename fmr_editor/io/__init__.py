"""Reading documents from files.  No Qt, no OpenGL."""

from __future__ import annotations

import os
from pathlib import Path

from ..model import Document
from .errors import DocumentLoadError
from .orzan import load_orzan, parse_orzan

__all__ = ["DocumentLoadError", "load_document", "load_orzan", "parse_orzan"]


def load_document(path: str | os.PathLike) -> Document:
    """Load a document, choosing the reader by the file's suffix.

    Parameters
    ----------
    path : str or os.PathLike
        ``.xml`` (any case) is read as Orzan CurveSetXML or usvg SceneXML.

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
    if suffix == ".xml":
        return load_orzan(path)
    name = Path(path).name or os.fspath(path)
    raise DocumentLoadError(name, f"unsupported file type {suffix or '(no suffix)'!r}; supported: .xml")
