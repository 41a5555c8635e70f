"""A document of two layers: the ribbon, and a copy of it with its hues turned under three soft dabs.

    .venv/bin/python docs/examples/layers.py
"""

from pathlib import Path

from fmr_editor import load, render_image
from fmr_editor.engine import setup_process
from fmr_editor.model import DiffusionPoint, Document, Layer, Mask
from fmr_editor.model.color_transform import hue_rotation

setup_process()  # the engine's thread and memory policy for this process, as the editor sets it
SAMPLES = Path(__file__).resolve().parents[2] / "resources" / "samples"

ribbon = load(SAMPLES / "ribbon.xml")
w, h = ribbon.width, ribbon.height
dabs = [DiffusionPoint((x, h / 2), 30.0, (1.0, 1.0, 1.0)) for x in (w / 3, w / 2, 2 * w / 3)]
layered = Document(w, h, layers=[
    Layer(ribbon.curves, name="ribbon"),
    Layer(ribbon.curves, name="turned", mask=Mask(points=dabs), transform=hue_rotation(120)),
])
image = render_image(layered)  # the ribbon, its hues turned by 120 degrees under three soft dabs
