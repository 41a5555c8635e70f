"""Fit Orzan's ``best_scale`` to a Gaussian's deviation on the one blurred reference render (issue 29).

    python bench/fit_orzan_blur.py

``reference_renders/no_blur_ex.jpg`` and ``blur-ex.jpg`` (../shared/data) are the same view of lady_bug
ray-traced without and with blur.  The view (scale and corner) is found by fitting our sharp picture to
``no_blur_ex.jpg`` (Nelder-Mead from a coarse grid, on a 64 x 64 subsample); then, for deviations of ``k``
pixels per unit of ``best_scale``, what our blur adds to the picture is set beside what theirs adds
(``blur-ex - no_blur_ex``): the mean difference and the correlation.  io/orzan.py's
``BEST_SCALE_DEVIATION`` comes from these figures.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
from PIL import Image
from scipy.optimize import minimize

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def main() -> None:
    from fmr_editor.engine import LiveStack, evaluate_points, setup_process
    from fmr_editor.engine.blur import blurred
    from fmr_editor.io import load_document
    from fmr_editor.io.orzan import BEST_SCALE_DEVIATION
    from fmr_editor.model import BlurStop

    setup_process()
    document = load_document(DATA / "orzan_xml" / "berkbavas" / "lady_bug.xml")
    unit = [replace(c, blur=tuple(BlurStop(s.position, s.blur / BEST_SCALE_DEVIATION) for s in c.blur), id=c.id)
            for c in document.curves]  # best_scale as the file gives it
    document = replace(document, layers=(document.layer.with_curves(unit),))
    stack = LiveStack(document, blur=True)
    picture, blur = stack.composite, stack.blur(document.layer)
    sharp_ref, blurred_ref = (np.asarray(Image.open(DATA / "reference_renders" / name)).astype(float) / 255
                              for name in ("no_blur_ex.jpg", "blur-ex.jpg"))

    def view(scale: float, x0: float, y0: float, n: int, margin: int = 0) -> np.ndarray:
        """Document points of an n x n view of the 512 x 512 reference (with margin pixels), reflected into the
        canvas."""
        ticks = (np.arange(-margin, n + margin) + 0.5) * (512 / n) / scale
        xs, ys = np.abs(x0 + ticks), np.abs(y0 + ticks)
        xs, ys = np.minimum(xs, 2 * document.width - xs), np.minimum(ys, 2 * document.height - ys)
        return np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)

    n = 64
    sub = sharp_ref[((np.arange(n) + 0.5) * 512 / n).astype(int)][:, ((np.arange(n) + 0.5) * 512 / n).astype(int)]

    def loss(params) -> float:
        shown = np.clip(evaluate_points(picture, view(*params, n)), 0, 1).reshape(n, n, 3)
        return float(np.abs(shown - sub).mean())

    start = min(((s, x, y) for s in (1.8, 2.0, 2.2) for x in (0, 5, 10) for y in (60, 67, 75)), key=loss)
    fitted = minimize(loss, start, method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-6, "maxiter": 300})
    scale, x0, y0 = fitted.x
    print(f"view: {scale:.3f}:1 from ({x0:.2f}, {y0:.2f}); mean error {fitted.fun:.4f} on the subsample")
    margin = 64
    points = view(scale, x0, y0, 512, margin)
    size = 512 + 2 * margin
    sharp = np.clip(evaluate_points(picture, points), 0, 1).reshape(size, size, 3)
    deviation = np.maximum(evaluate_points(blur, points)[:, 0], 0).reshape(size, size) * scale
    inner = (slice(margin, margin + 512),) * 2
    theirs = blurred_ref - sharp_ref
    off = np.abs(sharp[inner] - sharp_ref).mean()
    print(f"their blur adds {np.abs(theirs).mean():.5f} on average; our sharp picture is {off:.4f} from theirs")
    print("| k (px per unit) | mean difference of what the blurs add | correlation |\n|---:|---:|---:|")
    for k in (0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5):
        ours = blurred(sharp, deviation * k)[inner] - sharp[inner]
        correlation = np.corrcoef(ours.ravel(), theirs.ravel())[0, 1]
        print(f"| {k:.1f} | {np.abs(ours - theirs).mean():.5f} | {correlation:.3f} |")


if __name__ == "__main__":
    main()
