"""Measure the constant tables the engine ships and write them into the package.

    .venv/bin/python scripts/generate_tables.py

Writes ``fmr_editor/engine/fmm/truncation_errors.npz`` (``orders.SHIPPED_TABLES``): the M2L truncation errors of
every offset the passes use, which every process measured again before (1.2-1.9 s).  Run it after changing
``orders.TABLE_ORDER``, ``orders.SAMPLES_PER_SIDE``, ``expansions.m2l_matrix`` or the passes' offsets;
``tests/test_shipped_tables.py`` measures a sample again and fails while the file is out of date.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np

from fmr_editor.engine.fmm import orders


def main() -> None:
    offsets = orders.table_offsets()
    errors = np.stack([orders.measured_truncation_errors(dx, dy) for dx, dy in offsets])
    target = orders.SHIPPED_TABLES
    handle, temporary = tempfile.mkstemp(dir=target.parent, suffix=".npz")
    with os.fdopen(handle, "wb") as file:
        np.savez(file, offsets=np.array(offsets, np.int64), errors=errors, table_order=orders.TABLE_ORDER,
                 samples_per_side=orders.SAMPLES_PER_SIDE)
    os.chmod(temporary, 0o644)
    os.replace(temporary, target)
    print(f"wrote {target} ({len(offsets)} offsets, {target.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
