"""Makes the small hostile files of this folder, one per finding of the fuzzing campaign (issue 16).

    python tests/data/hostile/make.py

Each is the smallest file that showed the finding; ``tests/test_hostile_files.py`` says what each must give.
The large ones (300,001 control points, 100,000 curves) are made by the tests themselves.
"""

from __future__ import annotations

import io
import json
import sys
import zipfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))  # tests/, for shapes

from shapes import circle_points, scattered_document  # noqa: E402

from fmr_editor.engine import build  # noqa: E402
from fmr_editor.io import save_fmr  # noqa: E402


def orzan(width: int, height: int, curves: list[np.ndarray]) -> bytes:
    """An Orzan CurveSetXML file of ``curves`` (control points in document x, y), red left and blue right."""
    parts = [f'<curve_set image_width="{width}" image_height="{height}">']
    for points in curves:
        xy = "".join(f'<control_point x="{float(y)!r}" y="{float(x)!r}"/>' for x, y in points)  # Orzan swaps axes
        parts.append(f'<curve><control_points_set>{xy}</control_points_set>'
                     '<left_colors_set><left_color G="0" R="0" B="255" globalID="0"/></left_colors_set>'
                     '<right_colors_set><right_color G="0" R="255" B="0" globalID="0"/></right_colors_set>'
                     '</curve>')
    return ("".join(parts) + "</curve_set>").encode()


def tangent_fan() -> list[np.ndarray]:
    """Six cubics leaving one point along one tangent, then apart (issue 26): a hair apart for a pixel or two."""
    ends = [((110, 20), (90, 10)), ((30, 110), (118, 118)), ((64, 30), (10, 10)), ((100, 100), (40, 120)),
            ((70, 90), (120, 60)), ((20, 20), (60, 118))]
    return [np.array([(20.0, 64.0), (100.0, 64.0), inner, end]) for inner, end in ends]


def rewritten(source: Path, target: Path, change) -> None:
    """``source``'s archive with ``change(name, data) -> data`` applied to every entry, in order."""
    with zipfile.ZipFile(source) as archive:
        items = [(info, archive.read(info)) for info in archive.infolist()]
    with zipfile.ZipFile(target, "w") as out:
        for info, data in items:
            out.writestr(info, change(info.filename, data))


def main() -> None:
    document = scattered_document(64, circles=2, seed=4)
    good = HERE / "good.fmr"
    save_fmr(good, document, build(document))

    # a ZIP member whose name is flagged UTF-8 but is not
    blob = bytearray(good.read_bytes())
    name = b"thumbnail.png"
    for at in [i for i in range(len(blob)) if blob[i:i + len(name)] == name]:
        blob[at:at + 2] = b"\xff\xfe"
    for signature, flags in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):
        at = blob.find(signature)
        while at >= 0:
            blob[at + flags] |= 0x00
            blob[at + flags + 1] |= 0x08  # bit 11: the name is UTF-8
            at = blob.find(signature, at + 4)
    (HERE / "utf8-name.fmr").write_bytes(bytes(blob))

    # a colour of 1e308 in document.json
    def huge_colour(entry: str, data: bytes) -> bytes:
        if entry != "document.json":
            return data
        content = json.loads(data)
        content["layers"][0]["curves"][0]["left"][0]["color"] = [1e308, 0.0, 0.0]
        return json.dumps(content).encode()

    rewritten(good, HERE / "huge-colour.fmr", huge_colour)

    # a diffusion point of colour 32768 (finite, beyond model.limits.MAX_COLOR) in document.json
    def huge_point_colour(entry: str, data: bytes) -> bytes:
        if entry != "document.json":
            return data
        content = json.loads(data)
        content["layers"][0]["points"] = [{"position": [20.0, 20.0], "radius": 4.0, "color": [32768, 0, 0]}]
        return json.dumps(content).encode()

    rewritten(good, HERE / "point-colour.fmr", huge_point_colour)

    # the saved representation's segments shifted by a third of a pixel
    def shifted(entry: str, data: bytes) -> bytes:
        if not entry.endswith(("/p.npy", "/q.npy")):
            return data
        array = np.load(io.BytesIO(data))
        buffer = io.BytesIO()
        np.save(buffer, array + 1 / 3)
        return buffer.getvalue()

    rewritten(good, HERE / "shifted-segments.fmr", shifted)

    circle = circle_points(256.0, 256.0, 60.0)
    (HERE / "far-coordinates.xml").write_bytes(orzan(512, 512, [np.where(circle > 300, 1e308, -1e308)]))
    (HERE / "scaled-coordinates.xml").write_bytes(orzan(512, 512, [circle * 1e6]))
    far = circle.copy()
    far[4, 1] = 1e5
    (HERE / "one-point-far.xml").write_bytes(orzan(512, 512, [far]))
    (HERE / "huge-canvas.xml").write_bytes(orzan(32768, 32768, [circle]))
    (HERE / "thin-canvas.xml").write_bytes(orzan(1, 32768, [circle]))
    (HERE / "thin-largest-canvas.xml").write_bytes(orzan(1, 16384, [circle]))
    (HERE / "largest-canvas.xml").write_bytes(orzan(16384, 16384, [circle]))
    (HERE / "tiny-curves.xml").write_bytes(orzan(512, 512, [circle_points(100 + 7 * i, 100, 1e-6) for i in range(40)]))
    (HERE / "duplicated.xml").write_bytes(orzan(512, 512, [np.concatenate([circle[:-1]] * 300 + [circle[-1:]])]))
    sides = [((0, 0), (512, 0)), ((512, 0), (512, 512)), ((512, 512), (0, 512)), ((0, 512), (0, 0))]
    border = [np.linspace(sides[i % 4][0], sides[i % 4][1], 4) * (1 - 0.01 * (i // 4)) for i in range(71)]
    (HERE / "border-curves.xml").write_bytes(orzan(512, 512, border))  # curves lying on the canvas edge
    (HERE / "tangent-fan.xml").write_bytes(orzan(128, 128, tangent_fan()))
    good.unlink()
    for path in sorted(HERE.iterdir()):
        print(f"{path.name}: {path.stat().st_size:,} bytes")


if __name__ == "__main__":
    main()
