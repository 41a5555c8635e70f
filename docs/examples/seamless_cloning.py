"""A square of lady_bug pasted seamlessly into flower, scaled, turned and moved.

    .venv/bin/python docs/examples/seamless_cloning.py

Reads the shared sample data beside the repository (``../shared/data``).
"""

from pathlib import Path

from fmr_editor import load, render_image
from fmr_editor.engine import setup_process
from fmr_editor.model.clone import Similarity
from fmr_editor.model.clone_edits import copy_region, paste_seamless

setup_process()  # the engine's thread and memory policy for this process, as the editor sets it
DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "orzan_xml" / "berkbavas"

ladybird, flower = load(DATA / "lady_bug.xml"), load(DATA / "flower.xml")
copied = copy_region(ladybird, [(150, 150), (330, 150), (330, 300), (150, 300)])  # the active layer in a polygon
cloned = paste_seamless(flower, copied, Similarity(scale=0.8, degrees=20, offset=(100, -40)))
image = render_image(cloned, samples=1)  # the flower, the ladybird's square blended in without a seam
