"""What a layered picture is drawn from, and its composition sample by sample (docs/design.md section 5).

``Composite`` holds each visible layer's representation with its mask's and
alpha's, opacity and colour transform; ``compose`` blends their values sample
by sample, ``out = m S(V) + (1 - m) out_below`` with ``m = clamp(a, 0, 1)
opacity clamp(M, 0, 1)`` (``a`` the layer's alpha field, 1 for an opaque
layer; 0 or 1 within ``NEGLIGIBLE_WEIGHT`` of them, ``snapped``) and
``S(V) = clamp(T(clamp(V, 0, 1)), 0, 1)`` what the layer shows,
from the topmost layer that covers everything (what lies below it cannot
show).
Clamping each layer before blending makes the picture below a layer what the
user saw there: a glow that shows white is (4, 2.7, 1.5) underneath, and
blending that unclamped with green showed yellow fringes.  Composing the
values exactly, rather than the cells' polynomials as the paper's merged
coefficients (its equation 32) would, keeps a mask's edge and a product's
dropped terms out of the picture.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import StrEnum
from functools import cached_property

import numpy as np

from ..model.color_transform import IDENTITY, ColorTransform
from ..model.layer import MASK_LUMA
from .blending import blend_layer, layer_weights
from .representation import Representation, same_geometry

#: A layer's weight within this of 0 (or 1) is 0 (1): a sharp mask is 0 or 1 only to its expansions' accuracy, 1e-6
#: on lady_bug, and so would let the layer below it show by as much.  So weighted, a layer is not drawn where it
#: is hidden (``hidden``) and leaves the picture exactly as it was (or replaces it) there; the picture moves by at
#: most this much, every colour being in [0, 1] (1/400 of an 8-bit level).
NEGLIGIBLE_WEIGHT = 1e-5


def snapped(weight: np.ndarray | float) -> np.ndarray | float:
    """``weight`` with the values within ``NEGLIGIBLE_WEIGHT`` of 0 or 1 made 0 or 1."""
    return np.where(weight <= NEGLIGIBLE_WEIGHT, 0.0, np.where(weight >= 1.0 - NEGLIGIBLE_WEIGHT, 1.0, weight))


class Role(StrEnum):
    """What a layer's field is: its ``IMAGE``, its ``MASK``, a clone layer's ``SOURCE`` (kept, not drawn), its
    ``ALPHA`` (the diffusion of its stops' alphas, ``model.alpha``) or its ``BLUR`` (of its blur stops,
    ``model.blur``: the deviation that softens it, where the blur is shown)."""

    IMAGE = "image"
    MASK = "mask"
    SOURCE = "source"
    ALPHA = "alpha"
    BLUR = "blur"


#: A layer's field: ``(layer id, role)``.
FieldKey = tuple[int, Role]


@dataclass(frozen=True)
class LayerFields:
    """One layer as the engine draws it.

    Attributes
    ----------
    image : Representation
        The layer's diffusion image.
    mask : Representation or None
        The mask's diffusion image (its luminance plus ``mask_base`` is the
        mask); None for a mask without items (``mask_base`` everywhere) or no
        mask at all (base 1).
    mask_base : float
    mask_inverted : bool
    mask_enabled : bool
        False draws the layer as without a mask.
    opacity : float
    transform : ColorTransform
    visible : bool
        False for a hidden layer, and for an empty one (``model.Layer.empty``: clear).
    id : int
        The layer's stable id (``model.Layer.id``), by which views keep what they made of it.
    source : Representation or None
        A clone layer's source image (what a file keeps so that opening solves nothing); not drawn.
    alpha : Representation or None
        The layer's alpha field (its first channel, clamped to [0, 1], is the layer's coverage); None for an
        opaque layer.
    blur : Representation or None
        The layer's blur field (its first channel, clamped at 0, the deviation in document pixels by which
        the layer's image and alpha are softened, ``engine.blur``); None for a sharp layer, or where the
        blur is not shown.
    """

    image: Representation
    mask: Representation | None = None
    mask_base: float = 1.0
    mask_inverted: bool = False
    mask_enabled: bool = True
    opacity: float = 1.0
    transform: ColorTransform = IDENTITY
    visible: bool = True
    id: int = 0
    source: Representation | None = None
    alpha: Representation | None = None
    blur: Representation | None = None

    @property
    def covers(self) -> bool:
        """True when the layer's weight is 1 everywhere, hiding all below."""
        if self.alpha is not None:
            return False
        if not self.mask_enabled:
            return self.opacity == 1.0
        value = self.mask_base if not self.mask_inverted else 1.0 - self.mask_base
        return self.opacity == 1.0 and self.mask is None and value >= 1.0

    @property
    def masked(self) -> bool:
        """True when the weight varies over the canvas (an enabled mask with items)."""
        return self.mask_enabled and self.mask is not None

    @cached_property
    def carries_alpha(self) -> bool:
        """Whether the alpha field can be evaluated as its image's fourth channel (the canvas's ``packing``, the
        raster's kernels of four channels): the same segments, lattice and order, no points of its own, and no
        blur (a blurred layer's image and alpha are blurred apart).  Kept: every band of a raster and every draw
        asks, and comparing the segments reads them all."""
        image, alpha = self.image, self.alpha
        return (alpha is not None and self.blur is None and alpha.points is None and alpha.order == image.order
                and alpha.lattice.cells_per_side == image.lattice.cells_per_side
                and alpha.lattice.cell_size == image.lattice.cell_size and len(alpha.near[0].p) > 0
                and same_geometry(image, alpha))

    @cached_property
    def settled(self) -> np.ndarray:
        """``(2^L, 2^L)`` bool on its mask's lattice: the cells where its mask's bounds settle its weight
        (``settled``; its mask's ``Representation.scalar_bounds`` of the luminance).  Kept: every band of a raster
        asks."""
        return settled(self, *self.mask.scalar_bounds(MASK_LUMA))

    @property
    def read(self) -> tuple[tuple[Role, Representation], ...]:
        """What drawing the layer reads: ``(Role.IMAGE, image)``, ``(Role.MASK, mask)`` when ``masked`` and
        ``(Role.ALPHA, alpha)`` when it has one."""
        return (((Role.IMAGE, self.image),) + (((Role.MASK, self.mask),) if self.masked else ())
                + (((Role.ALPHA, self.alpha),) if self.alpha is not None else ()))

    def weight(self, mask_values: np.ndarray | None, alpha_values: np.ndarray | None = None) -> np.ndarray | float:
        """``k = clamp(a, 0, 1) * opacity * clamp(M, 0, 1)``, ``snapped``, from the mask's colour values ``(..., 3)``
        (None: constant) and the alpha field's (None: opaque; its first channel is ``a``)."""
        weight = self.opacity
        if self.mask_enabled:
            value = self.mask_base if mask_values is None else mask_values @ MASK_LUMA + self.mask_base
            if self.mask_inverted:
                value = 1.0 - value
            weight = weight * np.clip(value, 0.0, 1.0)
        if alpha_values is not None:
            weight = weight * np.clip(alpha_values[..., 0], 0.0, 1.0)
        return snapped(weight)


@dataclass(frozen=True)
class Composite:
    """A layered picture: every layer of a document, bottom first, on a ``width x height`` canvas."""

    width: int
    height: int
    layers: tuple[LayerFields, ...]

    @property
    def shown(self) -> tuple[LayerFields, ...]:
        """The layers that can show: the visible ones from the topmost that covers everything, up."""
        visible = [layer for layer in self.layers if layer.visible]
        start = max((i for i, layer in enumerate(visible) if layer.covers), default=0)
        return tuple(visible[start:])

    @property
    def sharp(self) -> Composite:
        """This picture without its layers' blur fields: every edge sharp."""
        return replace(self, layers=tuple(replace(layer, blur=None) for layer in self.layers))

    @property
    def representations(self) -> tuple[Representation, ...]:
        """Every representation ``shown`` reads: images and masks."""
        return tuple(rep for layer in self.shown for _, rep in layer.read)


def shown_colour(layer: LayerFields, colour: np.ndarray) -> np.ndarray:
    """What ``layer`` shows where its image's values are ``colour (..., 3)``: ``clamp(T(clamp(colour)))``."""
    colour = np.clip(colour, 0.0, 1.0)
    if layer.transform.is_identity:
        return colour
    return np.clip(layer.transform.apply(colour), 0.0, 1.0)


def compose(composite: Composite, values: Callable[[Representation], np.ndarray], shape: tuple[int, ...],
            coverage: bool = False, out: np.ndarray | None = None) -> np.ndarray:
    """The composite's colours, of ``shape`` ``(..., 3)``, given ``values(rep)`` of each representation there.

    In [0, 1] (each layer is clamped before it is blended): the picture over black, which is its colour
    premultiplied by its coverage.  With ``coverage``, ``(..., 4)``: the coverage ``a`` after the colour,
    ``a <- m + (1 - m) a`` from 0 up the layers (1 where a layer covers, 0 where nothing shows).
    Each layer is blended in one compiled pass (``blending.blend_layer``); ``compose_reference`` is the plain form.
    An image's values may have a fourth channel: its layer's alpha field, carried (``LayerFields.carries_alpha``),
    and then that alpha field's own values are not read.  A mask's or an alpha field's values may be the one
    channel it is read through (``scalar_reads``).  ``out``: a C-contiguous float64 array of ``shape`` (without
    ``coverage``) to write the colours into and return; the bottom layer's image values may be ``out`` itself
    (read before anything is written there), blended in place.
    """
    count, shown = int(np.prod(shape[:-1])), composite.shown
    if out is not None and (coverage or out.shape != shape or out.dtype != np.float64 or not out.flags.c_contiguous):
        raise ValueError(f"out must be a C-contiguous float64 array of shape {shape}, without coverage")
    picture = out.reshape(count, 3) if out is not None else np.empty((count, 3))
    alpha = np.empty(count)
    if not shown:
        picture[...], alpha[...] = 0.0, 0.0
    for index, layer in enumerate(shown):  # the bottom one writes every sample
        transform = layer.transform
        colour = _samples(values(layer.image), count)
        in_place = colour.shape == picture.shape and colour.ctypes.data == picture.ctypes.data
        blend_layer(picture, alpha, _NO_SAMPLES if in_place else colour, transform.matrix, transform.offset,
                    not transform.is_identity, _samples(values(layer.mask), count) if layer.masked else _NO_SAMPLES,
                    MASK_LUMA, float(layer.mask_base), layer.mask_enabled, layer.mask_inverted, NEGLIGIBLE_WEIGHT,
                    *_alpha_samples(layer, values, count, colour), float(layer.opacity), layer.covers, index == 0,
                    in_place)
    picture = picture.reshape(shape)
    return np.concatenate([picture, alpha.reshape(shape[:-1])[..., None]], axis=-1) if coverage else picture


def hidden(composite: Composite, values: Callable[[Representation], np.ndarray], count: int) -> list[np.ndarray]:
    """For each of ``composite.shown``, bool ``(count,)``: the samples where its image does not show, its weight
    being 0 there or a layer above it weighing 1 there (covering it), weights ``snapped``.

    ``compose`` takes nothing from an image there, as long as its values are finite: they need not be
    evaluated.  Reads ``values`` of the masks and alpha fields of the layers whose weight varies (of a carried
    alpha field: its image's four channels, as ``compose`` may read them).
    """
    shown = composite.shown
    covered = np.zeros(count, bool)
    result: list[np.ndarray] = [covered] * len(shown)
    for index in range(len(shown) - 1, -1, -1):
        layer = shown[index]
        if layer.covers:  # the bottom of what is shown
            result[index] = covered
            break
        weight = np.empty(count)
        layer_weights(weight, _samples(values(layer.mask), count) if layer.masked else _NO_SAMPLES, MASK_LUMA,
                      float(layer.mask_base), layer.mask_enabled, layer.mask_inverted, NEGLIGIBLE_WEIGHT,
                      *_alpha_samples(layer, values, count), float(layer.opacity))
        result[index] = covered | (weight == 0.0)
        covered = covered | (weight == 1.0)
    return result


#: What the raster's float64 rounding may move a field's value by beyond its bounds (``value_bounds``, which count
#: its float32 near field's and its sub-cells' errors): far below ``NEGLIGIBLE_WEIGHT``.
ROUNDING = 1e-9


def settled(layer: LayerFields, centre: np.ndarray, spread: np.ndarray) -> np.ndarray:
    """Where the weight of ``layer`` is one value for every mask luminance within ``spread`` (plus ``ROUNDING``) of
    ``centre`` (arrays alike, its mask's ``Representation.scalar_bounds``): 0 (snapped), the mask's factor 0 or 1
    exactly, or, without an alpha field, 1 (snapped).  There any luminance in that range, the centre's say, gives
    ``compose`` and ``hidden`` what the mask's values would."""
    low = centre - spread - ROUNDING + layer.mask_base
    high = centre + spread + ROUNDING + layer.mask_base
    if layer.mask_inverted:
        low, high = 1.0 - high, 1.0 - low
    nothing = layer.opacity * np.clip(high, 0.0, 1.0) <= NEGLIGIBLE_WEIGHT
    exact = (high <= 0.0) | (low >= 1.0)
    if layer.alpha is not None:
        return nothing | exact
    return nothing | exact | (layer.opacity * np.clip(low, 0.0, 1.0) >= 1.0 - NEGLIGIBLE_WEIGHT)


_NO_SAMPLES = np.zeros((0, 3))
#: The weights of the one channel an alpha field (and a blur field) is read through: its first.
FIRST_CHANNEL = np.array([1.0, 0.0, 0.0])
#: The fields read through one value a sample, by role, and its weights: a mask through its luminance, an alpha
#: and a blur field through their first channel (the raster's ``scalar_reads``, the canvas's scalar renderers).
SCALAR_WEIGHTS = {Role.MASK: MASK_LUMA, Role.ALPHA: FIRST_CHANNEL, Role.BLUR: FIRST_CHANNEL}


def scalar_reads(composite: Composite) -> dict[int, np.ndarray]:
    """By ``id``, the representations ``composite.shown`` reads only through one combination ``w . colour`` of
    their channels, and that ``w (3,)``: a mask's luminance (``MASK_LUMA``), an alpha field's first channel
    (``FIRST_CHANNEL``).  ``compose`` and ``hidden`` take such a field's values as that one channel ``(..., 1)`` or
    as its colour; a field read in two ways (a mask that is also an image, say) is not listed."""
    roles: dict[int, set[Role]] = {}
    for layer in composite.shown:
        for role, rep in layer.read:
            roles.setdefault(id(rep), set()).add(role)
    return {key: SCALAR_WEIGHTS[role] for key, (role, *others) in roles.items()
            if not others and role in SCALAR_WEIGHTS}


def _samples(values: np.ndarray, count: int) -> np.ndarray:
    """``values (..., k)`` as ``(count, k)`` float64, C-contiguous (a view where they are)."""
    return np.ascontiguousarray(values, np.float64).reshape(count, -1)


def _alpha_samples(layer: LayerFields, values: Callable[[Representation], np.ndarray], count: int,
                   colour: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """``blend_layer``'s ``alpha`` and ``alpha_column`` of ``layer``: none, the alpha field's first channel, or the
    fourth of its image's ``colour`` values (or, without them, of what ``values`` gives of its alpha field) that
    carry it (``carries_alpha``)."""
    if layer.alpha is None:
        return _NO_SAMPLES, 0
    if colour is not None and colour.shape[1] == 4 and layer.carries_alpha:
        return colour, 3
    alpha = _samples(values(layer.alpha), count)
    return alpha, 3 if alpha.shape[1] == 4 else 0


def compose_reference(composite: Composite, values: Callable[[Representation], np.ndarray], shape: tuple[int, ...],
                      coverage: bool = False) -> np.ndarray:
    """``compose`` in plain numpy, a pass over the samples for each step."""
    out = np.zeros(shape)
    alpha = np.zeros(shape[:-1])
    for layer in composite.shown:
        colour = shown_colour(layer, values(layer.image))
        if layer.covers:
            out, alpha = colour, np.ones(shape[:-1])
            continue
        weight = np.asarray(layer.weight(values(layer.mask) if layer.masked else None,
                                         values(layer.alpha) if layer.alpha is not None else None))
        out += weight[..., None] * (colour - out)
        alpha += weight * (1.0 - alpha)
    return np.concatenate([out, alpha[..., None]], axis=-1) if coverage else out
