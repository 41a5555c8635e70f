"""A layered document's representations, kept up to date edit by edit.

Every layer's image and every mask with items is a diffusion image of its
own, so each keeps its own ``LiveRepresentation`` (its lattice, solver and
kept states), under the layer's stable id.  An edit reaches only the fields
whose items changed: a dab in a mask is the mask's points update, a hue
change or an opacity change touches no representation at all (the
composite reads them when it is drawn).  Fields of layers that leave the
stack are kept a while (``RETIRED``), so undoing a deletion solves nothing.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..model import Document
from ..model.alpha import alpha_image
from ..model.blur import blur_image
from ..model.layer import Layer
from ..model.limits import check_document
from .cloning import LiveClone
from .composite import Composite, FieldKey, LayerFields, Role
from .kept_states import DEFAULT_MEMORY
from .live import LiveRepresentation, Progress, Update
from .memory import give_back_spare_pages
from .representation import Representation, Settings
from .solve.system_solvers import SharedFactorisations

#: Fields of removed layers kept for an undo.
RETIRED = 4



@dataclass(frozen=True)
class StackUpdate:
    """What one ``LiveStack.update`` did: each changed field's ``Update``, by ``FieldKey``."""

    fields: dict[FieldKey, Update]
    seconds: float

    @property
    def kind(self) -> str:
        """``"none"``, the one field's kind, or ``"layers"`` when several fields changed."""
        kinds = {update.kind for update in self.fields.values()} - {"none"}
        return kinds.pop() if len(kinds) == 1 else ("none" if not kinds else "layers")

    @property
    def exact(self) -> bool:
        return all(update.exact for update in self.fields.values())

    @property
    def stale(self) -> bool:
        return any(update.stale for update in self.fields.values())

    @property
    def changed(self) -> np.ndarray | None:
        """The changed cells of the one field updated (see ``Update.changed``); None when several or none were."""
        return next(iter(self.fields.values())).changed if len(self.fields) == 1 else None


def _wanted(document: Document, blur: bool = False) -> dict[FieldKey, Document]:
    """The one-image documents the engine solves for ``document``: each layer's image (a clone layer's
    source instead), each mask with items, each translucent layer's alpha and, with ``blur``, each blurred
    layer's blur field."""
    fields = {}
    for layer in document.layers:
        if layer.clone is not None:
            fields[layer.id, Role.SOURCE] = layer.clone.source
            continue
        fields[layer.id, Role.IMAGE] = document.flat(layer)
        if layer.mask is not None and not layer.mask.is_constant:
            fields[layer.id, Role.MASK] = document.flat(layer.mask)
        alpha = alpha_image(layer)
        if alpha is not None:
            fields[layer.id, Role.ALPHA] = document.flat(alpha)
        softness = blur_image(layer) if blur else None
        if softness is not None:
            fields[layer.id, Role.BLUR] = document.flat(softness)
    return fields


def _items_changed(before: Document, after: Document) -> bool:
    """True unless ``after`` holds the very curves and points of ``before`` on its canvas (a layer's settings
    changed, or nothing did): only then does the field need an update."""
    return (before.curves is not after.curves or before.points is not after.points
            or (before.width, before.height) != (after.width, after.height))


class LiveStack:
    """A layered document's representations and their composite.

    Parameters
    ----------
    document : Document
    settings : Settings
    progress : callable, optional
        ``progress(stage, fraction)`` over all the builds.
    saved : sequence, optional
        Per layer, its representations as saved in ``Role`` order, ``(image, mask)``, ``(image, mask,
        source)``, ``(image, mask, source, alpha)`` or ``(image, mask, source, alpha, blur)`` (any may be
        None): taken as they are, as ``LiveRepresentation`` takes one; a clone layer's image and mask with its
        source's; the blur fields once the blur is shown.
    memory : int
        Bytes the kept states of all fields may take, shared among them.
    blur : bool
        Solve each blurred layer's blur field too, so that the composite carries it (``show_blur``).

    Raises
    ------
    LimitError
        When ``document`` exceeds ``model.limits``, before any work.

    Attributes
    ----------
    document : Document
    fields : dict
        ``LiveRepresentation`` by ``FieldKey``: layers' images, masks,
        alphas, blur fields and clone layers' sources (``Role.SOURCE``).
    show_blur : bool
        True while blur fields are kept (``set_blur`` changes it).
    clones : dict
        ``cloning.LiveClone`` by clone layer id.
    """

    def __init__(self, document: Document, settings: Settings = Settings(), progress: Progress | None = None,
                 saved: Sequence[tuple[Representation | None, Representation | None]] | None = None,
                 memory: int = DEFAULT_MEMORY, blur: bool = False) -> None:
        check_document(document)
        self.settings = settings
        self.show_blur = blur
        self._memory = memory
        self.document = document
        self.fields: dict[FieldKey, LiveRepresentation] = {}
        self._factorisations = SharedFactorisations()  # a translucent layer's image and alpha share theirs
        self._retired: OrderedDict[FieldKey, LiveRepresentation] = OrderedDict()
        self.clones: dict[int, LiveClone] = {}
        self._below: dict[int, tuple] = {}  # per clone layer id, what lay below it when it was blended
        kept = {}
        for layer, fields in zip(document.layers, saved or ()):
            fields = dict(zip(Role, fields))
            if layer.clone is not None and fields.get(Role.IMAGE) is not None and fields.get(Role.MASK) is not None:
                self.clones[layer.id] = LiveClone(layer.clone, fields.pop(Role.IMAGE), fields.pop(Role.MASK))
                self._below[layer.id] = self._below_of(document, layer)
            kept.update({(layer.id, kind): rep for kind, rep in fields.items() if rep is not None})
        self._saved_blurs = {key: rep for key, rep in kept.items() if key[1] is Role.BLUR}  # for set_blur
        self._follow(document, progress, kept, exact=True)
        self._blend(document, {})  # the clones not saved
        give_back_spare_pages()

    @property
    def memory(self) -> int:
        """Bytes the kept states of all fields may take (a new budget holds from the next update on)."""
        return self._memory

    @memory.setter
    def memory(self, memory: int) -> None:
        self._memory = int(memory)

    def _follow(self, document: Document, progress: Progress | None, saved: dict[FieldKey, Representation],
                exact: bool) -> dict[FieldKey, Update]:
        wanted = _wanted(document, self.show_blur)
        share = self._memory // max(1, len(wanted))
        for live in self.fields.values():
            live.memory = share
        updates = {}
        for number, (key, flat) in enumerate(wanted.items()):
            def lap(stage: str, fraction: float, number=number) -> None:
                if progress:
                    progress(stage, (number + fraction) / len(wanted))

            live = self.fields.get(key) or self._retired.pop(key, None)
            if live is None:
                start = time.perf_counter()
                twin = None if key in saved else self._same_items(flat)
                live = twin.twin(flat) if twin else LiveRepresentation(flat, self.settings, lap, saved.get(key),
                                                                       memory=share, shared=self._factorisations)
                n = live.lattice.cells_per_side
                updates[key] = Update("rebuild", np.ones((n, n), bool), time.perf_counter() - start)
            elif _items_changed(live.document, flat):
                updates[key] = live.update(flat, lap, exact)
            elif exact and live.approximate:
                updates[key] = live.refine()
            self.fields[key] = live
        for key in [key for key in self.fields if key not in wanted]:
            self._retired[key] = self.fields.pop(key)
            while len(self._retired) > RETIRED:
                self._retired.popitem(last=False)
        self.document = document
        return updates

    def _same_items(self, flat: Document) -> LiveRepresentation | None:
        """An exact field of the very items of ``flat`` on its canvas (a layer a clone was pasted from), if any."""
        for live in self.fields.values():
            held = live.document
            if (held.curves is flat.curves and held.points is flat.points and not live.approximate
                    and (held.width, held.height) == (flat.width, flat.height)):
                return live
        return None

    def update(self, document: Document, progress: Progress | None = None, exact: bool = True) -> StackUpdate:
        """Bring every field to ``document``; see ``LiveRepresentation.update`` for ``exact``.

        Raises
        ------
        LimitError
            When ``document`` exceeds ``model.limits`` (nothing changes then).
        """
        if document.layers is not self.document.layers:
            check_document(document)
        start = time.perf_counter()
        updates = self._follow(document, progress, {}, exact)
        self._blend(document, updates)
        give_back_spare_pages()
        return StackUpdate(updates, time.perf_counter() - start)

    def set_blur(self, shown: bool, progress: Progress | None = None) -> StackUpdate:
        """Keep the blurred layers' blur fields (solving them) or let them go; the composite follows."""
        start = time.perf_counter()
        self.show_blur = bool(shown)
        updates = self._follow(self.document, progress, self._saved_blurs, exact=True)
        self._saved_blurs = {}
        give_back_spare_pages()
        return StackUpdate(updates, time.perf_counter() - start)

    def refine(self) -> StackUpdate:
        """Make every approximate field exact (after previews)."""
        start = time.perf_counter()
        updates = {key: live.refine() for key, live in self.fields.items() if live.approximate}
        self._blend(self.document, updates)
        give_back_spare_pages()
        return StackUpdate(updates, time.perf_counter() - start)

    @staticmethod
    def _below_of(document: Document, layer: Layer) -> tuple:
        """What a clone layer blends with: the canvas and the layers below it (compared by value)."""
        index = next(i for i, each in enumerate(document.layers) if each.id == layer.id)
        return (document.width, document.height) + document.layers[:index]

    def _blend(self, document: Document, updates: dict[FieldKey, Update]) -> None:
        """Make each clone layer's fields anew whose clone, or anything below it, changed (adds to ``updates``)."""
        changed_below = False
        for index, layer in enumerate(document.layers):
            changed_below = changed_below or any(key[0] == layer.id for key in updates)
            if layer.clone is None:
                continue
            live = self.clones.get(layer.id)
            below = self._below_of(document, layer)
            if (live is not None and live.image is not None and live.clone is layer.clone and not changed_below
                    and self._below.get(layer.id) == below):
                continue
            start = time.perf_counter()
            live = live or LiveClone(layer.clone)
            picture = Composite(document.width, document.height,
                                tuple(layer_fields(each, *self._drawn(each), bottom=at == 0)
                                      for at, each in enumerate(document.layers[:index])))
            source = self.fields[layer.id, Role.SOURCE].representation
            changed = live.follow(layer.clone, source, picture, self.settings, layer.id)
            self.clones[layer.id], self._below[layer.id] = live, below
            seconds = time.perf_counter() - start
            for kind, rep in ((Role.IMAGE, live.image), (Role.MASK, live.mask)):
                n = rep.lattice.cells_per_side
                cells = np.ones((n, n), bool) if changed is None else changed[kind]
                updates[layer.id, kind] = Update("clone", cells, seconds)
            changed_below = True
        for gone in set(self.clones) - {layer.id for layer in document.layers}:
            del self.clones[gone], self._below[gone]

    def _drawn(self, layer: Layer) -> tuple[Representation | None, ...]:
        """``layer``'s representations as drawn, in ``Role`` order: image, mask, a clone layer's source, alpha,
        blur."""
        if layer.clone is not None:
            live = self.clones[layer.id]
            return live.image, live.mask, self.fields[layer.id, Role.SOURCE].representation
        return self.image(layer), self.mask(layer), None, self.alpha(layer), self.blur(layer)

    @property
    def approximate(self) -> bool:
        return any(live.approximate for live in self.fields.values())

    @property
    def stale(self) -> bool:
        return any(live.stale for live in self.fields.values())

    def warm_up(self) -> None:
        for live in self.fields.values():
            live.warm_up()

    def image(self, layer: Layer) -> Representation:
        """``layer``'s image representation."""
        if layer.clone is not None:
            return self.clones[layer.id].image
        return self.fields[layer.id, Role.IMAGE].representation

    def mask(self, layer: Layer) -> Representation | None:
        """``layer``'s mask representation (a clone layer's region); None without a mask or for a constant one."""
        if layer.clone is not None:
            return self.clones[layer.id].mask
        live = self.fields.get((layer.id, Role.MASK))
        return live.representation if live is not None else None

    def alpha(self, layer: Layer) -> Representation | None:
        """``layer``'s alpha field; None for an opaque layer."""
        live = self.fields.get((layer.id, Role.ALPHA))
        return live.representation if live is not None else None

    def blur(self, layer: Layer) -> Representation | None:
        """``layer``'s blur field (``model.blur``); None for a sharp layer or while ``show_blur`` is off."""
        live = self.fields.get((layer.id, Role.BLUR))
        return live.representation if live is not None else None

    @property
    def representation(self) -> Representation:
        """The active layer's image (for a flat document, the picture itself)."""
        return self.image(self.document.layer)

    @property
    def composite(self) -> Composite:
        """The picture: every layer's representations with its mask, opacity, transform and visibility."""
        return composite_of(self.document, [self._drawn(layer) for layer in self.document.layers])


def layer_fields(layer: Layer, image: Representation, mask_field: Representation | None,
                 source: Representation | None = None, alpha: Representation | None = None,
                 blur: Representation | None = None, *, bottom: bool = False) -> LayerFields:
    """How ``layer`` is drawn from its image, mask and alpha representations (a clone layer's mask: its region;
    its ``source`` is kept with it).  An empty layer is clear, nothing of it drawn, unless it is the ``bottom``
    one, which starts opaque (black) as a new document does."""
    shown = {"opacity": layer.opacity, "transform": layer.transform,
             "visible": layer.visible and (bottom or not layer.empty), "id": layer.id, "alpha": alpha,
             "blur": blur}
    if layer.clone is not None:
        return LayerFields(image, mask_field, mask_base=0.0, source=source, **shown)
    mask = layer.mask
    if mask is None:
        return LayerFields(image, mask_field, **shown)
    return LayerFields(image, mask_field, mask_base=mask.base, mask_inverted=mask.inverted, mask_enabled=mask.enabled,
                       **shown)


def composite_of(document: Document, fields: Sequence[tuple]) -> Composite:
    """``document``'s picture from each layer's ``(image, mask, source, alpha, blur)`` representations (mask
    None: no mask or no items; alpha None: opaque; blur None: sharp; the last ones may be left out)."""
    layers = (layer_fields(layer, *reps, bottom=index == 0)
              for index, (layer, reps) in enumerate(zip(document.layers, fields, strict=True)))
    return Composite(document.width, document.height, tuple(layers))


def build(document: Document, settings: Settings = Settings(), progress: Progress | None = None) -> Representation:
    """Discretise, solve and propagate a one-layer ``document`` into its FMR.

    Parameters
    ----------
    document : Document
        One plain layer (``Document.is_flat``); ``LiveStack(document).composite`` draws any other.
    settings : Settings
    progress : callable, optional
        Called as ``progress(stage, fraction)`` as the build advances.

    Returns
    -------
    Representation

    Raises
    ------
    ValueError
        For a document of layers, whose picture no single representation is.
    """
    if not document.is_flat:
        raise ValueError("build takes a document of one plain layer; LiveStack(document).composite draws layers")
    check_document(document)
    return LiveRepresentation(document, settings, progress).representation
