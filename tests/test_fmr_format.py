"""The native ``.fmr`` format: save and open (``fmr_editor.io.fmr_file``).

Checks
------
* A document comes back exactly (curves, colour and blur stops, points, canvas), with or
  without a representation, through ``load_fmr`` and ``load_document``.
* A representation comes back with equal arrays and renders identically, without the boundary
  solve or the FMM passes being called; build settings come back too.
* The archive: ``mimetype`` first and stored, the thumbnail a PNG of at most 256 px.
* Saving is atomic: a failure mid-write keeps the old file and leaves no temporary file;
  permissions of an existing file and symbolic links are respected.
* Bad input -- truncated, random, not an .fmr ZIP, malformed or hostile JSON, pickled or
  inconsistent arrays, zip bombs, oversized directories, newer versions -- gives exactly one
  ``DocumentLoadError`` naming the file and the problem (a newer representation alone is
  skipped, with a note, and the document still opens).

Documents are small (48-64 px) so the whole file runs in seconds.
"""

from __future__ import annotations

import io
import json
import os
import stat
import struct
import sys
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from shapes import circle_points, scattered_document, straight_chain

from fmr_editor.engine import Representation, Settings, build, rasterise
from fmr_editor.engine.solve import solver as fast_solve
from fmr_editor.io import DocumentLoadError, FmrFile, fmr_file, load_document, load_fmr, save_fmr
from fmr_editor.io.document_json import document_from_data, document_to_data, dumps_document, loads_document
from fmr_editor.io.png import to_rgb8
from fmr_editor.io.zip_reading import MAX_ENTRIES
from fmr_editor.model import BlurStop, ColorStop, DiffusionCurve, DiffusionPoint, Document, edits

# --- fixtures and helpers -----------------------------------------------------------------------


def rich_document() -> Document:
    """A non-square canvas with colour stops on both sides, blur stops, a curve partly outside the
    canvas, and diffusion points (one narrow enough to stay an exact near point)."""
    base = scattered_document(64, circles=2, seed=5)
    extra = DiffusionCurve(
        straight_chain([(-6.0, 30.0), (20.0, 12.5), (41.25, 33.0), (70.0, 5.0)]),
        left=(ColorStop(0.0, (0.1, 0.2, 0.3)), ColorStop(1.5, (0.9, 0.05, 0.4)), ColorStop(3.0, (0.0, 1.0, 0.0))),
        right=(ColorStop(0.75, (1 / 3, 2 / 3, 0.125)),),
        blur=(BlurStop(0.0, 1.5), BlurStop(2.2, 0.25)),
    )
    ring = DiffusionCurve(circle_points(20.0, 20.0, 7.0), left=(ColorStop(0.0, (0.7, 0.7, 0.2)),))
    points = (
        DiffusionPoint((12.0, 30.0), 9.0, (1.0, 0.5, 0.0), 0.4),
        DiffusionPoint((50.5, 8.25), 1.0, (0.0, 0.2, 1.0), -0.3),
        DiffusionPoint((33.0, 35.0), 20.0, (0.2, 0.9, 0.4)),
    )
    return Document(64, 40, base.curves + (extra, ring), points)


@pytest.fixture(scope="module")
def document() -> Document:
    return rich_document()


@pytest.fixture(scope="module")
def built(document):
    return build(document, Settings())


@pytest.fixture(scope="module")
def saved(tmp_path_factory, document, built) -> Path:
    """The rich document saved with its representation and settings (read-only for tests)."""
    path = tmp_path_factory.mktemp("saved") / "rich.fmr"
    save_fmr(path, document, built, settings=Settings())
    return path


def entries(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as archive:
        return {info.filename: archive.read(info) for info in archive.infolist()}


def write_zip(path: Path, items: list[tuple[str, bytes]], compress: int = zipfile.ZIP_DEFLATED) -> Path:
    """A ZIP of ``items`` in order (``mimetype`` stored), without any checks."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # duplicate names, on purpose in one test
        with zipfile.ZipFile(path, "w") as archive:
            for name, data in items:
                archive.writestr(name, data, compress_type=zipfile.ZIP_STORED if name == "mimetype" else compress)
    return path


def rewritten(source: Path, target: Path, replace: dict[str, bytes | None] | None = None,
              add: list[tuple[str, bytes]] = ()) -> Path:
    """``source`` with entries replaced (None removes one) and others appended."""
    replace = replace or {}
    items = [(name, replace.get(name, data)) for name, data in entries(source).items()]
    return write_zip(target, [(name, data) for name, data in items if data is not None] + list(add))


def npy(array: np.ndarray, allow_pickle: bool = False) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=allow_pickle)
    return buffer.getvalue()


def load_error(path: Path, **kwargs) -> str:
    """The problem ``load_fmr`` reports; fails unless it raises exactly a ``DocumentLoadError`` naming the file."""
    with pytest.raises(DocumentLoadError) as info:
        load_fmr(path, **kwargs)
    assert info.value.source == path.name
    assert str(info.value).startswith(f"{path.name}: ")
    assert "\n" not in str(info.value)
    return info.value.problem


def rebuild_note(path: Path) -> str:
    """Why the representation of ``path`` is not taken: the file opens with its document, without the
    representation (which is derived data, made anew), and one note says why."""
    opened = load_fmr(path)
    assert opened.document == load_fmr(path, representation=False).document
    assert opened.representation is None and len(opened.notes) == 1, opened.notes
    assert opened.notes[0].endswith("the representation must be rebuilt") and "\n" not in opened.notes[0]
    return opened.notes[0]


def document_json(path: Path) -> dict:
    return json.loads(entries(path)["document.json"])


# --- round trips ----------------------------------------------------------------------------------


def test_document_round_trips_exactly(saved, document):
    loaded = load_fmr(saved).document
    assert loaded == document
    assert (loaded.width, loaded.height) == (64, 40)
    for a, b in zip(loaded.curves, document.curves, strict=True):
        np.testing.assert_array_equal(a.control_points, b.control_points)
        assert a.left == b.left and a.right == b.right and a.blur == b.blur
    assert loaded.points == document.points
    assert load_document(saved) == document


def test_alpha_round_trips_in_version_4_and_only_documents_with_alpha_need_it(tmp_path):
    curve = DiffusionCurve(np.array([[1.0, 1.0], [9.0, 2.0], [12.0, 9.0], [3.0, 12.0]]),
                           left=(ColorStop(0.0, (0.1, 0.2, 0.7), 0.25), ColorStop(1.0, (1.0, 0.5, 0.0))),
                           right=(ColorStop(0.5, (0.0, 0.0, 0.0), 0.0),))
    translucent = Document(16, 16, [curve])
    data = document_to_data(translucent)
    assert data["version"] == 4
    assert [stop.get("alpha") for stop in first(data)["curves"][0]["left"]] == [0.25, None]  # 1 is not written
    assert load_fmr(save_fmr(tmp_path / "alpha.fmr", translucent)).document == translucent
    opaque = edits.set_stop_alpha(translucent, curve.id, "left", 0, 1.0)
    opaque = edits.set_stop_alpha(opaque, curve.id, "right", 0, 1.0)
    assert document_to_data(opaque)["version"] == 2
    assert [stop.alpha for stop in opaque.curves[0].left] == [1.0, 1.0]
    assert opaque.curves[0].left[0].color == (0.1, 0.2, 0.7)  # setting the alpha keeps the colour ...
    recoloured = edits.set_stop_color(translucent, curve.id, "left", 0, (1.0, 1.0, 1.0))
    assert recoloured.curves[0].left[0].alpha == 0.25  # ... and setting the colour, or moving it, the alpha
    assert edits.move_stop(translucent, curve.id, "left", 0, 0.5).curves[0].left[0].alpha == 0.25
    with pytest.raises(ValueError, match="alphas must lie in"):
        edits.set_stop_alpha(translucent, curve.id, "left", 0, float("nan"))


def test_document_only_file_opens_without_representation(tmp_path, document):
    path = save_fmr(tmp_path / "plain.fmr", document)
    assert sorted(entries(path)) == ["document.json", "mimetype"]
    opened = load_fmr(path)
    nothing = tuple(None for _ in fmr_file.field_documents(document, document.layer))  # and more for blur
    assert opened == FmrFile(document, (nothing,), None, ())
    assert load_document(path) == document


def test_json_form_round_trips_and_keeps_negative_zero_and_odd_floats():
    curve = DiffusionCurve(
        np.array([[-0.0, 0.1], [1e-300, 12.000000000000002], [3.141592653589793, -7.0], [0.30000000000000004, 8.0]]),
        left=(ColorStop(0.5, (0.1, 0.2, 0.7)),),
    )
    document = Document(3, 5, [curve], [DiffusionPoint((-7.999999999999999, 2.0), 1e-3, (2.0, -1.0, 0.5), -0.0)])
    assert loads_document(dumps_document(document)) == document
    assert document_from_data(json.loads(json.dumps(document_to_data(document)))) == document
    assert np.signbit(loads_document(dumps_document(document)).curves[0].control_points[0, 0])


def test_representation_round_trips_without_solving(saved, built, monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("opening an .fmr file must not repeat the solve")

    # wherever the engine imports them from, so that this holds however build is organised
    patched = 0
    for module in [module for name, module in sys.modules.items() if name.startswith("fmr_editor.engine")]:
        for name in ("solve_boundary", "BoundarySolver", "upward_pass", "downward_pass"):
            if hasattr(module, name):
                monkeypatch.setattr(module, name, refuse)
                patched += 1
    assert patched >= 3 and fast_solve.solve_boundary is refuse
    opened = load_fmr(saved)
    rep = opened.representation
    assert rep is not None and opened.notes == ()
    assert opened.settings == Settings()
    assert (rep.width, rep.height, rep.order) == (built.width, built.height, built.order)
    assert rep.lattice == built.lattice
    for name in ("p", "q", "jump", "mean", "on_border", "flux"):
        a, b = getattr(rep.segments, name), getattr(built.segments, name)
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(rep.cell_start, built.cell_start)
    np.testing.assert_array_equal(rep.local, built.local)
    np.testing.assert_array_equal(rep.points.tensor, built.points.tensor)
    assert "open" in rep.timings


def test_opened_representation_renders_identically(saved, built):
    rep = load_fmr(saved).representation
    for samples in (1, 2):
        np.testing.assert_array_equal(rasterise(rep, samples=samples), rasterise(built, samples=samples))
    np.testing.assert_array_equal(rasterise(rep, 50, 31, samples=1), rasterise(built, 50, 31, samples=1))


def test_representation_without_points_and_without_settings(tmp_path):
    document = scattered_document(48, circles=2)
    rep = build(document)
    path = save_fmr(tmp_path / "curves.fmr", document, rep)
    opened = load_fmr(path)
    assert opened.settings is None and opened.representation.points is None
    np.testing.assert_array_equal(rasterise(opened.representation, samples=1), rasterise(rep, samples=1))
    assert load_fmr(path, representation=False) == FmrFile(document)


def test_settings_with_explicit_levels_and_order_round_trip(tmp_path):
    document = scattered_document(48, circles=1)
    settings = Settings(order=6, propagation_order=12, levels=4, tolerance=0.1, max_length=3.0)
    path = save_fmr(tmp_path / "s.fmr", document, build(document, settings), settings=settings)
    opened = load_fmr(path)
    assert opened.settings == settings
    assert opened.representation.lattice.levels == 4 and opened.representation.order == 6


def test_save_refuses_a_representation_of_another_document(tmp_path, document, built):
    other = Document(64, 41, document.curves, document.points)
    with pytest.raises(ValueError, match="64x40"):
        save_fmr(tmp_path / "x.fmr", other, built)
    with pytest.raises(ValueError, match="diffusion points"):
        save_fmr(tmp_path / "x.fmr", document.with_points(document.points[:2]), built)
    with pytest.raises(ValueError, match="diffusion points"):
        save_fmr(tmp_path / "x.fmr", document.with_points(()), built)
    with pytest.raises(ValueError, match="order"):
        save_fmr(tmp_path / "x.fmr", document, built, settings=Settings(order=6))
    assert list(tmp_path.iterdir()) == []


# --- the archive ------------------------------------------------------------------------------------


def test_mimetype_is_first_and_stored(saved):
    with zipfile.ZipFile(saved) as archive:
        first = archive.infolist()[0]
        assert first.filename == "mimetype"
        assert first.compress_type == zipfile.ZIP_STORED
        assert archive.read(first) == b"application/x-fmr-editor"
        names = archive.namelist()
    # readable by magic-number sniffing: the content follows the 30-byte header and the name
    assert saved.read_bytes()[38:62] == b"application/x-fmr-editor"
    assert {"document.json", MANIFEST, "thumbnail.png", ARRAYS + "local.npy"} <= set(names)


def stored_local(built: Representation) -> np.ndarray:
    """The ``local.npy`` of ``built``: the editor keeps the pixels' terms, the file those of the propagation
    order, zero past the pixels'."""
    width = Settings().propagation_order + 1
    assert built.local.shape[-1] == Settings().order + 1
    return np.concatenate([built.local, np.zeros(built.local.shape[:-1] + (width - built.local.shape[-1],))], axis=-1)


def test_arrays_are_plain_npy_files(saved, built):
    data = entries(saved)
    local = np.load(io.BytesIO(data[ARRAYS + "local.npy"]), allow_pickle=False)
    np.testing.assert_array_equal(local, stored_local(built))
    manifest = json.loads(data[MANIFEST])
    assert manifest["version"] == 1 and manifest["segment_count"] == len(built.segments)


def test_thumbnail_is_a_small_render(saved, built, tmp_path):
    with Image.open(io.BytesIO(entries(saved)["thumbnail.png"])) as image:
        assert image.format == "PNG" and image.mode == "RGB"
        assert image.size == (64, 40)  # a small canvas keeps its size
        np.testing.assert_array_equal(np.asarray(image), to_rgb8(rasterise(built, 64, 40, samples=2)))
    wide = Document(512, 200)
    path = save_fmr(tmp_path / "wide.fmr", wide, build(wide))
    with Image.open(io.BytesIO(entries(path)["thumbnail.png"])) as image:
        assert image.size == (256, 100)


# --- atomic saving ------------------------------------------------------------------------------------


def test_failure_mid_write_keeps_the_old_file_and_no_temporary(tmp_path, document, built, monkeypatch):
    target = tmp_path / "drawing.fmr"
    save_fmr(target, document)
    before = target.read_bytes()
    calls = []

    def failing_save(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        return np.lib.format.write_array(args[0], np.asanyarray(args[1]), allow_pickle=False)

    monkeypatch.setattr(np, "save", failing_save)
    with pytest.raises(OSError, match="No space left"):
        save_fmr(target, document, built)
    assert len(calls) == 3
    assert [p.name for p in tmp_path.iterdir()] == ["drawing.fmr"]
    assert target.read_bytes() == before
    assert load_fmr(target).document == document


def test_failure_on_a_new_path_creates_nothing(tmp_path, document, built, monkeypatch):
    def broken_thumbnail(rep):
        raise KeyboardInterrupt

    monkeypatch.setattr(fmr_file, "thumbnail_png", broken_thumbnail)
    with pytest.raises(KeyboardInterrupt):
        save_fmr(tmp_path / "new.fmr", document, built)
    assert list(tmp_path.iterdir()) == []


def test_save_replaces_keeping_permissions_and_follows_links(tmp_path, document):
    real = tmp_path / "real.fmr"
    save_fmr(real, Document(10, 10))
    os.chmod(real, 0o640)
    link = tmp_path / "link.fmr"
    link.symlink_to(real)
    assert save_fmr(link, document) == real
    assert link.is_symlink()
    assert stat.S_IMODE(real.stat().st_mode) == 0o640
    assert load_fmr(link).document == document
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.fmr", "real.fmr"]


def test_saving_into_a_missing_folder_fails_cleanly(tmp_path, document):
    with pytest.raises(FileNotFoundError):
        save_fmr(tmp_path / "absent" / "x.fmr", document)
    assert list(tmp_path.iterdir()) == []


# --- damaged and hostile files --------------------------------------------------------------------


def test_truncated_files_fail_cleanly_at_every_offset(saved, tmp_path):
    data = saved.read_bytes()
    offsets = sorted(set(range(0, len(data), max(1, len(data) // 150))) | set(range(len(data) - 300, len(data))))
    path = tmp_path / "cut.fmr"
    for cut in offsets:
        path.write_bytes(data[:cut])
        load_error(path)


def test_flipped_bytes_fail_cleanly_or_load_the_same(saved, tmp_path, document):
    data = saved.read_bytes()
    rng = np.random.default_rng(7)
    path = tmp_path / "flipped.fmr"
    with zipfile.ZipFile(saved) as archive:
        start = archive.start_dir
    for index in [*rng.integers(0, 2000, 80), *rng.integers(start, len(data), 120), *rng.integers(0, len(data), 60)]:
        blob = bytearray(data)
        blob[index] ^= 1 << int(rng.integers(8))
        path.write_bytes(bytes(blob))
        try:
            opened = load_fmr(path)
        except DocumentLoadError as error:
            assert error.source == path.name
        else:  # a flip in a field nothing depends on (a date, the thumbnail)
            assert opened.document == document


RANDOM_BYTES = bytes(np.random.default_rng(3).integers(0, 256, 5000, dtype=np.uint8))


@pytest.mark.parametrize("content", [b"", b"hello", RANDOM_BYTES, b"PK\x05\x06" + bytes(18), b"<curve_set/>"])
def test_random_bytes_are_not_an_fmr_file(tmp_path, content):
    path = tmp_path / "random.fmr"
    path.write_bytes(content)
    assert "not an fmr-editor file" in load_error(path)


def test_zip_without_mimetype_or_with_another_one(tmp_path, saved):
    doc = entries(saved)["document.json"]
    assert "first entry is 'document.json'" in load_error(write_zip(tmp_path / "a.fmr", [("document.json", doc)]))
    late = write_zip(tmp_path / "b.fmr", [("document.json", doc), ("mimetype", b"application/x-fmr-editor")])
    assert "not mimetype" in load_error(late)
    ora = write_zip(tmp_path / "c.fmr", [("mimetype", b"image/openraster"), ("document.json", doc)])
    assert "'image/openraster'" in load_error(ora)
    empty = write_zip(tmp_path / "d.fmr", [])
    assert "not an fmr-editor file" in load_error(empty)
    missing = write_zip(tmp_path / "e.fmr", [("mimetype", b"application/x-fmr-editor")])
    assert "document.json is missing" in load_error(missing)


def test_missing_file_and_folder(tmp_path):
    assert load_error(tmp_path / "absent.fmr") == "file not found"
    folder = tmp_path / "folder.fmr"
    folder.mkdir()
    assert "folder" in load_error(folder)


def with_document(tmp_path: Path, saved: Path, content, name: str = "doc.fmr") -> Path:
    data = content if isinstance(content, bytes) else json.dumps(content).encode()
    return rewritten(saved, tmp_path / name, {"document.json": data})


def test_document_json_that_is_not_json(tmp_path, saved):
    cases = {
        b"{not json": "not valid JSON",
        b"\xff\xfe{}": "not UTF-8",
        b"[" * 100000 + b"]" * 100000: "nested too deeply",
        b'{"format": "fmr-editor document", "format": 1}': "appears twice",
        b"1" * 5000: "not valid JSON",
    }
    for content, message in cases.items():
        assert message in load_error(with_document(tmp_path, saved, content)), content[:20]


def valid_document_data() -> dict:
    return document_to_data(rich_document())


#: Where a one-layer document's representation is kept.
MANIFEST, ARRAYS = "layers/0/image/representation.json", "layers/0/image/representation/"


def first(data: dict) -> dict:
    """The first layer of ``document.json`` data."""
    return data["layers"][0]


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: d.update(version=5), "newer fmr-editor (document format version 5; this version reads up to 4)"),
        (lambda d: d.update(version="1"), "version must be a whole number"),
        (lambda d: d.pop("version"), "version is missing"),
        (lambda d: d.update(format="something else"), "format is 'something else'"),
        (lambda d: d["canvas"].update(width=-64), "canvas.width must be from 1 to 16384, got -64"),
        (lambda d: d["canvas"].update(height=0), "canvas.height must be from 1"),
        (lambda d: d["canvas"].update(width=10**6), "canvas.width must be from 1 to 16384"),
        (lambda d: d["canvas"].update(width=12.5), "canvas.width must be a whole number"),
        (lambda d: d["canvas"].update(width=True), "canvas.width must be a whole number"),
        (lambda d: d.pop("canvas"), "canvas is missing"),
        (lambda d: first(d).update(curves={}), "layers[0].curves must be a list, got an object"),
        (lambda d: d.update(layers=[]), "layers must hold 1 to 200 layers, got 0"),
        (lambda d: d.pop("layers"), "layers is missing"),
        (lambda d: d.update(active=1), "active must be from 0 to 0, got 1"),
        (lambda d: first(d).update(opacity=1.5), "layers[0].opacity must lie in [0, 1], got 1.5"),
        (lambda d: first(d).update(visible="yes"), "layers[0].visible must be true or false"),
        (lambda d: first(d).update(transform={"matrix": [[1, 0, 0]]}), "layers[0].transform.matrix must have 3 rows"),
        (lambda d: first(d).update(mask={"base": "1"}), "layers[0].mask.base must be a number"),
        (lambda d: first(d).update(mask={"points": [{"position": [1, 2]}]}),
         "layers[0].mask.points[0]: radius is missing"),
        (lambda d: first(d)["curves"][1].update(control_points=[[0, 0]] * 5),
         "layers[0].curves[1].control_points has 5 points"),
        (lambda d: first(d)["curves"][1]["control_points"][2].__setitem__(1, "3"),
         "layers[0].curves[1].control_points[2][1] must be a number, got a string"),
        (lambda d: first(d)["curves"][1]["control_points"][2].append(1.0),
         "layers[0].curves[1].control_points[2] must be 2 numbers"),
        (lambda d: first(d)["curves"][0]["left"][1].update(color=[1, 2]),
         "layers[0].curves[0].left[1].color must be 3 numbers, got 2"),
        (lambda d: first(d)["curves"][0]["left"][1].update(color=[1, None, 2]),
         "layers[0].curves[0].left[1].color[1] must be a number, got null"),
        (lambda d: first(d)["curves"][0]["left"][1].update(alpha=1.5),
         "layers[0].curves[0].left[1].alpha is 1.5; an alpha lies in [0, 1]"),
        (lambda d: first(d)["curves"][0]["left"][1].update(alpha=-0.25), "left[1].alpha is -0.25"),
        (lambda d: first(d)["curves"][0]["left"][1].update(alpha="opaque"),
         "layers[0].curves[0].left[1].alpha must be a number, got a string"),
        (lambda d: first(d)["curves"][0]["right"][0].pop("position"),
         "layers[0].curves[0].right[0]: position is missing"),
        (lambda d: first(d)["curves"][3]["blur"][0].update(blur=False),
         "layers[0].curves[3].blur[0].blur must be a number, got a boolean"),
        (lambda d: first(d)["points"][0].update(radius=-2.0), "layers[0].points[0].radius must be positive"),
        (lambda d: first(d)["points"][0].update(radius=0), "layers[0].points[0].radius must be positive"),
        (lambda d: first(d)["points"][1].update(position=[1.0]), "layers[0].points[1].position must be 2 numbers"),
        (lambda d: first(d)["points"][1].update(amplitude=10**400),
         "layers[0].points[1].amplitude must be a finite number"),
        (lambda d: first(d).update(points=[3]), "layers[0].points[0] must be an object, got a number"),
    ],
)
def test_document_json_with_wrong_content(tmp_path, saved, edit, message):
    data = valid_document_data()
    edit(data)
    problem = load_error(with_document(tmp_path, saved, data))
    assert message in problem
    assert problem.startswith("written by a newer") or problem.startswith("document.json: ")


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity", "1e999"])
def test_document_json_with_non_finite_numbers(tmp_path, saved, constant):
    text = json.dumps(valid_document_data()).replace('"radius": 9.0', f'"radius": {constant}', 1)
    assert constant in text
    problem = load_error(with_document(tmp_path, saved, text.encode()))
    assert "not a number JSON allows" in problem or "must be a finite number" in problem


def test_unknown_keys_and_entries_are_ignored(tmp_path, saved, document):
    data = valid_document_data()
    data["future"] = True
    data["layers"][0]["future"] = True
    data["layers"][0]["curves"][0]["stroke"] = "later"
    path = rewritten(saved, tmp_path / "future.fmr", {"document.json": json.dumps(data).encode()},
                     add=[("history/0001.json", b"{}")])
    assert load_fmr(path).document == document


# --- the representation's entries -------------------------------------------------------------------


def with_array(tmp_path: Path, saved: Path, name: str, content: bytes) -> Path:
    return rewritten(saved, tmp_path / f"{name}.fmr", {f"{ARRAYS}{name}.npy": content})


def test_pickled_objects_are_never_loaded(tmp_path, saved):
    marker = tmp_path / "unpickled"

    class Payload:
        def __reduce__(self):
            return os.mkdir, (str(marker),)

    path = with_array(tmp_path, saved, "p", npy(np.array([Payload(), Payload()], dtype=object), allow_pickle=True))
    problem = rebuild_note(path)
    assert "dtype object" in problem and "pickled objects are never loaded" in problem
    assert not marker.exists()


def test_array_checks(tmp_path, saved, built):
    segments, n = built.segments, len(built.segments)
    cells = built.lattice.cells_per_side
    cell_start = built.cell_start.copy()
    moved = built.segments.p.copy()
    moved[0] += built.lattice.cell_size * 2
    nan_local = stored_local(built)
    nan_local[1, 2, 0, 3] = complex(np.nan, 0)
    on_border = np.ascontiguousarray(segments.on_border).view(np.uint8).copy()
    on_border[0] = 2
    fortran = npy(np.asfortranarray(segments.jump))
    cases = {
        ("p", npy(segments.p[:-1])): f"has shape ({n - 1}, 2), expected ({n}, 2)",
        ("p", npy(segments.p.astype(np.float32))): "holds dtype '<f4', expected <f8",
        ("p", npy(segments.p.astype(">f8"))): "holds dtype '>f8', expected <f8",
        ("jump", fortran): "Fortran order",
        ("local", npy(nan_local)): "local.npy holds values that are not finite",
        ("local", npy(stored_local(built)[..., :-1])): "has shape",
        ("cell_start", npy(cell_start[:-1])): f"expected ({cells * cells + 1},)",
        ("cell_start", npy(cell_start - 1)): f"runs from -1 to {n - 1}, expected 0 to {n}",
        ("cell_start", npy(np.concatenate([[0, n], cell_start[2:]]))): "not non-decreasing",
        ("p", npy(moved)): "segment 0 lies in cell",
        ("q", npy(np.full_like(segments.q, 1e308))): "q.npy holds points outside the canvas",
        ("on_border", npy(on_border.view(bool))): "booleans other than 0 and 1",
        ("q", npy(segments.q)[:-5]): "ends after",
        ("q", npy(segments.q) + b"\0" * 8): "more bytes after its array",
        ("mean", b"\x93NUMPY\x01\x00\x10\x00{'descr': '<f8',    "): "not a valid .npy array",
        ("flux", b"\x93NUMPY\x03\x00" + bytes(40)): ".npy version 3.0",
        ("flux", b"garbage" * 10): "not a valid .npy array",
    }
    for (name, content), message in cases.items():
        problem = rebuild_note(with_array(tmp_path, saved, name, content))
        assert message in problem, (name, message, problem)
    missing = rewritten(saved, tmp_path / "missing.fmr", {ARRAYS + "flux.npy": None})
    assert ARRAYS + "flux.npy is missing" in rebuild_note(missing)
    assert load_document(missing) == load_fmr(saved).document


def manifest_of(saved: Path) -> dict:
    return json.loads(entries(saved)[MANIFEST])


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda m: m.update(segment_count=10**12), "segment_count must be from 0 to"),
        (lambda m: m.update(segment_count=-1), "segment_count must be from 0"),
        (lambda m: m["lattice"].update(levels=11), "lattice.levels must be from 2 to 6"),
        (lambda m: m["lattice"].update(side=1e300), "lattice.side is 1e+300"),
        (lambda m: m["lattice"].update(side=10.0), "lattice.side is 10.0"),
        (lambda m: m.update(order=17), "order must be from 0 to 16"),
        (lambda m: m.update(propagation_order=61), "propagation_order must be from 0 to 60"),
        (lambda m: m["settings"].update(order=4), "settings: settings say order 4"),
        (lambda m: m["settings"].update(tolerance=[1]), "settings.tolerance must be a number"),
        (lambda m: m.update(format="x"), "format is 'x'"),
        (lambda m: m.pop("lattice"), "lattice is missing"),
    ],
)
def test_representation_json_with_wrong_content(tmp_path, saved, edit, message):
    manifest = manifest_of(saved)
    edit(manifest)
    path = rewritten(saved, tmp_path / "m.fmr", {MANIFEST: json.dumps(manifest).encode()})
    problem = rebuild_note(path)
    assert problem.startswith(MANIFEST + ": ") and message in problem, problem


def test_segment_count_that_disagrees_with_the_arrays(tmp_path, saved):
    manifest = manifest_of(saved)
    manifest["segment_count"] -= 1
    path = rewritten(saved, tmp_path / "m.fmr", {MANIFEST: json.dumps(manifest).encode()})
    assert ARRAYS + "p.npy" in rebuild_note(path)


def test_newer_representation_is_skipped_and_the_document_opens(tmp_path, saved, document):
    manifest = manifest_of(saved)
    manifest["version"] = 2
    path = rewritten(saved, tmp_path / "newer.fmr", {MANIFEST: json.dumps(manifest).encode()})
    opened = load_fmr(path)
    assert opened.document == document and opened.representation is None
    assert len(opened.notes) == 1 and "representation format version 2" in opened.notes[0]


# --- size limits -------------------------------------------------------------------------------------------


def test_zip_bomb_entry_is_refused_from_its_declared_size(tmp_path, saved):
    bomb = b"\x93NUMPY" + bytes(64 << 20)  # deflates to about 64 KiB
    path = with_array(tmp_path, saved, "p", bomb)
    assert path.stat().st_size < saved.stat().st_size + (1 << 20)
    problem = rebuild_note(path)
    assert "to 64.0 MiB" in problem and ARRAYS + "p.npy" in problem


def set_declared_size(blob: bytes, name: str, size: int) -> bytes:
    """``blob`` with the uncompressed size of entry ``name`` rewritten in both of its headers."""
    out = bytearray(blob)
    with zipfile.ZipFile(io.BytesIO(blob)) as archive:
        info = archive.getinfo(name)
        start = archive.start_dir
    struct.pack_into("<L", out, info.header_offset + 22, size)
    central = out.index(b"PK\x01\x02", start)
    while out[central + 46 : central + 46 + len(name)] != name.encode():
        central = out.index(b"PK\x01\x02", central + 4)
    struct.pack_into("<L", out, central + 24, size)
    return bytes(out)


def test_entry_whose_header_lies_about_its_size_is_read_with_a_limit(tmp_path, saved):
    padded = json.dumps(valid_document_data()).encode() + b" " * (32 << 20)
    honest = with_document(tmp_path, saved, padded, "honest.fmr")
    liar = tmp_path / "liar.fmr"
    liar.write_bytes(set_declared_size(honest.read_bytes(), "document.json", 70_000))
    assert "document.json is damaged" in load_error(liar)


def test_document_above_the_limit_is_refused(tmp_path, saved, monkeypatch):
    monkeypatch.setattr(fmr_file, "MAX_DOCUMENT_BYTES", 1000)
    assert "the entry document.json unpacks to" in load_error(saved)
    assert "more than the 1000 bytes allowed" in load_error(saved)


def test_too_many_entries_and_duplicates(tmp_path, saved):
    items = list(entries(saved).items())
    extra = MAX_ENTRIES + 1 - len(items)
    crowded = write_zip(tmp_path / "crowded.fmr", items + [(f"extra/{i}", b"") for i in range(extra)],
                        zipfile.ZIP_STORED)
    assert f"lists {MAX_ENTRIES + 1} entries" in load_error(crowded)
    twice = write_zip(tmp_path / "twice.fmr", items + [("document.json", b"{}")])
    assert "two entries named 'document.json'" in load_error(twice)


def test_oversized_central_directory_is_refused_before_parsing(tmp_path, saved):
    blob = bytearray(saved.read_bytes())
    assert blob[-22:-18] == b"PK\x05\x06"
    struct.pack_into("<L", blob, len(blob) - 22 + 12, 0x7FFFFFFF)
    path = tmp_path / "directory.fmr"
    path.write_bytes(bytes(blob))
    assert "2147483647 bytes" in load_error(path)


def test_encrypted_and_exotic_entries_are_refused(tmp_path, saved):
    items = list(entries(saved).items())
    path = tmp_path / "lzma.fmr"
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in items:
            method = zipfile.ZIP_STORED if name == "mimetype" else zipfile.ZIP_LZMA
            archive.writestr(name, data, compress_type=method)
    assert "compression method 14" in load_error(path)
    blob = bytearray(saved.read_bytes())
    with zipfile.ZipFile(saved) as archive:
        start = archive.start_dir
    central = blob.index(b"PK\x01\x02", start)
    central = blob.index(b"PK\x01\x02", central + 4)  # document.json's entry
    blob[central + 8] |= 1
    path.write_bytes(bytes(blob))
    assert "document.json is encrypted" in load_error(path)


# --- through load_document -------------------------------------------------------------------------------


def test_load_document_reads_only_the_document(tmp_path, saved, document, monkeypatch):
    path = with_array(tmp_path, saved, "local", b"broken")
    assert load_document(path) == document
    upper = tmp_path / "UPPER.FMR"
    upper.write_bytes(saved.read_bytes())
    assert load_document(upper) == document
    with pytest.raises(DocumentLoadError, match="supported: .fmr, .xml, .svg"):
        load_document(tmp_path / "x.png")


def test_the_documented_example_is_a_valid_document():
    text = (Path(__file__).resolve().parents[1] / "docs" / "fmr-format.md").read_text()
    example = text.split("```json\n")[1].split("```")[0]
    document = loads_document(example.encode())
    bottom, glow = document.layers
    assert (document.width, document.height, len(bottom.curves), len(bottom.points)) == (96, 64, 1, 1)
    assert bottom.curves[0].blur == (BlurStop(0.0, 2.0),) and document.active == 1
    assert glow.opacity == 0.8 and len(glow.mask.points) == 1 and tuple(glow.transform.offset) == (1.0, 0.6, 0.1)


def test_representation_of_an_edited_document_is_skipped(tmp_path, saved, document):
    data = valid_document_data()
    data["layers"][0]["curves"][0]["left"][0]["color"] = [0.0, 0.0, 0.0]
    path = with_document(tmp_path, saved, data)
    opened = load_fmr(path)
    assert opened.representation is None and opened.document != document
    assert opened.notes == (f"{MANIFEST}: it was saved with another document.json; the representation must be rebuilt",)
    # the same document, written again byte for byte, keeps its representation
    same = with_document(tmp_path, saved, entries(saved)["document.json"], "same.fmr")
    assert load_fmr(same).representation is not None
