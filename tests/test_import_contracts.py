"""The architecture contracts in pyproject.toml ([tool.importlinter]) hold, and would catch a breach.

Layers: ui -> tools | io | render -> engine -> model; inside the engine geometry -> kernels -> fmm ->
solve | points -> representation -> live | raster, and outside it only its public API; only ui
imports PySide6, only render imports OpenGL, and model, engine, io and tools reach neither.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PYPROJECT = REPO / "pyproject.toml"
ROOT = "fmr_editor"
FAKE_ROOT = "fakeeditor"
SUBPACKAGES = ("model", "engine", "io", "tools", "render", "ui")
ENGINE_PACKAGES = ("geometry", "kernels", "fmm", "solve", "points")
ENGINE_MODULES = ("representation", "composite", "live", "raster", "kept_states", "cells", "threads", "stack",
                  "cloning", "compile_kernels")

pytest.importorskip("importlinter", reason="import-linter is in the [test] extra")


def lint_imports(config: Path, cwd: Path, pythonpath: Path) -> subprocess.CompletedProcess[str]:
    """Run import-linter's command line with this interpreter, without cache."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(pythonpath), env.get("PYTHONPATH", "")) if p
    )
    code = "from importlinter.cli import lint_imports_command; lint_imports_command()"
    return subprocess.run(
        [sys.executable, "-c", code, "--config", str(config), "--no-cache", "--no-logo"],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def project_config() -> dict:
    with PYPROJECT.open("rb") as f:
        return tomllib.load(f)["tool"]["importlinter"]


def test_project_keeps_all_contracts() -> None:
    config = project_config()
    assert config["root_package"] == ROOT
    result = lint_imports(PYPROJECT, cwd=REPO, pythonpath=REPO)
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    n = len(config["contracts"])
    assert n >= 4, "the layer and Qt/GL contracts are missing from pyproject.toml"
    assert f"Contracts: {n} kept, 0 broken." in output, output


def _toml_value(value: object) -> str:
    # The contracts use only strings, booleans and lists of strings: JSON spells those as TOML does.
    return json.dumps(value)


def write_fake_project(tmp_path: Path, module: str, source: str) -> Path:
    """A copy of the project's contracts for a package FAKE_ROOT with one offending module.

    Returns the config file; the package lives in ``tmp_path / "src"``.
    """
    config = json.loads(json.dumps(project_config()).replace(ROOT, FAKE_ROOT))
    lines = ["[tool.importlinter]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in config.items() if k != "contracts"]
    for contract in config["contracts"]:
        lines += ["", "[[tool.importlinter.contracts]]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in contract.items()]
    config_file = tmp_path / "fake.toml"
    config_file.write_text("\n".join(lines) + "\n")

    package = tmp_path / "src" / FAKE_ROOT
    for sub in SUBPACKAGES:
        (package / sub).mkdir(parents=True)
        (package / sub / "__init__.py").write_text('"""Stub."""\n')
    (package / "__init__.py").write_text('"""Stub."""\n')
    for sub in ENGINE_PACKAGES:
        (package / "engine" / sub).mkdir()
        (package / "engine" / sub / "__init__.py").write_text('"""Stub."""\n')
    for name in ENGINE_MODULES:
        (package / "engine" / f"{name}.py").write_text('"""Stub."""\n')
    (package / "session.py").write_text(f"import {FAKE_ROOT}.engine\n")  # the public API: allowed
    (package / "cli.py").write_text('"""Stub."""\n')
    # Allowed uses, so that the allowed paths are exercised too.
    (package / "ui" / "window.py").write_text(
        f"from PySide6 import QtWidgets\nfrom {FAKE_ROOT} import render\n"
    )
    (package / "render" / "gl.py").write_text(f"import OpenGL.GL\nfrom {FAKE_ROOT} import engine\n")
    (package / "engine" / "core.py").write_text(f"import numpy\nfrom {FAKE_ROOT} import model\n")
    (package / "engine" / "live.py").write_text(f"from {FAKE_ROOT}.engine import kept_states, representation\n")
    (package / "engine" / "solve" / "dense.py").write_text(
        f"from {FAKE_ROOT}.engine.fmm import lattice\nfrom {FAKE_ROOT}.engine.geometry import segments\n")
    offender = package.joinpath(*module.split(".")).with_suffix(".py")
    offender.write_text(source.replace(ROOT, FAKE_ROOT))
    return config_file


def test_fake_project_without_violation_passes(tmp_path: Path) -> None:
    config = write_fake_project(tmp_path, "model.points", "import numpy\n")
    result = lint_imports(config, cwd=tmp_path, pythonpath=tmp_path / "src")
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.parametrize(
    ("module", "source", "broken"),
    [
        (
            "model.curve",
            "from PySide6.QtCore import QPointF\n",
            ["model, engine, io and tools import neither", "Only fakeeditor.ui imports PySide6"],
        ),
        (
            "tools.drag",
            "import OpenGL.GL as gl\n",
            ["model, engine, io and tools import neither", "Only fakeeditor.render imports OpenGL"],
        ),
        # Indirect: io reaches Qt through ui, which also breaks the layers.
        ("io.export", "from fmr_editor.ui import window\n", ["Layers:"]),
        ("engine.solve", "from fmr_editor import io\n", ["Layers:"]),
        ("render.upload", "import fmr_editor.io\n", ["Layers:"]),
        # Inside the engine, a lower sub-package reaching up; two siblings that must stay independent.
        ("engine.kernels.sums", "import fmr_editor.engine.fmm.lattice\n", ["Engine layers"]),
        ("engine.points.near", "from fmr_editor.engine.solve import dense\n", ["Engine layers"]),
        ("engine.geometry.cut", "from fmr_editor.engine import representation\n", ["Engine layers"]),
        # Outside the engine, past its public API.
        ("io.entries", "from fmr_editor.engine.fmm import lattice\n", ["Outside the engine"]),
        ("render.packing", "from fmr_editor.engine.representation import Settings\n", ["Outside the engine"]),
    ],
)
def test_contracts_catch_violation(
    tmp_path: Path, module: str, source: str, broken: list[str]
) -> None:
    config = write_fake_project(tmp_path, module, source)
    result = lint_imports(config, cwd=tmp_path, pythonpath=tmp_path / "src")
    output = result.stdout + result.stderr
    assert result.returncode != 0, output
    assert re.search(r"Contracts: \d+ kept, [1-9]\d* broken\.", output), output
    for name in broken:
        assert any(name in line and "BROKEN" in line for line in output.splitlines()), (
            f"expected a broken contract starting {name!r}:\n{output}"
        )
