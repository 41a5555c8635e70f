"""Shared test fixtures."""

from __future__ import annotations

import os
import select
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The project's sample data folder ``../shared/data``; skips when absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"sample data folder {SHARED_DATA} is absent (it lives beside the repository)")
    return SHARED_DATA


# --- Qt and OpenGL under a private X server ----------------------------------------------------
# Qt gets OpenGL here only through an X server (DESIGN.md section 8): GUI tests run on an Xvfb that
# the session starts itself, so they need no xvfb-run and no desktop.  pytest-qt's QApplication is
# made after it (``qapp_args`` below depends on it), so every Qt test of the run shares that display.

XVFB_TIMEOUT = 10.0


def _start_xvfb() -> tuple[subprocess.Popen, str] | None:
    """Start ``Xvfb`` on a free display; ``(process, ":N")``, or None when Xvfb is missing or fails."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        return None
    read_end, write_end = os.pipe()
    try:
        process = subprocess.Popen(
            # -terminate: exit when the last client (the test process's Qt) disconnects
            [xvfb, "-displayfd", str(write_end), "-screen", "0", "1280x1024x24", "-nolisten", "tcp", "-terminate"],
            pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
    finally:
        os.close(write_end)
    number = b""
    deadline = time.monotonic() + XVFB_TIMEOUT
    with os.fdopen(read_end, "rb", buffering=0) as pipe:
        while not number.endswith(b"\n") and time.monotonic() < deadline:
            ready, _, _ = select.select([pipe], [], [], max(deadline - time.monotonic(), 0.0))
            chunk = pipe.read(16) if ready else b""
            if not chunk:
                break
            number += chunk
    if not number.strip().isdigit():
        process.kill()
        process.wait()
        return None
    return process, f":{int(number)}"


def _qt_application_exists() -> bool:
    widgets = sys.modules.get("PySide6.QtWidgets")
    return widgets is not None and widgets.QApplication.instance() is not None


@pytest.fixture(scope="session")
def x_display():
    """The X display Qt uses (``QT_QPA_PLATFORM=xcb``): a private Xvfb, else ``$DISPLAY``; None without either.

    Without any X server, Qt falls back to the ``offscreen`` platform (no OpenGL); ``gl_display`` skips then.
    """
    saved = {key: os.environ.get(key) for key in ("DISPLAY", "QT_QPA_PLATFORM")}
    started = _start_xvfb()
    display = started[1] if started else os.environ.get("DISPLAY") or None
    if display:
        os.environ["DISPLAY"], os.environ["QT_QPA_PLATFORM"] = display, "xcb"
    else:
        os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    yield display
    if started and not _qt_application_exists():
        started[0].terminate()
        started[0].wait(timeout=XVFB_TIMEOUT)
    # else Qt keeps its connection until the interpreter exits; killing the server under it would make
    # Qt report a broken connection, so Xvfb ends itself (-terminate) when that connection closes.
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


@pytest.fixture(scope="session")
def qapp_args(pytestconfig, x_display):
    """pytest-qt's QApplication arguments (its default), made to wait for ``x_display``."""
    return [pytestconfig.getini("qt_qapp_name")]


@pytest.fixture(scope="session")
def gl_display(x_display, qapp):
    """An X display with the QApplication on it, for OpenGL tests; skips when there is none."""
    if x_display is None:
        pytest.skip("no X server for OpenGL: install Xvfb (scripts/setup.sh does, as root) or set DISPLAY")
    if qapp.platformName() != "xcb":
        pytest.skip(f"the QApplication runs on Qt's {qapp.platformName()!r} platform, which has no OpenGL here")
    return x_display
