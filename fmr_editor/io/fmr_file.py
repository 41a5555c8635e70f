"""The native ``.fmr`` file: save and open a document with its representation.

An ``.fmr`` file is a ZIP archive (as OpenRaster and Krita files are):

* ``mimetype``, first and stored: ``application/x-fmr-editor``;
* ``document.json``: the editable document (``document_json``);
* per layer ``i``, ``layers/i/image/representation.json`` and
  ``layers/i/image/representation/*.npy``: its solved representation
  (``representation_entries``), optional; ``layers/i/mask/...`` likewise
  for a mask with items, and for a clone layer, its region's indicator,
  with its source's under ``layers/i/source/...``.  Files of version 1 (one image) have
  ``representation.json`` and ``representation/*.npy`` at the top;
* ``thumbnail.png``: at most 256 px on its longest side, present with a
  representation.

``docs/fmr-format.md`` describes the format, its versioning and its limits.
Saving is atomic: the archive is written to a temporary file beside the
target, flushed and synced, then renamed over it.  Opening never repeats the
boundary solve and turns anything wrong with the file into one
:class:`DocumentLoadError` naming the file and the problem.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np
from PIL import Image

from ..engine import Composite, Representation, Role, Settings, clone_points, composite_of, rasterise
from ..model import Document, Layer
from ..model.alpha import alpha_image
from ..model.blur import blur_image
from .atomic import write_atomically
from .document_json import dumps_document, loads_document
from .errors import DocumentLoadError
from .json_checks import NewerVersionError, SchemaError, as_object, check_version, parse_json
from .png import to_rgb8
from .representation_entries import (
    REPRESENTATION_VERSION,
    RepresentationError,
    assemble,
    describe,
    entry_name,
    parse_manifest,
)
from .zip_reading import ArchiveError, open_archive, read_entry, read_npy

MIMETYPE = b"application/x-fmr-editor"
"""Content of the ``mimetype`` entry."""

DOCUMENT_ENTRY = "document.json"
REPRESENTATION_ENTRY = "representation.json"
THUMBNAIL_ENTRY = "thumbnail.png"

THUMBNAIL_SIZE = 256
"""Longest side of the thumbnail, in pixels (smaller canvases keep their size)."""

MAX_DOCUMENT_BYTES = 256 << 20
"""Largest ``document.json`` read (as the Orzan reader's file limit)."""

MAX_MANIFEST_BYTES = 64 << 10
"""Largest ``representation.json`` read."""

COMPRESS_LEVEL = 1
"""zlib level of deflated entries: the fastest; higher levels gained little here."""

_COMPRESSED = {"p", "q", "jump", "mean", "on_border", "flux", "cell_start"}
"""Arrays worth deflating (about 1.3x to 20x); ``local`` gains 3% for 0.13 s and is stored."""


@dataclass(frozen=True)
class FmrFile:
    """What an ``.fmr`` file holds.

    Attributes
    ----------
    document : Document
    fields : tuple
        Per layer, its image's and its mask's representations ``(image,
        mask)``, for a clone layer its source's ``(image, mask, source)``,
        and for a translucent layer its alpha's ``(image, mask, None, alpha)``,
        ready to render; None where the file has none, where they
        were not asked for, or where they cannot be used (see ``notes``).
    settings : Settings or None
        The build settings saved with the representations, when given.
    notes : tuple of str
        Why a representation present in the file was left out: written by
        a newer fmr-editor, or saved with another ``document.json`` (the
        document was edited after saving).
    """

    document: Document
    fields: tuple[tuple[Representation | None, ...], ...] = ()
    settings: Settings | None = None
    notes: tuple[str, ...] = ()

    @property
    def representation(self) -> Representation | None:
        """The picture's representation for a one-layer document (its image); None otherwise."""
        return self.fields[0][0] if self.fields and self.document.is_flat else None

    @property
    def composite(self) -> Composite | None:
        """The picture, ready to render, when the file holds every representation it needs; else None."""
        if len(self.fields) != len(self.document.layers):
            return None
        for layer, (image, mask, *rest) in zip(self.document.layers, self.fields):
            if image is None or (layer.mask is not None and not layer.mask.is_constant and mask is None):
                return None
            if layer.clone is not None and mask is None:
                return None
            if layer.translucent and (len(rest) < 2 or rest[1] is None):
                return None
        return composite_of(self.document, self.fields)


def field_prefix(layer: int, kind: Role) -> str:
    """Where the representation of layer ``layer``'s field ``kind`` is kept (its ``Role``'s value names it)."""
    return f"layers/{layer}/{kind}/"


# --- saving --------------------------------------------------------------------------------------


def save_fmr(
    path: str | os.PathLike,
    document: Document,
    representation: Representation | Composite | None = None,
    *,
    settings: Settings | None = None,
) -> Path:
    """Write ``document`` (and its representation) to the ``.fmr`` file ``path``.

    The archive goes to a temporary file in the target's folder, is flushed
    and synced, and is renamed over ``path``; on any failure the temporary
    file is removed and an existing ``path`` is untouched.  A symbolic link
    is followed (the file it names is replaced); an existing file's
    permissions are kept.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write; its folder must exist.
    document : Document
    representation : Representation or Composite, optional
        What opening takes instead of solving, and what the thumbnail shows:
        ``LiveStack.composite`` (every layer's representations), or for a
        one-layer document ``build(document, settings)``.
    settings : Settings, optional
        The settings ``representation`` was built with, saved beside it.

    Returns
    -------
    pathlib.Path
        The absolute path written.

    Raises
    ------
    ValueError
        If ``representation`` (or ``settings``) does not belong to ``document``.
    OSError
        If the file cannot be written.
    """
    document_bytes = dumps_document(document)
    fields = []
    for prefix, rep, target in _fields(document, representation):
        manifest, arrays = describe(rep, target, settings)
        manifest["document_sha256"] = _digest(document_bytes)
        fields.append((prefix, manifest, arrays))
    return write_atomically(path, lambda stream: _write_archive(stream, document_bytes, fields, representation))


def _fields(document: Document, representation: Representation | Composite | None) -> list[tuple]:
    """``(prefix, representation, the document it is made for)`` of each representation to save."""
    if representation is None:
        return []
    if isinstance(representation, Representation):
        if len(document.layers) != 1:
            raise ValueError(f"a document of {len(document.layers)} layers is saved with its composite")
        return [(field_prefix(0, Role.IMAGE), representation, document.flat(document.layers[0]))]
    if len(representation.layers) != len(document.layers):
        raise ValueError(f"the composite has {len(representation.layers)} layers, the document "
                         f"{len(document.layers)}")
    fields = []
    for i, (layer, drawn) in enumerate(zip(document.layers, representation.layers)):
        targets = field_documents(document, layer)
        fields.append((field_prefix(i, Role.IMAGE), drawn.image, targets[Role.IMAGE]))
        if drawn.mask is not None:
            if targets.get(Role.MASK) is None:
                raise ValueError(f"layer {i} of the composite has a mask, the document's has none")
            fields.append((field_prefix(i, Role.MASK), drawn.mask, targets[Role.MASK]))
        if layer.clone is not None:
            if drawn.source is None:
                raise ValueError(f"layer {i} is a clone layer: its source's representation is saved with it")
            fields.append((field_prefix(i, Role.SOURCE), drawn.source, targets[Role.SOURCE]))
        if (drawn.alpha is None) != (targets.get(Role.ALPHA) is None):
            raise ValueError(f"layer {i}'s alpha does not match its document's (translucent on one side only)")
        if drawn.alpha is not None:
            fields.append((field_prefix(i, Role.ALPHA), drawn.alpha, targets[Role.ALPHA]))
        if drawn.blur is not None and targets.get(Role.BLUR) is not None:  # shown with blur: kept, if it fits
            fields.append((field_prefix(i, Role.BLUR), drawn.blur, targets[Role.BLUR]))
    return fields


def field_documents(document: Document, layer: Layer) -> dict[Role, Document | None]:
    """The one-image documents each representation of ``layer`` is made for, in ``Role`` order: its image, its
    mask (None without one), for a clone layer its source (its image holds its placed points; its mask, the
    region's indicator, none), for a translucent layer its alpha (``model.alpha``; source None) and for a
    blurred one its blur field (``model.blur``; alpha None for an opaque one)."""
    if layer.clone is None:
        alpha, blur = alpha_image(layer), blur_image(layer)
        fields = {Role.IMAGE: document.flat(layer),
                  Role.MASK: document.flat(layer.mask) if layer.mask is not None else None}
        if alpha is not None or blur is not None:
            fields |= {Role.SOURCE: None, Role.ALPHA: document.flat(alpha) if alpha is not None else None}
        return fields | ({Role.BLUR: document.flat(blur)} if blur is not None else {})
    placed = Document(document.width, document.height, (), clone_points(layer.clone, document.width, document.height))
    return {Role.IMAGE: placed, Role.MASK: Document(document.width, document.height), Role.SOURCE: layer.clone.source}


def _write_archive(stream: BinaryIO, document_bytes: bytes, fields: list[tuple], rep: Representation | Composite
                   | None) -> None:
    """The archive's entries, in their order (``mimetype`` first and stored)."""
    stamp = time.localtime()[:6]

    def info(name: str, compress: int) -> zipfile.ZipInfo:
        entry = zipfile.ZipInfo(name, date_time=stamp)
        entry.compress_type = compress
        entry.external_attr = 0o644 << 16
        return entry

    with zipfile.ZipFile(stream, "w", allowZip64=True) as archive:
        archive.writestr(info("mimetype", zipfile.ZIP_STORED), MIMETYPE)
        archive.writestr(info(DOCUMENT_ENTRY, zipfile.ZIP_DEFLATED), document_bytes, compresslevel=COMPRESS_LEVEL)
        for prefix, manifest, arrays in fields:
            text = dumps_manifest(manifest)
            archive.writestr(info(prefix + REPRESENTATION_ENTRY, zipfile.ZIP_DEFLATED), text)
            for name, array in arrays.items():
                if name in _COMPRESSED:  # small: through memory, which lets writestr set the level
                    buffer = io.BytesIO()
                    np.save(buffer, array, allow_pickle=False)
                    entry = info(entry_name(name, prefix), zipfile.ZIP_DEFLATED)
                    archive.writestr(entry, buffer.getbuffer(), compresslevel=COMPRESS_LEVEL)
                else:  # large: streamed
                    entry = info(entry_name(name, prefix), zipfile.ZIP_STORED)
                    with archive.open(entry, "w", force_zip64=array.nbytes > (1 << 30)) as out:
                        np.save(out, array, allow_pickle=False)
        if rep is not None:
            archive.writestr(info(THUMBNAIL_ENTRY, zipfile.ZIP_STORED), thumbnail_png(rep))


def dumps_manifest(manifest: dict) -> bytes:
    """``representation.json`` bytes."""
    return json.dumps(manifest, allow_nan=False, indent=1).encode("utf-8")


def thumbnail_png(rep: Representation | Composite) -> bytes:
    """A PNG of ``rep`` at most ``THUMBNAIL_SIZE`` pixels on its longest side (2x2 samples a pixel)."""
    scale = min(1.0, THUMBNAIL_SIZE / max(rep.width, rep.height))
    image = rasterise(rep, max(1, round(rep.width * scale)), max(1, round(rep.height * scale)), samples=2)
    buffer = io.BytesIO()
    Image.fromarray(to_rgb8(image)).save(buffer, format="PNG", compress_level=1)
    return buffer.getvalue()


# --- opening -------------------------------------------------------------------------------------


def load_fmr(path: str | os.PathLike, *, representation: bool = True) -> FmrFile:
    """Open the ``.fmr`` file ``path``.

    Parameters
    ----------
    path : str or os.PathLike
    representation : bool
        False reads only the document (faster; nothing of the representation
        is read or checked).

    Returns
    -------
    FmrFile
        The document, and the representation ready to render when the file
        has one (its boundary solve is not repeated; diffusion points are
        rebuilt on its lattice).

    Raises
    ------
    DocumentLoadError
        If the file is missing, unreadable, not an ``.fmr`` file, damaged,
        malformed, too large, or written by a newer fmr-editor; the message
        names the file and the problem.
    """
    name = Path(path).name or os.fspath(path)
    start = time.perf_counter()
    try:
        with open(path, "rb") as stream:
            size = os.fstat(stream.fileno()).st_size
            with open_archive(stream, size) as archive:
                result = _read(archive, representation)
    except FileNotFoundError:
        raise DocumentLoadError(name, "file not found") from None
    except IsADirectoryError:
        raise DocumentLoadError(name, "is a folder, not a file") from None
    except (ArchiveError, SchemaError, RepresentationError) as error:
        raise DocumentLoadError(name, str(error)) from None
    except MemoryError:
        raise DocumentLoadError(name, "not enough memory to open the file") from None
    except OSError as error:
        raise DocumentLoadError(name, f"cannot read the file ({error.strerror or error})") from None
    for rep in (rep for pair in result.fields for rep in pair if rep is not None):
        rep.timings["open"] = time.perf_counter() - start
    return result


def _read(archive: zipfile.ZipFile, with_representation: bool) -> FmrFile:
    _check_mimetype(archive)
    document_bytes = read_entry(archive, DOCUMENT_ENTRY, MAX_DOCUMENT_BYTES)
    try:
        document = loads_document(document_bytes)
    except SchemaError as error:
        raise _prefixed(error, DOCUMENT_ENTRY) from None
    if not with_representation:
        return FmrFile(document)
    names = set(archive.namelist())
    fields, notes, settings = [], [], None
    for i, layer in enumerate(document.layers):
        reps = []
        for kind, target in field_documents(document, layer).items():
            prefix = "" if REPRESENTATION_ENTRY in names and (i, kind) == (0, Role.IMAGE) else field_prefix(i, kind)
            if target is None or prefix + REPRESENTATION_ENTRY not in names:
                reps.append(None)
                continue
            rep, field_settings, note = _read_field(archive, prefix, document_bytes, target)
            reps.append(rep)
            settings = settings or field_settings
            notes += [note] if note else []
        fields.append(tuple(reps))
    return FmrFile(document, tuple(fields), settings, tuple(dict.fromkeys(notes)))


def _read_field(archive: zipfile.ZipFile, prefix: str, document_bytes: bytes,
                target: Document) -> tuple[Representation | None, Settings | None, str | None]:
    """The representation saved under ``prefix`` for ``target``; or None and a note saying why not."""
    entry = prefix + REPRESENTATION_ENTRY
    try:
        manifest = as_object(parse_json(read_entry(archive, entry, MAX_MANIFEST_BYTES)), "the top level")
        check_version(manifest, "version", REPRESENTATION_VERSION, "representation format")
    except NewerVersionError as error:  # derived data a newer engine wrote: the document still opens
        return None, None, f"{entry}: {error}; the representation must be rebuilt"
    except (SchemaError, ArchiveError) as error:
        return None, None, f"{_prefixed(error, entry)}; the representation must be rebuilt"
    if manifest.get("document_sha256") != _digest(document_bytes):  # document.json edited after saving
        return None, None, f"{entry}: it was saved with another {DOCUMENT_ENTRY}; the representation must be rebuilt"
    try:  # derived data: whatever is wrong with it, the document opens and the representation is made anew
        layout = parse_manifest(manifest, target)
        arrays = {
            name: read_npy(archive, entry_name(name, prefix), dtype, shape)
            for name, (dtype, shape) in layout.arrays().items()
        }
        return assemble(layout, arrays, target), layout.settings, None
    except SchemaError as error:
        return None, None, f"{_prefixed(error, entry)}; the representation must be rebuilt"
    except (ArchiveError, RepresentationError) as error:
        return None, None, f"{error}; the representation must be rebuilt"


def _digest(document_bytes: bytes) -> str:
    """What ``representation.json`` records of the ``document.json`` it was saved with."""
    return hashlib.sha256(document_bytes).hexdigest()


def _check_mimetype(archive: zipfile.ZipFile) -> None:
    entries = archive.infolist()
    if not entries or entries[0].filename != "mimetype":
        first = repr(entries[0].filename) if entries else "nothing"
        raise ArchiveError(f"not an fmr-editor file (a ZIP archive whose first entry is {first}, not mimetype)")
    content = read_entry(archive, "mimetype", 256)
    if content != MIMETYPE:
        raise ArchiveError(
            f"not an fmr-editor file (its mimetype is {content.decode('ascii', 'replace')!r}, "
            f"expected {MIMETYPE.decode()!r})"
        )


def _prefixed(error: SchemaError, entry: str) -> SchemaError:
    """``error`` with the entry's name in front, except for version messages, which stand alone."""
    if isinstance(error, NewerVersionError):
        return error
    return SchemaError(f"{entry}: {error}")
