"""The constant tables shipped with the package (``scripts/generate_tables.py``) equal freshly measured ones."""

from __future__ import annotations

import numpy as np
import pytest

from fmr_editor.engine.fmm import orders


@pytest.fixture
def fresh_tables():
    orders._shipped_tables.cache_clear()
    orders.truncation_errors.cache_clear()
    yield
    orders._shipped_tables.cache_clear()
    orders.truncation_errors.cache_clear()


def test_every_offset_the_passes_use_is_shipped(fresh_tables):
    assert set(orders.table_offsets()) == set(orders._shipped_tables())


@pytest.mark.parametrize("offset", [(2, 0), (3, 2)])
def test_shipped_truncation_errors_equal_freshly_measured_ones(fresh_tables, offset):
    shipped = orders.truncation_errors(*offset)
    assert not shipped.flags.writeable
    np.testing.assert_allclose(shipped, orders.measured_truncation_errors(*offset), rtol=1e-9, atol=1e-15)


def test_tables_measured_with_other_constants_are_measured_again(fresh_tables, tmp_path, monkeypatch):
    stale = tmp_path / "tables.npz"
    np.savez(stale, offsets=np.array([[2, 0]]), errors=np.zeros((1, 5, 5)), table_order=4,
             samples_per_side=orders.SAMPLES_PER_SIDE)
    monkeypatch.setattr(orders, "SHIPPED_TABLES", stale)
    np.testing.assert_array_equal(orders.truncation_errors(2, 0), orders.measured_truncation_errors(2, 0))


def test_a_missing_or_unreadable_file_is_measured_again(fresh_tables, tmp_path, monkeypatch):
    broken = tmp_path / "tables.npz"
    broken.write_bytes(b"not a zip file")
    monkeypatch.setattr(orders, "SHIPPED_TABLES", broken)
    assert orders._shipped_tables() == {}
    monkeypatch.setattr(orders, "SHIPPED_TABLES", tmp_path / "missing.npz")
    orders._shipped_tables.cache_clear()
    assert orders._shipped_tables() == {}
