"""Reading ZIP entries without trusting the archive.

Every size is checked before anything is allocated: the central directory
(from the end record, before :class:`zipfile.ZipFile` parses it), each
entry's declared size against what the caller expects, and each ``.npy``
header (dtype, order, shape) against the exact array expected.  Data is then
read with a limit, so an entry whose header lies about its size cannot
inflate past it (``zipfile`` stops at the declared size and checks the CRC at
the end, which every reader here reaches).  Only stored and deflated entries
are read; encrypted ones are refused.  Nothing is ever unpickled.
"""

from __future__ import annotations

import struct
import zipfile
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from typing import BinaryIO

import numpy as np

MAX_ENTRIES = 4096
"""More entries than this and the file is refused (an ``.fmr`` file has nine a layer and mask, plus three;
``document_json.MAX_LAYERS`` layers with masks stay below it)."""

MAX_DIRECTORY_BYTES = 1 << 20
"""Largest central directory accepted."""

MAX_NPY_HEADER = 4096
"""Largest ``.npy`` header accepted (``np.save`` writes 128 bytes for these arrays)."""

MAX_RATIO = 100
"""An entry declared larger than ``RATIO_FLOOR`` must not unpack to more than this many times its packed size:
real entries (JSON, float arrays) deflate by less than ten, a bomb of zeros by a thousand."""

RATIO_FLOOR = 64 << 20

_CHUNK = 1 << 22
_END = struct.Struct("<4s4H2LH")  # end of central directory record
_END_SIGNATURE = b"PK\x05\x06"
_LOCATOR = struct.Struct("<4sLQL")  # ZIP64 end of central directory locator
_LOCATOR_SIGNATURE = b"PK\x06\x07"
_END64 = struct.Struct("<4sQ2H2L4Q")  # ZIP64 end of central directory record
_END64_SIGNATURE = b"PK\x06\x06"


class ArchiveError(ValueError):
    """The archive or one of its entries is unusable; the message says why."""


def open_archive(stream: BinaryIO, size: int) -> zipfile.ZipFile:
    """Open ``stream`` (``size`` bytes) as a ZIP archive after checking its directory's size.

    Raises
    ------
    ArchiveError
        If it is not a ZIP archive, or its directory is too large, or it has
        too many or duplicate entries.
    """
    entries, directory = _directory_size(stream, size)
    if entries > MAX_ENTRIES or directory > MAX_DIRECTORY_BYTES:
        raise ArchiveError(
            f"the archive's directory lists {entries} entries in {directory} bytes; "
            f"at most {MAX_ENTRIES} entries in {_size(MAX_DIRECTORY_BYTES)} are read"
        )
    stream.seek(0)
    try:
        archive = zipfile.ZipFile(stream)
    except (zipfile.BadZipFile, NotImplementedError, EOFError, ValueError, struct.error) as error:
        # ValueError covers entry names flagged UTF-8 that are not
        raise ArchiveError(
            f"not an fmr-editor file, or a damaged one (not a valid ZIP archive: {_first_line(error)})"
        ) from None
    names = archive.namelist()
    if len(names) > MAX_ENTRIES:
        raise ArchiveError(f"the archive has {len(names)} entries; at most {MAX_ENTRIES} are read")
    if len(set(names)) != len(names):
        duplicate = next(name for i, name in enumerate(names) if name in names[:i])
        raise ArchiveError(f"the archive holds two entries named {duplicate!r}")
    return archive


def _directory_size(stream: BinaryIO, size: int) -> tuple[int, int]:
    """Entry count and central directory size from the end records, found as ``zipfile`` finds them."""
    tail_start = max(size - _END.size - (1 << 16), 0)
    stream.seek(tail_start)
    tail = stream.read(size - tail_start)
    at = len(tail) - _END.size
    if at < 0 or tail[at : at + 4] != _END_SIGNATURE or tail[-2:] != b"\0\0":
        at = tail.rfind(_END_SIGNATURE)
    if at < 0 or len(tail) - at < _END.size:
        raise ArchiveError("not an fmr-editor file, or a truncated one (no ZIP directory at its end)")
    _, _, _, _, entries, directory, _, _ = _END.unpack_from(tail, at)
    locator = tail_start + at - _LOCATOR.size
    if locator >= _END64.size:
        stream.seek(locator - _END64.size)
        records = stream.read(_END64.size + _LOCATOR.size)
        if records[_END64.size : _END64.size + 4] == _LOCATOR_SIGNATURE and records[:4] == _END64_SIGNATURE:
            fields = _END64.unpack_from(records)
            return fields[7], fields[8]
    return entries, directory


def entry_info(archive: zipfile.ZipFile, name: str) -> zipfile.ZipInfo:
    """The entry ``name``, checked to be readable (stored or deflated, not encrypted).

    Raises
    ------
    ArchiveError
        If it is missing or unreadable.
    """
    try:
        info = archive.getinfo(name)
    except KeyError:
        raise ArchiveError(f"the entry {name} is missing") from None
    if info.flag_bits & 0x1:
        raise ArchiveError(f"the entry {name} is encrypted")
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise ArchiveError(
            f"the entry {name} uses compression method {info.compress_type}; only stored and deflated are read"
        )
    if info.file_size > RATIO_FLOOR and info.file_size > MAX_RATIO * info.compress_size:
        raise ArchiveError(f"the entry {name} would unpack {_size(info.compress_size)} to {_size(info.file_size)}, "
                           f"more than {MAX_RATIO} times as much (a ZIP bomb)")
    return info


def read_entry(archive: zipfile.ZipFile, name: str, limit: int) -> bytes:
    """The bytes of entry ``name``, refusing more than ``limit`` bytes.

    Raises
    ------
    ArchiveError
        If the entry is missing, unreadable or larger than ``limit``.
    """
    info = entry_info(archive, name)
    if info.file_size > limit:
        raise ArchiveError(f"the entry {name} unpacks to {_size(info.file_size)}, more than the {_size(limit)} allowed")
    with _opened(archive, info) as entry:
        data = entry.read(limit + 1)
    if len(data) > limit:  # only if zipfile did not stop at the declared size
        raise ArchiveError(f"the entry {name} unpacks to more than the {_size(limit)} allowed")
    return data


def read_npy(archive: zipfile.ZipFile, name: str, dtype: str, shape: tuple[int, ...]) -> np.ndarray:
    """The array in ``.npy`` entry ``name``, which must have exactly ``dtype`` and ``shape``.

    Parameters
    ----------
    archive : zipfile.ZipFile
    name : str
        The entry.
    dtype : str
        The exact NumPy type string, e.g. ``"<f8"`` (byte order included).
    shape : tuple of int
        The exact shape.

    Raises
    ------
    ArchiveError
        If the entry is missing or larger than such an array, its header is
        malformed or says another dtype (an object dtype, which would need
        pickle, included), order or shape, or its data is short or followed
        by more bytes.
    """
    expected = np.dtype(dtype)
    nbytes = int(np.prod(shape, dtype=np.int64)) * expected.itemsize
    info = entry_info(archive, name)
    if info.file_size > nbytes + MAX_NPY_HEADER:
        raise ArchiveError(
            f"the entry {name} unpacks to {_size(info.file_size)}; a {dtype} array of shape {shape} "
            f"needs {_size(nbytes)}"
        )
    with _opened(archive, info) as entry:
        found_dtype, fortran, found_shape = _npy_header(entry, name)
        if found_dtype.str != expected.str or found_dtype.hasobject:
            raise ArchiveError(
                f"{name} holds dtype {_describe(found_dtype)}, expected {dtype}"
                + (" (pickled objects are never loaded)" if found_dtype.hasobject else "")
            )
        if fortran:
            raise ArchiveError(f"{name} is in Fortran order; C order is expected")
        if found_shape != tuple(shape):
            raise ArchiveError(f"{name} has shape {found_shape}, expected {tuple(shape)}")
        array = np.empty(shape, dtype=expected)
        buffer = memoryview(array.reshape(-1).view(np.uint8))
        done = 0
        while done < nbytes:
            count = entry.readinto(buffer[done : min(done + _CHUNK, nbytes)])
            if not count:
                raise ArchiveError(f"{name} ends after {done} of its {nbytes} data bytes")
            done += count
        if entry.read(1):
            raise ArchiveError(f"{name} has more bytes after its array")
    return array


@contextmanager
def _opened(archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> Iterator[BinaryIO]:
    """``archive.open(info)``, turning damage found while reading (bad CRC, bad deflate data) into ``ArchiveError``."""
    try:
        with archive.open(info) as entry:
            yield entry
    except (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError, UnicodeDecodeError) as error:
        # UnicodeDecodeError: the local header's name is flagged UTF-8 but is not
        raise ArchiveError(f"the entry {info.filename[:60]} is damaged ({_first_line(error)})") from None


def _npy_header(entry: BinaryIO, name: str) -> tuple[np.dtype, bool, tuple[int, ...]]:
    """``(dtype, fortran_order, shape)`` from a ``.npy`` header (parsed with ``ast.literal_eval``, never ``eval``)."""
    try:
        version = np.lib.format.read_magic(entry)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(entry, max_header_size=MAX_NPY_HEADER)
        elif version == (2, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(entry, max_header_size=MAX_NPY_HEADER)
        else:
            raise ArchiveError(f"{name} is .npy version {version[0]}.{version[1]}; 1.0 and 2.0 are read")
    except ArchiveError:
        raise
    except Exception as error:  # numpy's header parser meets hostile text: any failure means a bad header
        raise ArchiveError(f"{name} is not a valid .npy array ({_first_line(error)})") from None
    return dtype, bool(fortran), tuple(int(n) for n in shape)


def _describe(dtype: np.dtype) -> str:
    return "object" if dtype == np.dtype(object) else repr(dtype.str if not dtype.fields else dtype.descr)[:60]


def _first_line(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    return text[0][:120] if text else type(error).__name__


def _size(nbytes: int) -> str:
    for unit, scale in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if nbytes >= scale:
            return f"{nbytes / scale:.1f} {unit}"
    return f"{nbytes} bytes"
