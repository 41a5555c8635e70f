"""Mutations of diffusion-curve files, for the fuzz test (``test_fuzz_files.py``) and the long campaign
(``bench/fuzz_campaign.py``): byte flips, truncation, hostile attribute values, repeated or dropped XML
elements, control points snapped onto a few points, ``.fmr`` members and JSON values replaced.  Each takes
the file's bytes and a ``numpy.random.Generator`` and returns the mutated bytes (the kind is in its name).
"""

from __future__ import annotations

import io
import json
import re
import zipfile

import numpy as np

#: Values an attribute or a JSON leaf is replaced with: extremes, non-numbers, long numbers, odd spellings.
HOSTILE_VALUES = ["1e308", "-1e308", "nan", "inf", "-inf", "1e-300", "0", "-1", "999999999999", "1" * 2000,
                  "", " ", "0x10", "1,5", "\u0661\u0662", "2147483648", "-0", "1e5", "3.5", "abc"]
_ATTRIBUTE = re.compile(rb'="([^"]*)"')
_ELEMENT = re.compile(rb"<(control_point|left_color|right_color|best_scale|curve)\b[^>]*?(/>|>.*?</\1>)", re.S)
_CONTROL_POINT = re.compile(rb"<control_point\b[^>]*?/>")
_CANVAS = re.compile(rb'image_(width|height)="([0-9.]+)"')


def flip_bytes(data: bytes, rng: np.random.Generator) -> bytes:
    out = bytearray(data)
    for at in rng.integers(0, len(out), int(rng.integers(1, 9))):
        out[at] ^= 1 << int(rng.integers(0, 8))
    return bytes(out)


def truncate(data: bytes, rng: np.random.Generator) -> bytes:
    return data[: int(rng.integers(0, len(data)))]


def attribute_value(data: bytes, rng: np.random.Generator) -> bytes:
    found = list(_ATTRIBUTE.finditer(data))
    if not found:
        return flip_bytes(data, rng)
    match = found[int(rng.integers(0, len(found)))]
    value = HOSTILE_VALUES[int(rng.integers(0, len(HOSTILE_VALUES)))].encode()
    return data[: match.start(1)] + value + data[match.end(1):]


def repeat_element(data: bytes, rng: np.random.Generator) -> bytes:
    found = list(_ELEMENT.finditer(data))
    if not found:
        return truncate(data, rng)
    match = found[int(rng.integers(0, len(found)))]
    times = int(rng.choice([2, 3, 50, 300]))
    return data[: match.end()] + match.group(0) * (times - 1) + data[match.end():]


def drop_element(data: bytes, rng: np.random.Generator) -> bytes:
    found = list(_ELEMENT.finditer(data))
    if not found:
        return truncate(data, rng)
    match = found[int(rng.integers(0, len(found)))]
    return data[: match.start()] + data[match.end():]


def snap_points(data: bytes, rng: np.random.Generator) -> bytes:
    """Every control point moved onto one of a few points: the canvas's corners, edge midpoints and centre, a
    hair inside them, or anywhere; curves then overlap, share tangents and run along the border."""
    size = {name.decode(): float(value) for name, value in _CANVAS.findall(data)}
    width, height = size.get("width", 512.0), size.get("height", 512.0)
    inset = float(rng.choice([0.0, 1e-6, 0.5, 0.1 * min(width, height)]))
    spots = [(x, y) for x in (inset, width / 2, width - inset) for y in (inset, height / 2, height - inset)]
    spots += [tuple(xy) for xy in rng.uniform((0, 0), (width, height), (int(rng.integers(0, 4)), 2))]
    spots = [spots[i] for i in rng.choice(len(spots), int(rng.integers(2, len(spots) + 1)), replace=False)]

    def snapped(_: re.Match) -> bytes:
        x, y = spots[int(rng.integers(0, len(spots)))]
        return f'<control_point x="{float(x)!r}" y="{float(y)!r}" />'.encode()

    return _CONTROL_POINT.sub(snapped, data)


def _rewritten(data: bytes, change) -> bytes:
    """The archive ``data`` with ``change(names, contents) -> contents`` applied (contents: list of bytes)."""
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        infos = archive.infolist()
        contents = [archive.read(info) for info in infos]
    contents = change([info.filename for info in infos], contents)
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
        for info, content in zip(infos, contents):
            archive.writestr(info, content)
    return out.getvalue()


def member_bytes(data: bytes, rng: np.random.Generator) -> bytes:
    """One ZIP member's bytes flipped or truncated (the archive itself stays valid)."""
    def change(names, contents):
        at = int(rng.integers(0, len(contents)))
        contents[at] = (flip_bytes if rng.random() < 0.5 else truncate)(contents[at], rng) if contents[at] else b"x"
        return contents
    return _rewritten(data, change)


def member_array(data: bytes, rng: np.random.Generator) -> bytes:
    """One ``.npy`` member replaced by an array of another shape or dtype, or with NaNs or huge values."""
    def change(names, contents):
        arrays = [i for i, name in enumerate(names) if name.endswith(".npy")]
        if not arrays:
            return contents
        at = arrays[int(rng.integers(0, len(arrays)))]
        array = np.load(io.BytesIO(contents[at]))
        kind = int(rng.integers(0, 4))
        if kind == 0 and array.size:
            array = array.reshape(-1)[: max(array.size - 1, 0)]
        elif kind == 1:
            array = array.real.astype(np.float32 if array.dtype != np.float32 else np.int64)
        elif kind == 2 and array.size and array.dtype.kind in "fc":
            array = array.copy()
            array.reshape(-1)[int(rng.integers(0, array.size))] = rng.choice([np.nan, np.inf, 1e308])
        else:
            array = np.zeros((3,) + array.shape, array.dtype)
        buffer = io.BytesIO()
        np.save(buffer, array)
        contents[at] = buffer.getvalue()
        return contents
    return _rewritten(data, change)


def json_value(data: bytes, rng: np.random.Generator) -> bytes:
    """One leaf of a JSON member replaced by a hostile value, a wrong type, or a long list."""
    def change(names, contents):
        members = [i for i, name in enumerate(names) if name.endswith(".json")]
        if not members:
            return contents
        at = members[int(rng.integers(0, len(members)))]
        content = json.loads(contents[at])
        leaves = list(_leaves(content))
        if not leaves:
            return contents
        parent, key = leaves[int(rng.integers(0, len(leaves)))]
        replacements = [1e308, -1e308, -1, 0, 2**63, "x", None, [], {}, [0.5] * 10_000, True, 1.5]
        parent[key] = replacements[int(rng.integers(0, len(replacements)))]
        contents[at] = json.dumps(content).encode()
        return contents
    return _rewritten(data, change)


def _leaves(node, parent=None, key=None):
    if isinstance(node, dict):
        for name, value in node.items():
            yield from _leaves(value, node, name)
    elif isinstance(node, list):
        for index, value in enumerate(node):
            yield from _leaves(value, node, index)
    elif parent is not None:
        yield parent, key


XML_MUTATIONS = [flip_bytes, truncate, attribute_value, repeat_element, drop_element]
#: Mutations whose inputs take seconds to build (the long campaign's, not the test suite's).
SLOW_XML_MUTATIONS = [snap_points]
FMR_MUTATIONS = [flip_bytes, truncate, member_bytes, member_array, json_value]


def mutated(data: bytes, suffix: str, seed: int, slow: bool = False) -> tuple[str, bytes]:
    """The mutation ``seed`` chooses for a file of ``suffix`` (``.xml``, ``.svg`` or ``.fmr``; an SVG is
    mutated as XML is), from the slow ones too if ``slow``: its name and its bytes."""
    rng = np.random.default_rng(seed)
    kinds = FMR_MUTATIONS if suffix == ".fmr" else XML_MUTATIONS + (SLOW_XML_MUTATIONS if slow else [])
    kind = kinds[int(rng.integers(0, len(kinds)))]
    return kind.__name__, kind(data, rng)


def outcome(path) -> str:
    """``"refused"`` (the documented error: ``DocumentLoadError`` on reading, ``LimitError`` or
    ``SingularSystemError`` on building) or ``"accepted"`` (built and rendered); raises ``AssertionError``
    when an accepted file renders a non-finite pixel, and lets any other exception through."""
    from fmr_editor.engine import LiveStack, Settings, rasterise
    from fmr_editor.engine.solve.dense import SingularSystemError
    from fmr_editor.io import DocumentLoadError, load_document, load_fmr
    from fmr_editor.model.limits import LimitError

    try:
        if str(path).endswith(".fmr"):
            opened = load_fmr(path)
            document, picture = opened.document, opened.composite
            if picture is None:
                picture = LiveStack(document, opened.settings or Settings(), None, opened.fields).composite
        else:
            document = load_document(path)
            picture = LiveStack(document, Settings()).composite
    except (DocumentLoadError, LimitError, SingularSystemError):
        return "refused"
    image = rasterise(picture, 32, 32, samples=1)
    assert np.isfinite(image).all(), "non-finite pixels"
    return "accepted"
