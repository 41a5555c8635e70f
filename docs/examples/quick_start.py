"""Open a curve set, render it, add a diffusion point and render again.

    .venv/bin/python docs/examples/quick_start.py
"""

from pathlib import Path

from fmr_editor import load, render_image
from fmr_editor.engine import setup_process
from fmr_editor.model import DiffusionPoint

setup_process()  # the engine's thread and memory policy for this process, as the editor sets it
SAMPLES = Path(__file__).resolve().parents[2] / "resources" / "samples"

doc = load(SAMPLES / "ribbon.xml")  # an Orzan .xml curve set, or a .fmr document
image = render_image(doc, width=None, height=None, samples=3)  # float32 array (H, W, 3) in [0, 1]
sharp = render_image(doc, blur=False)  # without the curves' blur stops (on by default)

# diffusion points: Gaussian colour blobs amplitude * colour * exp(-d^2 / radius^2), added to the curves
glow = doc.with_points([DiffusionPoint(position=(120, 80), radius=25.0, color=(1.0, 0.8, 0.2), amplitude=0.5)])
glowing = render_image(glow)
