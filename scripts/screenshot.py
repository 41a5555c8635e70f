"""Make docs/screenshot.png: the editor on the bundled sample after three named edits, a curve and a stop chosen.

    xvfb-run -a -s "-screen 0 1400x1000x24" .venv/bin/python scripts/screenshot.py [OUT.png]

The window is driven through its own API (open, edits through the history, a selection), waits until the
engine has drawn the exact image, and grabs itself; run it again after a change the window shows.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication

from fmr_editor.engine import setup_process
from fmr_editor.model import DiffusionPoint, edits
from fmr_editor.tools import Selection
from fmr_editor.ui.main_window import MainWindow

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "resources" / "samples" / "ribbon.xml"


def wait_until(app: QApplication, done, seconds: float = 120.0) -> None:
    import time

    end = time.monotonic() + seconds
    while not done():
        if time.monotonic() > end:
            raise TimeoutError("the editor did not get there in time")
        app.processEvents()
        time.sleep(0.02)


def main(out: Path) -> None:
    setup_process()
    app = QApplication.instance() or QApplication(sys.argv[:1])
    with tempfile.TemporaryDirectory() as folder:
        window = MainWindow(QSettings(str(Path(folder) / "settings.ini"), QSettings.Format.IniFormat))
        window.resize(1280, 800)
        window.show()
        window.open_path(SAMPLE)
        wait_until(app, lambda: window.workspace is not None and window.workspace.current)
        history = window.workspace.history
        curve = history.document.curves[1]
        history.apply(edits.set_stop_color(history.document, curve.id, "left", 2, (0.95, 0.3, 0.25)),
                      "Change Stop Colour")
        history.apply(edits.add_points(history.document, [DiffusionPoint((60.0, 150.0), 14.0, (0.2, 0.9, 1.0)),
                                                          DiffusionPoint((196.0, 60.0), 16.0, (1.0, 0.95, 0.7))]),
                      "Paint Stroke")
        anchor = curve.control_points[6]
        history.apply(edits.move_control_point(history.document, curve.id, 6, (anchor[0], anchor[1] - 6.0)),
                      "Move Anchor")
        window.workspace.context.selection = Selection.of(stops=[(curve.id, "left", 2)])
        window.after_tool()  # what a click of the select tool ends with
        wait_until(app, lambda: window.workspace.current)
        for _ in range(20):
            app.processEvents()
        window.grab().save(str(out))
        window._close_now = True  # noqa: SLF001 - nothing to ask
        window.close()
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "screenshot.png")
