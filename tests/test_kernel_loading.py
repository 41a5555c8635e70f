"""The editor's worker loads the CPU raster kernels after opening, so a save's thumbnail or a PNG export finds
them ready (a stale numba cache once made a first save take 70-80 s, all of it compiling inside Save)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

RIBBON = Path(__file__).resolve().parents[1] / "resources" / "samples" / "ribbon.xml"

PROBE = """
import json, sys
from fmr_editor.engine import LiveStack, Settings, load_raster_kernels, setup_process
from fmr_editor.engine.kernels import grid, local_grid, subcells
from fmr_editor.io import load_document
from fmr_editor.io.fmr_file import thumbnail_png

setup_process()
kernels = {f"{name} {channels}": table[channels] for channels in (3, 4) for name, table in
           (("near", grid._NEAR_GRID), ("local", local_grid._LOCAL_GRID), ("subcells", subcells._SUBCELL_GRID))}
def compiled():
    return {name: len(kernel.signatures) for name, kernel in kernels.items()}
live = LiveStack(load_document(sys.argv[1]), Settings())
fresh = compiled()
load_raster_kernels()
loaded = compiled()
thumbnail_png(live.composite)
print(json.dumps([fresh, loaded, compiled()]))
"""


def test_after_loading_the_raster_kernels_a_saves_thumbnail_compiles_no_new_kernel():
    done = subprocess.run([sys.executable, "-c", PROBE, str(RIBBON)], check=True, capture_output=True, text=True)
    fresh, loaded, after_thumbnail = json.loads(done.stdout)
    assert set(fresh.values()) == {0}  # a fresh process: opening the document used none of them
    assert all(count > 0 for count in loaded.values())
    assert after_thumbnail == loaded


def test_the_editors_worker_loads_them_when_it_warms_up(monkeypatch):
    from fmr_editor.engine import LiveStack, Settings
    from fmr_editor.io import load_document
    from fmr_editor.ui import engine_thread

    calls = []
    monkeypatch.setattr(engine_thread, "load_raster_kernels", lambda: calls.append("raster"))
    engine_thread._Worker(LiveStack(load_document(RIBBON), Settings())).warm_up()  # noqa: SLF001
    assert calls == ["raster"]
