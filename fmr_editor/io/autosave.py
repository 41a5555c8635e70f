"""Autosaved copies of open documents, and finding them again after a crash.

Each open document with unsaved changes has one entry in the autosave
folder: ``KEY.fmr`` (the document, written atomically by ``save_fmr``) and
``KEY.json`` (the process that wrote it, the file the document came from,
when).  The editor discards an entry when its document is saved or closed
normally, so entries whose process is gone are what a crash left behind:
``AutosaveFolder.orphans`` lists them for the recovery dialog.
"""

from __future__ import annotations

import json
import os
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from ..model import Document
from .fmr_file import load_fmr, save_fmr

#: Largest metadata file read (a few hundred bytes are written).
MAX_METADATA_BYTES = 64 * 1024


@dataclass(frozen=True)
class Autosaved:
    """One autosaved document.

    Attributes
    ----------
    key : str
        Its name in the folder.
    path : pathlib.Path or None
        The file the document was opened from or last saved to; None when never saved.
    written : float
        When it was autosaved (seconds since the epoch).
    pid : int
        The process that wrote it.
    """

    key: str
    path: Path | None
    written: float
    pid: int

    @property
    def name(self) -> str:
        return self.path.name if self.path is not None else "Untitled"


class AutosaveFolder:
    """The folder autosaved documents go to.

    Parameters
    ----------
    folder : pathlib.Path
        Made when first written to.
    """

    def __init__(self, folder: str | os.PathLike) -> None:
        self.folder = Path(folder)

    def new_key(self) -> str:
        """A key no other document of any process uses."""
        return f"{os.getpid()}-{uuid.uuid4().hex[:12]}"

    def write(self, key: str, document: Document, path: Path | None) -> Autosaved:
        """Autosave ``document`` (from ``path``) under ``key``, atomically; the previous copy stays until then."""
        self.folder.mkdir(parents=True, exist_ok=True)
        save_fmr(self.folder / f"{key}.fmr", document)
        entry = Autosaved(key, path, time.time(), os.getpid())
        metadata = {"path": str(path) if path is not None else None, "written": entry.written, "pid": entry.pid}
        temporary = self.folder / f".{key}.json.tmp"
        temporary.write_text(json.dumps(metadata))
        os.replace(temporary, self.folder / f"{key}.json")
        return entry

    def discard(self, key: str) -> None:
        """Remove the entry ``key`` (nothing when there is none)."""
        for suffix in (".json", ".fmr"):
            (self.folder / f"{key}{suffix}").unlink(missing_ok=True)

    def orphans(self) -> list[Autosaved]:
        """Entries whose process is no longer running, newest first (unreadable metadata skipped).

        This process counts as not running: call it at start, before this process autosaves (a crashed
        process may have had its id).
        """
        found = []
        for metadata in self.folder.glob("*.json") if self.folder.is_dir() else ():
            entry = _read_entry(metadata)
            if entry is not None and not _running(entry.pid) and (self.folder / f"{entry.key}.fmr").is_file():
                found.append(entry)
        return sorted(found, key=lambda entry: -entry.written)

    def load(self, entry: Autosaved) -> Document:
        """The document autosaved in ``entry``.

        Raises
        ------
        DocumentLoadError
            When the copy cannot be read.
        """
        return load_fmr(self.folder / f"{entry.key}.fmr", representation=False).document


def _read_entry(metadata: Path) -> Autosaved | None:
    try:
        if metadata.stat().st_size > MAX_METADATA_BYTES:
            return None
        content = json.loads(metadata.read_text())
        path = content["path"]
        return Autosaved(metadata.stem, Path(path) if isinstance(path, str) else None, float(content["written"]),
                         int(content["pid"]))
    except (OSError, ValueError, KeyError, TypeError, UnicodeDecodeError):
        return None


def _running(pid: int) -> bool:
    """Whether a process ``pid`` (other than this one) exists."""
    if pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except PermissionError:
        return True  # another user's process
    except (ProcessLookupError, OverflowError, ValueError):
        return False
    return pid > 0
