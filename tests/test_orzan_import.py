"""Tests for the Orzan CurveSetXML / usvg SceneXML reader."""

from __future__ import annotations

import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from fmr_editor.io import DocumentLoadError, load_document, load_orzan, parse_orzan, safe_xml
from fmr_editor.model import BlurStop

SAMPLE = Path(__file__).resolve().parents[1] / "resources" / "samples" / "ribbon.xml"
NAME = "inline_test.xml"

LINE_POINTS = (("10", "20"), ("11", "30"), ("12", "40"), ("13", "50"))  # (x, y) as in the file


# ---------------------------------------------------------------------------------------------
# helpers building small files


def _stop(tag: str, globalid: str = "0", r: str = "0", g: str = "0", b: str = "0") -> str:
    return f'<{tag} G="{g}" R="{r}" globalID="{globalid}" B="{b}" />'


def _curve(
    points=LINE_POINTS,
    left: str | None = None,
    right: str | None = None,
    blur: str = '<best_scale value="0" globalID="0" />',
    attributes: str = 'nb_control_points="4" nb_left_colors="1" nb_right_colors="1" nb_blur_points="1"',
    extra: str = "",
) -> str:
    left = _stop("left_color") if left is None else left
    right = _stop("right_color") if right is None else right
    control = "".join(f'<control_point x="{x}" y="{y}" />' for x, y in points)
    return (
        f"<curve {attributes} lifetime=\"32\">"
        f"<control_points_set>{control}</control_points_set>"
        f"<left_colors_set>{left}</left_colors_set>"
        f"<right_colors_set>{right}</right_colors_set>"
        f"<blur_points_set>{blur}</blur_points_set>{extra}</curve>"
    )


def _orzan(*curves: str, size: str = 'image_width="300" image_height="200"') -> bytes:
    body = "".join(curves) or ""
    return f'<!DOCTYPE CurveSetXML>\n<curve_set {size} nb_curves="{len(curves)}">{body}</curve_set>'.encode()


def _scene(*curves: str, size: str = 'image_width="300" image_height="200"', curve_set_size: str = "") -> bytes:
    return (
        f"<!DOCTYPE SceneXML>\n<scene {size}><curve_set nb_curves=\"{len(curves)}\" {curve_set_size}>"
        f"{''.join(curves)}</curve_set>"
        '<poisson_curve_set nb_curves="1"><poisson_curve nb_control_points="4"><control_points_set>'
        '<control_point x="1" y="2"/><control_point x="1" y="2"/><control_point x="1" y="2"/>'
        '<control_point x="1" y="2"/></control_points_set></poisson_curve></poisson_curve_set>'
        '<mesh_set nb_meshes="0"></mesh_set></scene>'
    ).encode()


def _load_error(data: bytes, name: str = NAME) -> DocumentLoadError:
    with pytest.raises(DocumentLoadError) as caught:
        parse_orzan(data, name)
    assert type(caught.value) is DocumentLoadError
    assert name in str(caught.value)
    return caught.value


def _viewer_left(doc_tangent: np.ndarray) -> np.ndarray:
    """The viewer's left of a direction on a y-down screen (document frame)."""
    tx, ty = doc_tangent
    return np.array([ty, -tx])


def _rotate_plus_90(v: np.ndarray) -> np.ndarray:
    """A vector rotated by +90 degrees in its own frame."""
    return np.array([-v[1], v[0]])


def _unit(v: np.ndarray) -> np.ndarray:
    return np.asarray(v, dtype=float) / np.linalg.norm(v)


# ---------------------------------------------------------------------------------------------
# real files


SHARED_FOLDERS = [
    "orzan_xml/berkbavas",
    "orzan_xml/handmade",
    "scenes_usvg/curve_only",
    "scenes_usvg/unified",
    "scenes_usvg/mesh_backgrounds",
]


@pytest.mark.parametrize("folder", SHARED_FOLDERS)
def test_every_shared_file_loads_with_its_curve_count_and_size(shared_data: Path, folder: str) -> None:
    files = sorted((shared_data / folder).glob("*.xml"))
    assert files, f"no .xml files in {folder}"
    for path in files:
        text = path.read_bytes()
        document = load_orzan(path)
        assert len(document.curves) == len(re.findall(rb"<curve[\s>]", text)), path.name
        width = int(re.search(rb'image_width\s*=\s*"(\d+)"', text).group(1))
        height = int(re.search(rb'image_height\s*=\s*"(\d+)"', text).group(1))
        assert (document.width, document.height) == (width, height), path.name


def test_lady_bug_spot_check(shared_data: Path) -> None:
    document = load_document(shared_data / "orzan_xml" / "berkbavas" / "lady_bug.xml")
    assert (document.width, document.height) == (512, 512)
    assert len(document.curves) == 71
    first = document.curves[0]
    np.testing.assert_array_equal(first.control_points[0], (220.0, 114.0))  # file: x="114" y="220"
    # first right_color in the file: G="131" R="109" B="197" -> red 197, green 131, blue 109
    assert first.right[0].color == pytest.approx((197 / 255, 131 / 255, 109 / 255))


def test_usvg_scene_is_read_without_swaps_and_with_sides_exchanged(shared_data: Path) -> None:
    """usvg's ladybug.xml scene is Orzan's lady_bug.xml moved and halved; both must agree on screen."""
    orzan_curve = load_orzan(shared_data / "orzan_xml" / "berkbavas" / "lady_bug.xml").curves[0]
    scene_curve = load_orzan(shared_data / "scenes_usvg" / "unified" / "ladybug.xml").curves[0]
    expected = 0.5 * orzan_curve.control_points + (460.0, 345.0)
    np.testing.assert_allclose(scene_curve.control_points, expected, atol=1e-3)
    # The map is orientation-preserving, so the viewer's right must carry the same colours.
    # (The scene replaced the other side by a grey Neumann boundary.)
    assert [stop.position for stop in scene_curve.right] == [stop.position for stop in orzan_curve.right]
    for scene_stop, orzan_stop in zip(scene_curve.right, orzan_curve.right):
        assert scene_stop.color == pytest.approx(orzan_stop.color)


def test_bundled_sample_loads() -> None:
    document = load_document(SAMPLE)
    assert (document.width, document.height) == (256, 256)
    assert 3 <= len(document.curves) <= 6
    points = np.concatenate([curve.control_points for curve in document.curves])
    outside = (points[:, 0] < 0) | (points[:, 0] > 256) | (points[:, 1] < 0) | (points[:, 1] > 256)
    assert outside.any(), "some curve should extend past the canvas edge"
    assert all(curve.left and curve.right for curve in document.curves)


def test_bundled_sample_blob_is_warm_inside_and_cool_outside() -> None:
    blob = next(c for c in load_document(SAMPLE).curves if np.allclose(c.control_points[0], c.control_points[-1]))
    samples = blob.point_at(np.linspace(0, blob.piece_count, 400))
    x, y = samples[:, 0], samples[:, 1]
    clockwise_on_screen = np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0  # y down
    inside, outside = (blob.right, blob.left) if clockwise_on_screen else (blob.left, blob.right)
    assert all(stop.color[0] > stop.color[2] for stop in inside)
    assert all(stop.color[2] > stop.color[0] for stop in outside)


# ---------------------------------------------------------------------------------------------
# the traps, one test each


def test_axes_are_swapped() -> None:
    points = (("10", "20"), ("11", "30"), ("12", "40"), ("13", "50"))
    curve = parse_orzan(_orzan(_curve(points)), NAME).curves[0]
    np.testing.assert_array_equal(curve.control_points, [(20, 10), (30, 11), (40, 12), (50, 13)])


def test_attribute_b_is_red_and_r_is_blue() -> None:
    left = _stop("left_color", r="0", g="128", b="255")
    curve = parse_orzan(_orzan(_curve(left=left)), NAME).curves[0]
    assert curve.left[0].color == pytest.approx((1.0, 128 / 255, 0.0))


def test_global_id_is_ten_per_piece() -> None:
    points = [(str(i), str(2 * i)) for i in range(7)]  # 2 pieces
    left = _stop("left_color", "0") + _stop("left_color", "15") + _stop("left_color", "20")
    curve = parse_orzan(_orzan(_curve(points, left=left)), NAME).curves[0]
    assert curve.piece_count == 2
    assert [stop.position for stop in curve.left] == [0.0, 1.5, 2.0]


def test_unsorted_and_out_of_range_stops_are_sorted_and_clamped() -> None:
    points = [(str(i), str(2 * i)) for i in range(7)]  # 2 pieces, globalID range [0, 20]
    left = (
        _stop("left_color", "25", b="25")
        + _stop("left_color", "-5", b="5")
        + _stop("left_color", "30", b="30")
        + _stop("left_color", "5", b="50")
    )
    curve = parse_orzan(_orzan(_curve(points, left=left)), NAME).curves[0]
    assert [stop.position for stop in curve.left] == [0.0, 0.5, 2.0, 2.0]
    assert [round(stop.color[0] * 255) for stop in curve.left] == [5, 50, 25, 30]  # ties keep file order


def test_wrong_nb_counts_are_ignored() -> None:
    wrong = 'nb_control_points="7" nb_left_colors="9" nb_right_colors="0" nb_blur_points="5"'
    left = _stop("left_color", "0") + _stop("left_color", "10")
    data = _orzan(_curve(left=left, attributes=wrong), _curve()).replace(b'nb_curves="2"', b'nb_curves="1"')
    document = parse_orzan(data, NAME)
    assert len(document.curves) == 2
    assert len(document.curves[0].control_points) == 4
    assert len(document.curves[0].left) == 2 and len(document.curves[0].right) == 1


def test_extension_tags_are_ignored() -> None:
    extras = (
        '<weight_set><weight globalID="0" w="20" /><weight globalID="10" w="1" /></weight_set>'
        '<weight_degree_set><weight_degree globalID="0" w="0.9" /></weight_degree_set>'
        '<connects><connect curve="2" /></connects>'
    )
    plain = parse_orzan(_orzan(_curve()), NAME)
    extended = parse_orzan(
        _orzan(_curve(attributes='use_endcap="true" global_len="99"', extra=extras)), NAME
    )
    assert extended == plain


def test_blur_values_are_kept_as_deviations() -> None:
    from fmr_editor.io.orzan import BEST_SCALE_DEVIATION

    blur = '<best_scale value="3.5" globalID="10" /><best_scale value="0" globalID="0" />'
    curve = parse_orzan(_orzan(_curve(blur=blur)), NAME).curves[0]
    assert curve.blur == (BlurStop(0.0, 0.0), BlurStop(1.0, 3.5 * BEST_SCALE_DEVIATION))


@pytest.mark.parametrize(
    "points",
    [
        LINE_POINTS,
        (("100", "10"), ("100", "40"), ("100", "70"), ("100", "100")),  # rightwards on screen
        (("10", "10"), ("40", "30"), ("70", "50"), ("100", "70")),  # down and right
        (("90", "90"), ("60", "70"), ("40", "40"), ("10", "20")),  # up and left
    ],
)
def test_file_left_side_is_the_viewers_left(points) -> None:
    """README: in the file's (x, y) frame left = tangent rotated by +90 degrees."""
    red, blue = _stop("left_color", b="255"), _stop("right_color", r="255")
    curve = parse_orzan(_orzan(_curve(points, left=red, right=blue)), NAME).curves[0]
    file_points = np.array(points, dtype=float)
    file_left = _rotate_plus_90(file_points[1] - file_points[0])  # in the file's (x=row, y=column) frame
    file_left_on_screen = file_left[::-1]  # (column, row) = (y, x)
    doc_tangent = curve.control_points[1] - curve.control_points[0]
    np.testing.assert_allclose(_unit(file_left_on_screen), _unit(_viewer_left(doc_tangent)))
    assert curve.left[0].color == (1.0, 0.0, 0.0) and curve.right[0].color == (0.0, 0.0, 1.0)


def test_viewer_left_of_a_rightward_curve_is_up() -> None:
    points = (("100", "10"), ("100", "40"), ("100", "70"), ("100", "100"))
    curve = parse_orzan(_orzan(_curve(points)), NAME).curves[0]
    tangent = curve.control_points[-1] - curve.control_points[0]
    assert tangent[0] > 0 and tangent[1] == 0  # walking right on screen
    assert _viewer_left(tangent)[1] < 0  # the viewer's left has the smaller y: upwards


def test_scene_has_no_swaps_and_its_left_is_the_viewers_right() -> None:
    points = (("10", "20"), ("40", "20"), ("70", "20"), ("100", "20"))
    left = _stop("left_color", r="255")  # R is red in a scene
    right = _stop("right_color", b="255")
    curve = parse_orzan(_scene(_curve(points, left=left, right=right)), NAME).curves[0]
    np.testing.assert_array_equal(curve.control_points, np.array(points, dtype=float))
    file_left = _rotate_plus_90(curve.control_points[1] - curve.control_points[0])  # x=column, y=row
    np.testing.assert_allclose(_unit(file_left),
                               -_unit(_viewer_left(curve.control_points[1] - curve.control_points[0])))
    assert curve.right[0].color == (1.0, 0.0, 0.0)
    assert curve.left[0].color == (0.0, 0.0, 1.0)


# ---------------------------------------------------------------------------------------------
# sizes, defaults and lenient values


def test_scene_size_can_be_on_the_scene_only() -> None:
    document = parse_orzan(_scene(_curve(), size='image_width="640" image_height="480"'), NAME)
    assert (document.width, document.height, len(document.curves)) == (640, 480, 1)


def test_scene_size_falls_back_to_its_curve_set_and_scene_wins() -> None:
    inner = 'image_width="100" image_height="90"'
    assert parse_orzan(_scene(size="", curve_set_size=inner), NAME).width == 100
    outer = parse_orzan(_scene(size='image_width="640" image_height="480"', curve_set_size=inner), NAME)
    assert (outer.width, outer.height) == (640, 480)


def test_missing_size_defaults_to_512() -> None:
    document = parse_orzan(_orzan(_curve(), size=""), NAME)
    assert (document.width, document.height) == (512, 512)
    assert parse_orzan(_scene(size=""), NAME).height == 512


def test_colours_outside_0_255_are_clamped_and_fractions_kept() -> None:
    left = _stop("left_color", r="-20", g="127.5", b="300")
    curve = parse_orzan(_orzan(_curve(left=left)), NAME).curves[0]
    assert curve.left[0].color == pytest.approx((1.0, 0.5, 0.0))


def test_an_alpha_attribute_is_read_on_the_colour_scale_and_its_absence_is_opaque() -> None:
    def alpha(stop: str, value: str) -> str:
        return stop.replace(" />", f' A="{value}" />')

    left = alpha(_stop("left_color"), "51") + alpha(_stop("left_color", globalid="5"), "400")
    right, scene_left = alpha(_stop("right_color"), "-3"), alpha(_stop("left_color"), "127.5")
    curve = parse_orzan(_orzan(_curve(left=left, right=right), _curve()), NAME).curves
    assert [stop.alpha for stop in curve[0].left] == pytest.approx([0.2, 1.0])  # clamped as the channels are
    assert curve[0].right[0].alpha == 0.0 and curve[1].left[0].alpha == curve[1].right[0].alpha == 1.0
    assert parse_orzan(_scene(_curve(left=scene_left)), NAME).curves[0].right[0].alpha == pytest.approx(0.5)
    unreadable = _orzan(_curve(left=left.replace('A="51"', 'A="half"')))
    assert "left_color 1: A='half' is not a number" in str(_load_error(unreadable))


def test_empty_colour_sides_and_missing_blur_load_empty() -> None:
    curve = parse_orzan(_orzan(_curve(left="", right="", blur="")), NAME).curves[0]
    assert curve.left == () and curve.right == () and curve.blur == ()


def test_empty_curve_set_gives_an_empty_document() -> None:
    notes = []
    document = parse_orzan(_orzan(), NAME, notes)
    assert document.curves == () and (document.width, document.height) == (300, 200)
    assert notes == ["the file holds no diffusion curve"]


def test_a_scenes_meshes_and_poisson_curves_are_named_as_not_imported() -> None:
    mesh = '<mesh><position_set><position x="0" y="0"/></position_set></mesh>'
    one_each, notes = _scene(_curve()), []
    assert len(parse_orzan(one_each.replace(b"</mesh_set>", f"{mesh}</mesh_set>".encode()), NAME, notes).curves) == 1
    assert notes == ["not imported: 1 gradient mesh, 1 Poisson curve (the editor draws diffusion curves alone)"]
    meshes_alone = one_each.replace(b"</mesh_set>", f"{mesh}{mesh}</mesh_set>".encode())
    meshes_alone = meshes_alone.replace(b'<poisson_curve nb', b'<other nb').replace(b"</poisson_curve>", b"</other>")
    parse_orzan(meshes_alone, NAME, notes := [])
    assert notes == ["not imported: 2 gradient meshes (the editor draws diffusion curves alone)"]
    parse_orzan(_orzan(_curve()), NAME, notes := [])
    assert notes == []  # everything read


# ---------------------------------------------------------------------------------------------
# control point counts


@pytest.mark.parametrize("count", [0, 1, 3, 5, 6, 8])
def test_control_point_count_not_3k_plus_1_is_an_error(count: int) -> None:
    points = [(str(i), str(i)) for i in range(count)]
    error = _load_error(_orzan(_curve(), _curve(points)))
    assert f"curve 2 has {count} control points" in str(error)
    assert "3k+1" in str(error)


# ---------------------------------------------------------------------------------------------
# malformed input


@pytest.mark.parametrize(
    "data",
    [b"", b"hello, world", b"\x00\xff\xfe binary", b"<curve_set image_width='5'", b"<a><b></a>"],
    ids=["empty", "text", "binary", "unclosed", "mismatched"],
)
def test_not_xml_is_an_error(data: bytes) -> None:
    assert "XML" in str(_load_error(data))


def test_truncated_file_is_an_error() -> None:
    data = _orzan(_curve(), _curve())
    _load_error(data[: len(data) // 2])


def test_unknown_encoding_is_an_error() -> None:
    _load_error(b'<?xml version="1.0" encoding="no-such-codec"?><curve_set/>')


def test_wrong_root_element_is_an_error() -> None:
    assert "<svg>" in str(_load_error(b'<svg width="10" height="10"></svg>'))


@pytest.mark.parametrize(("attribute", "value"), [("x", "12"), ("y", "40")])
def test_missing_control_point_attribute_is_an_error(attribute: str, value: str) -> None:
    original = _orzan(_curve())
    data = original.replace(f' {attribute}="{value}"'.encode(), b"", 1)
    assert data != original
    error = _load_error(data)
    assert f"attribute {attribute} is missing" in str(error) and "curve 1" in str(error)


@pytest.mark.parametrize("attribute", ["R", "G", "B", "globalID"])
def test_missing_colour_attribute_is_an_error(attribute: str) -> None:
    left = _stop("left_color").replace(f' {attribute}="0"', "").replace(f'<left_color {attribute}="0"', "<left_color")
    assert attribute not in left
    assert f"attribute {attribute} is missing" in str(_load_error(_orzan(_curve(left=left))))


def test_missing_blur_attribute_is_an_error() -> None:
    _load_error(_orzan(_curve(blur='<best_scale globalID="0" />')))


@pytest.mark.parametrize(
    ("old", "new"),
    [(b'x="12"', b'x="twelve"'), (b'y="40"', b'y=""'), (b'globalID="0"', b'globalID="0x1"'), (b'B="0"', b'B="1,5"')],
)
def test_non_numeric_attribute_is_an_error(old: bytes, new: bytes) -> None:
    data = _orzan(_curve())
    assert old in data
    assert "not a number" in str(_load_error(data.replace(old, new, 1)))


@pytest.mark.parametrize("value", ["nan", "inf", "-Infinity", "1e999"])
@pytest.mark.parametrize("old", ['x="12"', 'y="40"', 'R="0"', 'globalID="0"', 'value="0"'])
def test_non_finite_number_is_an_error(old: str, value: str) -> None:
    data = _orzan(_curve()).decode()
    assert old in data
    name = old.split("=")[0]
    error = _load_error(data.replace(old, f'{name}="{value}"', 1).encode())
    assert "not a finite number" in str(error)


@pytest.mark.parametrize("value", ["0", "-5", "40000", "12.5", "abc", "nan", ""])
@pytest.mark.parametrize("attribute", ["image_width", "image_height"])
def test_bad_canvas_size_is_an_error(attribute: str, value: str) -> None:
    size = f'image_width="300" image_height="200" {attribute}="{value}"'
    size = size.replace(f'{attribute}="{"300" if attribute == "image_width" else "200"}" ', "", 1)
    assert size.count(attribute) == 1
    assert attribute in str(_load_error(_orzan(_curve(), size=size)))


def test_bad_scene_size_is_an_error() -> None:
    _load_error(_scene(_curve(), size='image_width="-1" image_height="10"'))


def test_entity_expansion_bomb_is_refused() -> None:
    bomb = (
        b'<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!ENTITY lol "lol">\n'
        + b"".join(
            f' <!ENTITY lol{i} "{("&lol" + (str(i - 1) if i > 1 else "") + ";") * 10}">\n'.encode()
            for i in range(1, 10)
        )
        + b']>\n<curve_set image_width="10" image_height="10">&lol9;</curve_set>'
    )
    assert "entities" in str(_load_error(bomb))


def test_external_entity_is_refused() -> None:
    data = (
        b'<!DOCTYPE curve_set [<!ENTITY ext SYSTEM "file:///etc/passwd">]>'
        b'<curve_set image_width="10" image_height="10">&ext;</curve_set>'
    )
    assert "entities" in str(_load_error(data))


def test_doctype_without_internal_subset_loads() -> None:
    assert parse_orzan(b'<!DOCTYPE CurveSetXML>\n<curve_set image_width="8" image_height="9"/>', NAME).width == 8


def test_missing_file_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(DocumentLoadError, match="no_such_file.xml: file not found"):
        load_orzan(tmp_path / "no_such_file.xml")


def test_unreadable_path_is_an_error(tmp_path: Path) -> None:
    folder = tmp_path / "folder.xml"
    folder.mkdir()
    with pytest.raises(DocumentLoadError, match="folder.xml: cannot read"):
        load_document(folder)


def test_huge_file_is_refused_before_reading(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    huge = tmp_path / "huge.xml"
    with open(huge, "wb") as stream:
        stream.truncate(safe_xml.MAX_FILE_BYTES + 1)  # sparse: no data written

    def no_reading(*args, **kwargs):
        raise AssertionError("the file must not be opened")

    monkeypatch.setattr("builtins.open", no_reading)
    with pytest.raises(DocumentLoadError, match="huge.xml: the file is larger than 256 MiB"):
        load_orzan(huge)


def test_huge_bytes_are_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(safe_xml, "MAX_FILE_BYTES", 16)
    assert "larger than" in str(_load_error(_orzan(_curve())))


def test_file_errors_name_the_file_and_curve(tmp_path: Path) -> None:
    path = tmp_path / "lady_bug.xml"
    path.write_bytes(_orzan(_curve(), _curve(), _curve([("1", "2")] * 5)))
    with pytest.raises(DocumentLoadError) as caught:
        load_orzan(path)
    assert str(caught.value) == (
        "lady_bug.xml: curve 3 has 5 control points; a chain of cubic Beziers needs 3k+1 (4, 7, 10, ...)"
    )
    assert caught.value.source == "lady_bug.xml"


# ---------------------------------------------------------------------------------------------
# load_document and the error type


def test_load_document_dispatches_on_suffix(tmp_path: Path) -> None:
    upper = tmp_path / "CURVES.XML"
    upper.write_bytes(_orzan(_curve()))
    assert len(load_document(upper).curves) == 1
    other = tmp_path / "drawing.svg"  # read as SVG, by its suffix: an Orzan root is not SVG
    other.write_bytes(_orzan(_curve()))
    with pytest.raises(DocumentLoadError, match="drawing.svg: not an SVG file"):
        load_document(other)
    unknown = tmp_path / "drawing.ai"
    unknown.write_bytes(_orzan(_curve()))
    with pytest.raises(DocumentLoadError, match="drawing.ai: unsupported file type '.ai'"):
        load_document(unknown)


def test_document_load_error_pickles() -> None:
    error = pickle.loads(pickle.dumps(DocumentLoadError("a.xml", "broken")))
    assert (str(error), error.source, error.problem) == ("a.xml: broken", "a.xml", "broken")
