"""Start-up stays light: the command line's own modules import nothing heavy until a command needs it
(issue 26; ``bench/bench_start.py`` times the whole processes)."""

from __future__ import annotations

import subprocess
import sys

from cli_runs import run

import fmr_editor

HEAVY = ("numba", "scipy", "shapely", "PIL", "fmr_editor.engine", "fmr_editor.io", "PySide6", "OpenGL")


def imported_after(code: str) -> set[str]:
    """The top-level names of the modules a fresh interpreter holds after running ``code``."""
    script = f"{code}\nimport sys\nprint('\\n'.join(sys.modules))"
    listed = subprocess.run([sys.executable, "-c", script], check=True, capture_output=True, text=True).stdout
    return set(listed.split())


def test_importing_the_package_and_its_command_line_loads_nothing_heavy():
    modules = imported_after("import fmr_editor, fmr_editor.cli")
    assert "fmr_editor.cli" in modules
    assert not [name for name in modules if name.startswith(HEAVY)]


def test_the_version_is_printed_without_loading_the_engine():
    code, out, _ = run("--version")
    assert code == 0 and out == f"fmr-editor {fmr_editor.__version__}\n"
    modules = imported_after("import contextlib, io\nfrom fmr_editor.cli import main\n"
                             "with contextlib.suppress(SystemExit), contextlib.redirect_stdout(io.StringIO()):\n"
                             "    main(['--version'])")
    assert not [name for name in modules if name.startswith(HEAVY)]


def test_a_render_does_load_the_engine():  # the check above would pass vacuously if the listing were broken
    modules = imported_after("from fmr_editor import render_image\nfrom fmr_editor.model import Document\n"
                             "render_image(Document(8, 8, ()), samples=1)")
    assert {"numba", "fmr_editor.engine"} <= modules


SETTINGS = """
import ctypes, json, sys
import numpy, scipy.linalg  # their BLAS libraries, given a setting of the process's own
from threadpoolctl import threadpool_limits

threadpool_limits(int(sys.argv[1]), user_api="blas")
looked_up = []


class Recording(ctypes.CDLL):  # the engine reaches glibc's mallopt through ctypes.CDLL(None)
    def __getattr__(self, name):
        looked_up.append(name)
        return super().__getattr__(name)


ctypes.CDLL = Recording
import fmr_editor.engine
from fmr_editor.engine.threads import blas_threads

seen = [(blas_threads(), "mallopt" in looked_up)]
fmr_editor.engine.setup_process()
seen.append((blas_threads(), "mallopt" in looked_up))
print(json.dumps(seen))
"""


def test_importing_the_engine_leaves_the_process_alone_until_it_is_set_up():
    """BLAS threads and glibc's allocator are the process's own until ``setup_process``, which sets both."""
    import json
    import os

    from fmr_editor.engine.threads import BLAS_THREADS

    environment = {key: value for key, value in os.environ.items() if not key.startswith("MALLOC_")}
    done = subprocess.run([sys.executable, "-c", SETTINGS, str(BLAS_THREADS + 2)], check=True, capture_output=True,
                          text=True, env=environment)
    (threads_before, allocator_before), (threads_after, allocator_after) = json.loads(done.stdout)
    assert threads_before and set(threads_before) == {BLAS_THREADS + 2} and not allocator_before
    assert set(threads_after) == {BLAS_THREADS} and allocator_after
