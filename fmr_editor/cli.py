"""Command line: the editor, and headless rendering.

``fmr-editor [FILE ...]`` opens the editor (each FILE in a tab, or a new document);
``fmr-editor render INPUT -o OUT.png`` or ``fmr-editor render A.xml B.xml ... -o DIR``
renders without a window; ``fmr-editor compose BOTTOM TOP -o OUT.fmr [--mask
MASK] [--opacity A] [--hue DEGREES]`` layers two documents into one;
``fmr-editor clone TARGET SOURCE --region "x1,y1 x2,y2 ..." -o OUT.fmr``
pastes a region of SOURCE seamlessly into TARGET.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from . import __version__


def _colour(text: str) -> tuple[float, float, float]:
    from .io.png import parse_hex_colour

    try:
        return parse_hex_colour(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive whole number, got {text}")
    return value


def _editor_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fmr-editor", usage="fmr-editor [FILE ...]\n       fmr-editor render INPUT ... -o OUTPUT [options]\n"
                                  "       fmr-editor compose BOTTOM TOP -o OUT.fmr [options]\n"
                                  "       fmr-editor clone TARGET SOURCE --region POLYGON -o OUT.fmr [options]",
        description="Diffusion-curve images on the fast multipole representation. Without a command, opens the "
                    "editor (each FILE in a tab, or a new document); 'fmr-editor render --help' tells how to render "
                    "documents to PNG without a window, 'fmr-editor compose --help' how to layer two documents, "
                    "'fmr-editor clone --help' how to paste a region of one into another seamlessly.")
    parser.add_argument("files", nargs="*", metavar="FILE",
                        help="documents to open, each in a tab (.fmr, or Orzan CurveSetXML .xml)")
    parser.add_argument("--version", action="version", version=f"fmr-editor {__version__}")
    return parser


def run_editor(args: argparse.Namespace) -> int:
    """Open the editor (needs a display) on the files; 2 with one line on stderr when it cannot start.

    A file that cannot be opened is named in the window, and the others open (as when a file manager opens
    several at once).
    """
    from .ui.app import main as editor_main

    return editor_main(args.files)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="fmr-editor",
                                     description="Diffusion-curve images on the fast multipole representation.")
    commands = parser.add_subparsers(dest="command", required=True)
    render = commands.add_parser("render", help="render documents to PNG, or SVG (an .svg output)")
    render.add_argument("inputs", nargs="+", metavar="INPUT",
                        help="documents to render (.fmr, or Orzan CurveSetXML .xml)")
    render.add_argument("-o", "--output", required=True,
                        help="PNG file to write (an .svg file: the PNG embedded, the curves as hidden paths), or "
                             "with several inputs a folder (made if missing) for NAME.png each")
    render.add_argument("--width", type=_positive, help="output width (default: canvas width)")
    render.add_argument("--height", type=_positive, help="output height (default: canvas height)")
    render.add_argument("--samples", type=_positive, default=3,
                        help="N x N samples per pixel (default 3; 1 = pixel centre)")
    render.add_argument("--order", type=int, help="degree of the cell polynomials (default 8)")
    render.add_argument("--method", choices=("fmr", "direct"), default="fmr",
                        help="fmr (default) or direct summation (slow, for checking)")
    render.add_argument("--blur", action=argparse.BooleanOptionalAction, default=True,
                        help="soften the picture by its curves' blur stops, as the editor shows it with View > Show "
                             "Blur (default; --no-blur: every edge sharp)"),
    render.add_argument("--background", type=_colour, metavar="RRGGBB",
                        help="lay a picture that is not opaque on this colour (default: an RGBA PNG)")
    compose = commands.add_parser("compose", help="layer TOP over BOTTOM into a two-layer .fmr document")
    compose.add_argument("bottom", metavar="BOTTOM", help="the lower layer's document (.fmr or .xml)")
    compose.add_argument("top", metavar="TOP", help="the upper layer's document, on the same canvas size")
    compose.add_argument("-o", "--output", required=True, help=".fmr file to write")
    compose.add_argument("--mask", metavar="MASK", help="a document whose luminance (0.2126 R + 0.7152 G + "
                         "0.0722 B) masks TOP: white shows it, black hides it")
    compose.add_argument("--opacity", type=_unit, default=1.0, help="TOP's opacity, from 0 to 1 (default 1)")
    compose.add_argument("--hue", type=_finite, default=0.0, metavar="DEGREES",
                         help="rotate TOP's hues (W3C hueRotate)")
    clone = commands.add_parser("clone", help="paste a region of SOURCE seamlessly into TARGET (Poisson cloning)")
    clone.add_argument("target", metavar="TARGET", help="the document to paste into (.fmr or .xml)")
    clone.add_argument("source", metavar="SOURCE", help="the document to copy from (its active layer)")
    clone.add_argument("--region", required=True, type=_polygon, metavar='"x1,y1 x2,y2 ..."',
                       help="the region to copy: a polygon in SOURCE's pixels, at least three corners")
    clone.add_argument("--offset", type=_pair, default=(0.0, 0.0), metavar="DX,DY",
                       help="move the region by this much into TARGET, pixels (default 0,0)")
    clone.add_argument("--rotate", type=_finite, default=0.0, metavar="DEGREES",
                       help="turn the region about its centroid, clockwise on screen (y points down)")
    clone.add_argument("--scale", type=_finite, default=1.0, help="scale the region about its centroid (default 1)")
    clone.add_argument("-o", "--output", required=True, help=".fmr file to write: TARGET with the clone layer on top")
    return parser


def _pair(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"must be two numbers as X,Y, got {text!r:.60}")
    return _finite(parts[0]), _finite(parts[1])


def _polygon(text: str) -> list[tuple[float, float]]:
    corners = [_pair(corner) for corner in text.replace(";", " ").split()]
    if len(corners) < 3:
        raise argparse.ArgumentTypeError(f"a region needs at least three corners as \"x1,y1 x2,y2 x3,y3\", "
                                         f"got {len(corners)}")
    return corners


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text}")
    return value


def _unit(text: str) -> float:
    value = _finite(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must lie between 0 and 1, got {text}")
    return value


class StderrProgress:
    """Prints ``stage NN%`` lines on stderr, at most one per stage and ten percent."""

    def __init__(self, stream=None) -> None:
        self.stream = stream
        self.last: tuple[str, int] | None = None
        self.start = time.perf_counter()

    def __call__(self, stage: str, fraction: float) -> None:
        step = (stage, int(fraction * 10))
        if step != self.last:
            self.last = step
            print(f"[{time.perf_counter() - self.start:6.1f}s] {stage} {fraction:4.0%}",
                  file=self.stream or sys.stderr, flush=True)


def render_one(source: str, output: str, args: argparse.Namespace) -> int:
    """Render ``source`` to ``output``, a PNG, or an SVG by its suffix (the PNG embedded, the curves kept as
    hidden paths); 0, or 2 after one line on stderr.

    A ``.fmr`` file's saved representation is rendered as it is (no solve),
    unless ``--order`` or ``--method direct`` ask for another.
    """
    from . import load, render_image
    from .engine import LiveStack, Settings, check_image_memory, output_size, rasterise
    from .io import DocumentLoadError, load_fmr, save_picture
    from .io.png import flattened
    from .model.blur import blurred

    try:
        saved = load_fmr(source) if Path(source).suffix.lower() == ".fmr" else None
        document = saved.document if saved is not None else load(source)
    except DocumentLoadError as error:
        print(f"fmr-editor: cannot open {error}", file=sys.stderr)
        return 2
    progress = StderrProgress()
    try:
        check_image_memory(*output_size(document.width, document.height, args.width, args.height))
        if saved is not None and args.order is None and args.method == "fmr":
            picture = saved.composite  # every representation saved: no solve
            if picture is not None and not args.blur:
                picture = picture.sharp
            elif picture is not None and any(blurred(layer) and drawn.blur is None
                                             for layer, drawn in zip(document.layers, picture.layers)):
                picture = None  # saved without its blur fields
            if picture is None:
                picture = LiveStack(document, saved.settings or Settings(), progress, saved.fields,
                                    blur=args.blur).composite
            image = rasterise(picture, args.width, args.height, samples=args.samples, progress=progress,
                              coverage=True)
            image = image.clip(0.0, 1.0)
        else:
            image = render_image(document, args.width, args.height, samples=args.samples, order=args.order,
                                 method=args.method, progress=progress, coverage=True, blur=args.blur)
    except (ValueError, MemoryError) as error:
        print(f"fmr-editor: cannot render {source}: {error}", file=sys.stderr)
        return 2
    if args.background is not None:
        image = flattened(image, args.background)
    try:
        written = save_picture(document, image, output)
    except OSError as error:
        print(f"fmr-editor: cannot write {output}: {error.strerror or error}", file=sys.stderr)
        return 2
    print(f"wrote {written} ({image.shape[1]}x{image.shape[0]})")
    return 0


def run_render(args: argparse.Namespace) -> int:
    """One input to a file, or several into a folder; every input is tried, 2 if any failed."""
    if len(args.inputs) == 1 and not Path(args.output).is_dir():
        return render_one(args.inputs[0], args.output, args)
    stems = [Path(source).stem for source in args.inputs]
    clashes = {stem for stem in stems if stems.count(stem) > 1}
    if clashes:
        print(f"fmr-editor: several inputs would write {', '.join(sorted(clashes))}.png; rename or render them apart",
              file=sys.stderr)
        return 2
    folder = Path(args.output)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        print(f"fmr-editor: cannot make the folder {folder}: {error.strerror or error}", file=sys.stderr)
        return 2
    failed = [source for source, stem in zip(args.inputs, stems)
              if render_one(source, str(folder / f"{stem}.png"), args)]
    if failed:
        print(f"fmr-editor: {len(failed)} of {len(args.inputs)} documents failed", file=sys.stderr)
    return 2 if failed else 0


def run_compose(args: argparse.Namespace) -> int:
    """Write TOP over BOTTOM (masked, faded, hue-rotated) as a two-layer ``.fmr``; 0, or 2 after one line on stderr.

    Saved representations of ``.fmr`` inputs built with the first one's
    settings are taken as they are; the others are solved.  Nothing is
    written when anything fails.
    """
    from .engine import Settings
    from .io import DocumentLoadError, load_fmr
    from .model import layer_edits
    from .model.color_transform import hue_rotation

    if Path(args.output).suffix.lower() != ".fmr":
        print(f"fmr-editor: compose writes an .fmr document, not {args.output}", file=sys.stderr)
        return 2
    sources = {"bottom": args.bottom, "top": args.top} | ({"mask": args.mask} if args.mask else {})
    documents, saved, settings = {}, {}, None
    try:
        for role, source in sources.items():
            if Path(source).suffix.lower() == ".fmr":
                opened = load_fmr(source)
                documents[role] = opened.document
                settings = settings or opened.settings  # the first file's settings: another file's representation
                if opened.settings is not None and opened.settings == settings:  # is taken when built with them
                    saved[role] = opened.representation
            else:
                from . import load

                documents[role] = load(source)
    except DocumentLoadError as error:
        print(f"fmr-editor: cannot open {error}", file=sys.stderr)
        return 2
    try:
        document = layer_edits.stacked(documents["bottom"], documents["top"], documents.get("mask"), args.opacity,
                                       hue_rotation(args.hue) if args.hue else None)
    except ValueError as error:
        print(f"fmr-editor: cannot compose: {error}", file=sys.stderr)
        return 2
    fields = [(saved.get("bottom"), None), (saved.get("top"), saved.get("mask"))]
    return _build_and_save(args.output, document, settings or Settings(), fields, "compose")


def _build_and_save(output: str, document, settings, saved: list, verb: str) -> int:
    """Build ``document``'s layers (``saved`` representations taken as they are) and save it with them to
    ``output``; 0, or 2 after one line on stderr saying why the command (``verb``) could not."""
    from .engine import LiveStack
    from .io import save_fmr

    try:
        stack = LiveStack(document, settings, StderrProgress(), saved)
        written = save_fmr(output, document, stack.composite, settings=settings)
    except (ValueError, MemoryError) as error:
        print(f"fmr-editor: cannot {verb}: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"fmr-editor: cannot write {output}: {error.strerror or error}", file=sys.stderr)
        return 2
    print(f"wrote {written} ({len(document.layers)} layers, {document.width}x{document.height})")
    return 0


def run_clone(args: argparse.Namespace) -> int:
    """Write TARGET with a seamless clone of SOURCE's region on top; 0, or 2 after one line on stderr.

    The region is turned and scaled about its centroid, then moved by the
    offset.  Saved representations of ``.fmr`` inputs are taken as they are
    (the source's when it is one plain layer built with the target's
    settings); nothing is written when anything fails.
    """
    import shapely

    from .engine import Settings
    from .io import DocumentLoadError, load_fmr
    from .model.clone import Similarity
    from .model.clone_edits import copy_region, paste_seamless

    if Path(args.output).suffix.lower() != ".fmr":
        print(f"fmr-editor: clone writes an .fmr document, not {args.output}", file=sys.stderr)
        return 2
    try:
        opened = [load_fmr(path) if Path(path).suffix.lower() == ".fmr" else None
                  for path in (args.target, args.source)]
        from . import load

        target, source = (file.document if file is not None else load(path)
                          for file, path in zip(opened, (args.target, args.source)))
    except DocumentLoadError as error:
        print(f"fmr-editor: cannot open {error}", file=sys.stderr)
        return 2
    settings = (opened[0].settings if opened[0] is not None else None) or Settings()
    try:
        if not (math.isfinite(args.scale) and args.scale > 0):
            raise ValueError(f"the scale must be positive, got {args.scale}")
        copied = copy_region(source, args.region)
        centroid = shapely.Polygon(copied.region).centroid
        similarity = Similarity().about((centroid.x, centroid.y), args.scale, args.rotate).moved(*args.offset)
        document = paste_seamless(target, copied, similarity)
    except ValueError as error:
        print(f"fmr-editor: cannot clone: {error}", file=sys.stderr)
        return 2
    saved = list(opened[0].fields) if opened[0] is not None else [()] * len(target.layers)
    source_saved = opened[1] is not None and opened[1].settings == settings and source.is_flat
    saved.insert(document.active, (None, None, opened[1].representation if source_saved else None))
    return _build_and_save(args.output, document, settings, saved, "clone")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``fmr-editor`` command: ``render``, ``compose`` and ``clone`` work headless, else the
    editor opens."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in ("render", "compose", "clone"):
        return run_editor(_editor_parser().parse_args(argv))
    args = _parser().parse_args(argv)
    from .engine import setup_process

    setup_process()
    return {"render": run_render, "compose": run_compose, "clone": run_clone}[args.command](args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
