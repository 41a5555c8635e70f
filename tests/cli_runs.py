"""Running the command line in-process, as a test reads it."""

from __future__ import annotations

import contextlib
import io

from fmr_editor.cli import main


def run(*argv: str) -> tuple[int, str, str]:
    """``fmr-editor ARGV``: its exit status, what it printed and what it said on stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exit:  # argparse
            code = exit.code
    return code, out.getvalue(), err.getvalue()
