"""How ``layers.fmr`` and ``layers.npy`` were made: run at commit f5b2150, the last before colour stops had an
alpha and layers were clamped before blending (it writes document.json version 2 for a document without
clones), as

    PYTHONPATH=.:tests python tests/data/before_alpha/make.py tests/data/before_alpha

``layers.fmr`` is a document of four layers as the editor of that time saved it (a picture with points, a
layer of curves through a mask of dabs at opacity 0.6 with an inversion, a Paint fill layer, a hidden
layer), every colour within [0, 1] so that the later clamp changes nothing; ``layers.npy`` is its picture
as that code rasterised it (48 x 48, one sample a pixel, float32).  ``tests/test_alpha.py`` opens the
file with today's code and expects the same picture.
"""

import sys
from pathlib import Path

import numpy as np
from shapes import scattered_document

from fmr_editor.engine import rasterise, setup_process
from fmr_editor.model import DiffusionPoint, Document, Layer, layer_edits
from fmr_editor.model.color_transform import inversion
from fmr_editor.model.layer import Mask
from fmr_editor.session import Session

setup_process()
out = Path(sys.argv[1])
size = 64
bottom = scattered_document(size, circles=4, seed=3)
bottom = Document(size, size, bottom.curves, [DiffusionPoint((20.0, 40.0), 6.0, (0.2, 0.1, 0.0), 0.5)])
middle = Layer(scattered_document(size, circles=3, seed=8).curves, name="Inverted", opacity=0.6,
               mask=Mask(points=(DiffusionPoint((40.0, 24.0), 14.0, (1.0, 1.0, 1.0), 0.9),)),
               transform=inversion())
document = layer_edits.add_layer(bottom, middle)
document, fill = layer_edits.with_fill_layer(document, (0.9, 0.8, 0.1))
document = layer_edits.add_mask_points(document, fill, [DiffusionPoint((16.0, 16.0), 8.0, (1.0, 1.0, 1.0), 0.8)])
document = layer_edits.add_layer(document, Layer(scattered_document(size, circles=2, seed=5).curves, name="Off",
                                                 visible=False))
session = Session(document)
image = session.image(48, 48, samples=1)
for layer in session.live.composite.layers:  # every layer's colours within [0, 1]: the later clamp changes nothing
    shown = rasterise(layer.image, 48, 48, samples=1)
    assert 0.0 <= shown.min() and shown.max() <= 1.0, (layer.id, shown.min(), shown.max())
session.save(out / "layers.fmr")
np.save(out / "layers.npy", image.astype(np.float32), allow_pickle=False)
