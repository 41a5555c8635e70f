"""Documents are built and rendered on several threads at once (a job per tab, an engine thread per document)."""

from __future__ import annotations

import threading

import numba
import numpy as np
from shapes import scattered_document

from fmr_editor.engine import build, rasterise


def test_two_documents_build_and_render_at_once_as_they_do_one_after_the_other():
    documents = [scattered_document(64, circles=2, seed=seed) for seed in (3, 4)]
    alone = [rasterise(build(document), 48, 48, samples=1) for document in documents]
    together: list = [None, None]

    def work(k: int) -> None:
        together[k] = rasterise(build(documents[k]), 48, 48, samples=1)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(120)
    for one, other in zip(alone, together):
        np.testing.assert_allclose(other, one, rtol=0, atol=1e-12)
    # numba's fallback layer (workqueue) aborts the process when two threads run parallel kernels at once;
    # OpenMP (libgomp1, which scripts/setup.sh installs) or TBB does not
    assert numba.threading_layer() in ("omp", "tbb")
