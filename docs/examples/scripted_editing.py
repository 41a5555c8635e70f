"""Edit a document as the editor does, without Qt: a colour change, a dab, undo, redo, a PNG.

    .venv/bin/python docs/examples/scripted_editing.py     # writes out/edited.png
"""

from pathlib import Path

from fmr_editor.engine import setup_process
from fmr_editor.model import DiffusionPoint, edits
from fmr_editor.session import Session

setup_process()  # the engine's thread and memory policy for this process, as the editor sets it
SAMPLES = Path(__file__).resolve().parents[2] / "resources" / "samples"

session = Session.open(SAMPLES / "ribbon.xml")
update = session.apply(lambda doc: edits.set_stop_color(doc, doc.curves[0].id, "left", 1, (0.9, 0.2, 0.1)),
                       "Change Stop Colour")
print(update.kind, update.changed.sum(), "cells changed")  # colours: the factorisation was reused
session.apply(lambda doc: edits.add_points(doc, [DiffusionPoint((128, 64), 12.0, (1.0, 1.0, 0.6))]), "Glow Stroke")
session.undo()  # the dab is gone; session.history.redo_label == "Glow Stroke"
session.redo()
image = session.image(width=128)  # float (H, W, 3), as engine.rasterise
cells = session.cells()  # cell polynomials c[row, column, channel, i, j]
session.save_png("out/edited.png")
