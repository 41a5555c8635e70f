"""Strict JSON reading and the small type checks the ``.fmr`` manifests share.

Every check raises :class:`SchemaError` with a message naming the place in
the data (``curves[3].left[1].color``), ready to be prefixed with the file
and entry names.  Booleans are never numbers here (JSON ``true`` is not 1),
and NaN, Infinity and numbers too large for a float are refused.
"""

from __future__ import annotations

import json
import math

import numpy as np


class SchemaError(ValueError):
    """JSON data that does not follow its schema; the message names the place."""


class NewerVersionError(SchemaError):
    """The data was written with a newer schema than this reader knows."""


def parse_json(data: bytes) -> object:
    """Strict JSON: UTF-8, no NaN or Infinity, no duplicate keys.

    Raises
    ------
    SchemaError
        With the parser's reason.
    """
    try:
        return json.loads(data.decode("utf-8"), parse_constant=_refuse_constant, object_pairs_hook=_unique_keys)
    except UnicodeDecodeError as error:
        raise SchemaError(f"not UTF-8 text ({error.reason} at byte {error.start})") from None
    except json.JSONDecodeError as error:
        raise SchemaError(f"not valid JSON ({error.msg} at line {error.lineno}, column {error.colno})") from None
    except RecursionError:
        raise SchemaError("not valid JSON (nested too deeply)") from None
    except ValueError as error:  # the hooks below, and integers with too many digits
        raise SchemaError(f"not valid JSON ({error})") from None


def _refuse_constant(name: str) -> None:
    raise ValueError(f"{name} is not a number JSON allows")


def _unique_keys(pairs: list[tuple[str, object]]) -> dict:
    result = dict(pairs)
    if len(result) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise ValueError(f"key {key!r} appears twice in one object")
            seen.add(key)
    return result


def check_version(root: dict, key: str, newest: int, what: str) -> int:
    """The whole number ``root[key]``, from 1 to ``newest``.

    Raises
    ------
    NewerVersionError
        For a version above ``newest``.
    SchemaError
        For a missing or malformed version.
    """
    version = required(root, key, "")
    if type(version) is not int or version < 1:
        raise SchemaError(f"{key} must be a whole number from 1, got {_short(version)}")
    if version > newest:
        raise NewerVersionError(
            f"written by a newer fmr-editor ({what} version {version}; this version reads up to {newest})"
        )
    return version


def as_object(value: object, where: str) -> dict:
    """``value`` if it is a JSON object."""
    if not isinstance(value, dict):
        raise SchemaError(f"{where} must be an object, got {_kind(value)}")
    return value


def as_list(value: object, where: str) -> list:
    """``value`` if it is a JSON list."""
    if not isinstance(value, list):
        raise SchemaError(f"{where} must be a list, got {_kind(value)}")
    return value


def required(item: dict, key: str, where: str) -> object:
    """``item[key]``, or an error naming the missing key."""
    if key not in item:
        raise SchemaError(f"{where + ': ' if where else ''}{key} is missing")
    return item[key]


def finite(value: object, where: str) -> float:
    """A JSON number as a finite float."""
    if type(value) not in (int, float):
        raise SchemaError(f"{where} must be a number, got {_kind(value)}")
    try:
        number = float(value)
    except OverflowError:
        number = math.inf
    if not math.isfinite(number):
        raise SchemaError(f"{where} must be a finite number, got {_short(value)}")
    return number


def finite_tuple(value: object, count: int, where: str) -> tuple[float, ...]:
    """A list of exactly ``count`` finite numbers."""
    items = as_list(value, where)
    if len(items) != count:
        raise SchemaError(f"{where} must be {count} numbers, got {len(items)}")
    return tuple(finite(v, f"{where}[{i}]") for i, v in enumerate(items))


def finite_rows(value: object, columns: int, where: str) -> np.ndarray:
    """A list of ``columns``-number lists as a finite ``(n, columns)`` float64 array."""
    rows = as_list(value, where)
    for i, row in enumerate(rows):
        if not (isinstance(row, list) and len(row) == columns and all(type(v) in (int, float) for v in row)):
            finite_tuple(row, columns, f"{where}[{i}]")  # raises with the precise reason
    try:
        array = np.array(rows, dtype=np.float64).reshape(len(rows), columns)
    except OverflowError:
        raise SchemaError(f"{where} holds a number too large to be finite") from None
    if not np.isfinite(array).all():
        raise SchemaError(f"{where} holds a number too large to be finite")
    return array


def whole(value: object, where: str, low: int, high: int) -> int:
    """A whole number (a JSON integer, or a number without fraction) from ``low`` to ``high``."""
    if type(value) not in (int, float) or (isinstance(value, float) and not value.is_integer()):
        raise SchemaError(f"{where} must be a whole number, got {_short(value)}")
    if not low <= value <= high:
        raise SchemaError(f"{where} must be from {low} to {high}, got {_short(value)}")
    return int(value)


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _kind(value: object) -> str:
    names = {dict: "an object", list: "a list", str: "a string", bool: "a boolean", type(None): "null"}
    return names.get(type(value), "a number")
