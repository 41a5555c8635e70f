"""What the window says when the document refuses an edit, and when a command fails for a reason that is a bug.

An ``EditRefused`` (``model.refusals``) is the document saying no, with the reason for the user.  Any other
exception in a command is a bug: Qt drops an exception let out of its slots (and PySide may crash later), so
it goes to ``sys.excepthook`` with its traceback, and the status bar says that something went wrong.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from ..model import EditRefused


@dataclass
class Outcome:
    """Whether the block under ``reporting`` failed (refused, or a bug)."""

    failed: bool = False


@contextmanager
def reporting(say: Callable[[str], None], refused: str = "Not done") -> Iterator[Outcome]:
    """Run the block; a refusal says ``"<refused>: <why>"`` through ``say``, a bug is reported as one.

    Either way the exception goes no further and the yielded ``Outcome`` has ``failed`` set.
    """
    outcome = Outcome()
    try:
        yield outcome
    except EditRefused as error:
        outcome.failed = True
        say(f"{refused}: {error}")
    except Exception as error:  # noqa: BLE001 - reported with its traceback, see the module
        outcome.failed = True
        sys.excepthook(type(error), error, error.__traceback__)
        say(f"Internal error ({type(error).__name__}): please report it, with the message printed in the terminal")
