"""A read-only install keeps its compiled kernels in the user's cache directory (issue 26).

numba caches a kernel beside its source when that folder can be written, and otherwise in the user's cache
directory (``$XDG_CACHE_HOME/numba``).  Here the package is copied without any cache into a folder the probe
cannot write (for root, who writes anywhere, a read-only bind mount in a private mount namespace): the first
process compiles a kernel into the user's cache, and the second loads it from there instead of compiling it.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "fmr_editor"

PROBE = """
import json, os
import numpy as np
from fmr_editor.engine.solve import linalg
sketch = linalg.SparseSign(4, 6) @ np.eye(6)
stats = linalg._apply_sparse_sign.stats
print(json.dumps({"writable": os.access(os.path.dirname(linalg.__file__), os.W_OK),
                  "hits": sum(stats.cache_hits.values()), "misses": sum(stats.cache_misses.values()),
                  "path": stats.cache_path, "sketch": sketch.tolist()}))
"""


def _set_modes(root: Path, folders: int, files: int) -> None:
    for folder, _, names in os.walk(root):
        os.chmod(folder, folders)
        for name in names:
            os.chmod(Path(folder) / name, files)


@pytest.fixture
def read_only_install(tmp_path):
    """``(install, cache, run)``: the package in a folder the probe cannot write, the user's cache folder, and
    a function running the probe there."""
    install, cache = tmp_path / "install", tmp_path / "cache"
    shutil.copytree(PACKAGE, install / "fmr_editor", ignore=shutil.ignore_patterns("__pycache__"))
    cache.mkdir()
    command = [sys.executable, "-c", PROBE]
    if os.geteuid() == 0:
        unshare = shutil.which("unshare")
        if unshare is None:
            pytest.skip("running as root without unshare(1): no way to make the install read-only for root")
        mount = f"mount --bind {install} {install} && mount -o remount,bind,ro {install} {install}"
        command = [unshare, "--mount", "sh", "-c", f'{mount} && exec "$@"', "probe", *command]
    else:
        _set_modes(install, stat.S_IRUSR | stat.S_IXUSR, stat.S_IRUSR)
    environment = {key: value for key, value in os.environ.items() if not key.startswith("NUMBA_CACHE")}
    environment.update(PYTHONPATH=str(install), XDG_CACHE_HOME=str(cache), PYTHONDONTWRITEBYTECODE="1")

    def run() -> dict:
        done = subprocess.run(command, cwd=tmp_path, env=environment, capture_output=True, text=True, timeout=300)
        if os.geteuid() == 0 and done.returncode and "mount" in done.stderr:
            pytest.skip(f"root cannot make a read-only bind mount here: {done.stderr.strip()[-200:]}")
        assert done.returncode == 0, done.stderr[-2000:]
        return json.loads(done.stdout)

    yield install, cache, run
    _set_modes(install, stat.S_IRWXU, stat.S_IRUSR | stat.S_IWUSR)


def test_a_read_only_install_compiles_each_kernel_once_into_the_user_cache(read_only_install):
    install, cache, run = read_only_install
    first, second = run(), run()
    assert not first["writable"]
    assert first["misses"] == 1 and first["hits"] == 0  # compiled in the first process ...
    assert Path(first["path"]).is_relative_to(cache / "numba")  # ... into the user's cache
    assert any(cache.rglob("*.nbi")) and any(cache.rglob("*.nbc"))
    assert second["hits"] == 1 and second["misses"] == 0  # loaded, not compiled, in the next one
    assert first["sketch"] == second["sketch"]
    assert not any(install.rglob("__pycache__"))
