"""Brush edits of an emission raster with their undo and redo history.

Dobashi et al. (2023, Sec. 5) add and delete lights interactively. Here a brush stroke (points
joined by segments, a radius) sets, erases or scales the flux density of the cells whose
centres lie within the radius; every step keeps the window it changed, before and after, so
undo and redo copy a window back. Steps beyond the history's memory are kept as operations
only (they can no longer be undone, but a session file still replays them).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from affine import Affine

from nightlights._typing import FloatArray
from nightlights._validate import check_flux_density
from nightlights.errors import InputError

__all__ = ["EDIT_OPS", "PLAN_OP", "EmissionEdits", "band_share", "check_saved_edits"]

#: Edit operations.
EDIT_OPS = ("paint", "erase", "scale")
#: Operation of an applied road plan: its fields are :data:`PLAN_FIELDS`, ``dimming`` the
#: level of every light of the road model [1] (:mod:`nightlights.explore._roads`).
PLAN_OP = "road-plan"
#: Fields of a saved road plan.
PLAN_FIELDS = ("op", "dimming", "target", "objective")
#: Most cells one brush stroke may touch (a stroke wider than the raster is refused) [1].
MAX_BRUSH_CELLS = 16_000_000
#: Undo history kept, all steps together [B].
HISTORY_BYTES = 512 * 2**20


@dataclass(frozen=True)
class _Step:
    """One undoable edit: the window it changed, before and after."""

    window: tuple[slice, slice]
    before: FloatArray
    after: FloatArray
    op: dict[str, Any]
    changed: int
    extra_before: Any = None
    extra_after: Any = None


class EmissionEdits:
    """An emission array edited in place, with its undo and redo history.

    Parameters
    ----------
    data
        Shape ``(bands, rows, cols)``: the flux density edited in place [lm m-2].
    transform
        Affine transform of the raster (north up) [m].
    share
        Shape ``(bands,)``: how painted flux density splits between the bands [1].

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> data = np.zeros((1, 4, 4))
    >>> edits = EmissionEdits(data, Affine(10, 0, 0, 0, -10, 40), np.ones(1))
    >>> edits.apply("paint", [(15.0, 25.0)], radius=6.0, value=2.0), float(data.sum())
    (1, 2.0)
    >>> edits.undo(), float(data.sum())
    (1, 0.0)
    """

    def __init__(self, data: FloatArray, transform: Affine, share: FloatArray) -> None:
        self.data = data
        self.transform = transform
        self.share = np.asarray(share, dtype=float)
        self._undo: list[_Step] = []
        self._redo: list[_Step] = []
        self._baked: list[dict[str, Any]] = []  # steps older than the history
        #: State kept with the emission by a step of :meth:`set_cells` (restored by undo and
        #: redo); None before any.
        self.extra: Any = None

    @property
    def can_undo(self) -> bool:
        """Whether a step can be undone."""
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        """Whether an undone step can be redone."""
        return bool(self._redo)

    @property
    def ops(self) -> list[dict[str, Any]]:
        """The operations in force, oldest first (JSON-ready)."""
        return self._baked + [step.op for step in self._undo]

    def apply(
        self,
        op: str,
        points: Sequence[Sequence[float]],
        *,
        radius: float,
        value: float | None = None,
        check: Callable[[tuple[slice, slice], FloatArray], None] | None = None,
    ) -> int:
        """Apply one brush stroke.

        A stroke whose result is not finite or above
        :data:`~nightlights._validate.MAX_FLUX_DENSITY` in any cell it changes is refused
        (:class:`~nightlights.errors.InputError`) and changes nothing, history included.

        Parameters
        ----------
        op
            ``paint``, ``erase`` or ``scale``.
        points
            The stroke, (x, y) in the raster CRS [m].
        radius
            Brush radius [m].
        value
            Flux density for ``paint`` [lm m-2] or factor for ``scale`` [1].
        check
            Called with the window and its edited values ``(bands, rows, cols)`` [lm m-2]
            before they are written; raises to refuse the stroke.

        Returns
        -------
        int
            Cells changed (0: nothing recorded).
        """
        if op not in EDIT_OPS:
            raise InputError(f"edit {op!r}; expected one of {', '.join(EDIT_OPS)}")
        stroke = np.asarray(points, dtype=float)
        if stroke.ndim != 2 or stroke.shape[1] != 2 or stroke.shape[0] < 1:
            raise InputError("a stroke is a list of at least one (x, y) point")
        if not np.isfinite(stroke).all():
            raise InputError("stroke points must be finite numbers")
        if not (math.isfinite(radius) and radius > 0):
            raise InputError(f"brush radius {radius} m; expected a finite value > 0")
        if op != "erase" and (value is None or not math.isfinite(value) or value < 0):
            raise InputError(f"{op} needs a finite value >= 0; got {value}")
        if op == "paint":
            check_flux_density([float(value)], what="paint value")  # type: ignore[arg-type]
        window, inside = self._brush(stroke, float(radius))
        if window is None:
            return 0
        block = self.data[(slice(None), *window)]
        before = block.copy()
        after = block.copy()
        if op == "paint":
            after[:, inside] = float(value) * self.share[:, None]  # type: ignore[arg-type]
        elif op == "erase":
            after[:, inside] = 0.0
        else:
            with np.errstate(over="ignore", invalid="ignore"):
                after[:, inside] = before[:, inside] * float(value)  # type: ignore[arg-type]
        moved = ~_same(before, after)
        changed = int(np.sum(np.any(moved, axis=0)))
        if changed == 0:
            return 0
        if op == "scale":
            check_flux_density(after[moved], what=f"scale by {value:g}: the edited cells")
        if check is not None:
            check(window, after)
        self.data[(slice(None), *window)] = after
        record = {
            "op": op,
            "points": stroke.tolist(),
            "radius": float(radius),
            "value": None if value is None else float(value),
        }
        self._undo.append(_Step(window, before, after, record, changed))
        self._redo.clear()
        self._trim_history()
        return changed

    def set_cells(
        self,
        rows: np.ndarray,
        cols: np.ndarray,
        values: FloatArray,
        op: dict[str, Any],
        extra: Any = None,
    ) -> int:
        """Set the flux density of given cells in one undoable step.

        Parameters
        ----------
        rows, cols
            The cells (n,).
        values
            Shape ``(bands, n)``: their new flux density [lm m-2].
        op
            The step's record (:attr:`ops`).
        extra
            State that goes with the step (:attr:`extra` after it; undo restores the one
            before).

        Returns
        -------
        int
            Cells changed (0: nothing recorded).
        """
        rows = np.asarray(rows, dtype=np.intp)
        cols = np.asarray(cols, dtype=np.intp)
        if rows.size == 0:
            return 0
        window = (slice(int(rows.min()), int(rows.max()) + 1),
                  slice(int(cols.min()), int(cols.max()) + 1))  # fmt: skip
        block = self.data[(slice(None), *window)]
        before = block.copy()
        after = block.copy()
        after[:, rows - window[0].start, cols - window[1].start] = values
        changed = int(np.sum(np.any(~_same(before, after), axis=0)))
        if changed == 0 and extra is None:
            return 0
        self.data[(slice(None), *window)] = after
        self._undo.append(_Step(window, before, after, op, changed, self.extra, extra))
        self.extra = extra
        self._redo.clear()
        self._trim_history()
        return changed

    def undo(self) -> int:
        """Undo the last step; returns the cells it changed back."""
        if not self._undo:
            raise InputError("nothing to undo")
        step = self._undo.pop()
        self.data[(slice(None), *step.window)] = step.before
        if step.extra_after is not None:
            self.extra = step.extra_before
        self._redo.append(step)
        return step.changed

    def redo(self) -> int:
        """Redo the last undone step; returns the cells it changed."""
        if not self._redo:
            raise InputError("nothing to redo")
        step = self._redo.pop()
        self.data[(slice(None), *step.window)] = step.after
        if step.extra_after is not None:
            self.extra = step.extra_after
        self._undo.append(step)
        return step.changed

    def _brush(
        self, stroke: FloatArray, radius: float
    ) -> tuple[tuple[slice, slice] | None, np.ndarray]:
        inverse = ~self.transform
        rows, cols = self.data.shape[1:]
        corners = [
            inverse @ (x, y)
            for x in (stroke[:, 0].min() - radius, stroke[:, 0].max() + radius)
            for y in (stroke[:, 1].min() - radius, stroke[:, 1].max() + radius)
        ]
        c0 = max(math.floor(min(c for c, _ in corners)), 0)
        c1 = min(math.ceil(max(c for c, _ in corners)), cols)
        r0 = max(math.floor(min(r for _, r in corners)), 0)
        r1 = min(math.ceil(max(r for _, r in corners)), rows)
        if c0 >= c1 or r0 >= r1:
            return None, np.zeros((0, 0), bool)
        if (r1 - r0) * (c1 - c0) > MAX_BRUSH_CELLS:
            raise InputError(
                f"the stroke covers {(r1 - r0) * (c1 - c0)} cells; at most {MAX_BRUSH_CELLS}"
            )
        t = self.transform
        cx = t.c + t.a * (np.arange(c0, c1) + 0.5)
        cy = t.f + t.e * (np.arange(r0, r1) + 0.5)
        px, py = np.meshgrid(cx, cy)
        inside = np.zeros(px.shape, dtype=bool)
        ends = stroke if stroke.shape[0] > 1 else np.vstack([stroke, stroke])
        for (ax, ay), (bx, by) in itertools.pairwise(ends):
            dx, dy = bx - ax, by - ay
            length2 = dx * dx + dy * dy
            along = (
                0.0 if length2 == 0 else np.clip(((px - ax) * dx + (py - ay) * dy) / length2, 0, 1)
            )
            inside |= np.hypot(px - (ax + along * dx), py - (ay + along * dy)) <= radius
        if not inside.any():
            return None, inside
        return (slice(r0, r1), slice(c0, c1)), inside

    def _trim_history(self) -> None:
        while len(self._undo) > 1 and sum(s.before.nbytes * 2 for s in self._undo) > HISTORY_BYTES:
            dropped = self._undo.pop(0)
            self._baked.append(dropped.op)


#: Fields of a saved edit (:attr:`EmissionEdits.ops`); ``value`` may be null for ``erase``.
EDIT_FIELDS = ("op", "points", "radius", "value")


def check_saved_edits(edits: Any, source: str) -> list[dict[str, Any]]:
    """The edits of a session file, each checked field by field before any is replayed.

    Parameters
    ----------
    edits
        The file's ``edits``: a list of ``{"op", "points", "radius", "value"}`` objects, as
        :attr:`EmissionEdits.ops` writes them.
    source
        The session file, for messages.

    Returns
    -------
    list of dict
        The edits (``value`` None where absent).

    Raises
    ------
    InputError
        Not a list; an edit that is not an object, lacks a field, has one of the wrong type or
        an unknown one: the message names the edit (counted from 1) and the field.

    Examples
    --------
    >>> check_saved_edits([{"op": "erase", "points": [[0, 0]]}], "s.json")
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: s.json: edit 1 of 1: missing field 'radius'; expected op, \
points, radius and value (null for erase)
    """
    if not isinstance(edits, list):
        raise InputError(f"{source}: edits is a {_json_type(edits)}; expected a list of edits")
    expected = "expected op, points, radius and value (null for erase)"
    checked = []
    for index, edit in enumerate(edits):
        where = f"{source}: edit {index + 1} of {len(edits)}"
        if not isinstance(edit, dict):
            raise InputError(f"{where}: a {_json_type(edit)}; {expected}")
        if edit.get("op") == PLAN_OP:
            checked.append(_checked_plan(edit, where))
            continue
        unknown = sorted(set(edit) - set(EDIT_FIELDS))
        if unknown:
            raise InputError(f"{where}: unknown field {unknown[0]!r}; {expected}")
        for name in ("op", "points", "radius"):
            if name not in edit:
                raise InputError(f"{where}: missing field {name!r}; {expected}")
        op, points, radius = edit["op"], edit["points"], edit["radius"]
        value = edit.get("value")
        if op not in EDIT_OPS:
            raise InputError(f"{where}: op {op!r}; expected one of {', '.join(EDIT_OPS)}")
        if not (
            isinstance(points, list)
            and points
            and all(
                isinstance(point, list) and len(point) == 2 and all(map(_finite, point))
                for point in points
            )
        ):
            raise InputError(
                f"{where}: points {_shown(points)}; expected a list of [x, y] points (finite "
                "numbers)"
            )
        if not (_finite(radius) and radius > 0):
            raise InputError(f"{where}: radius {_shown(radius)}; expected a number > 0 [m]")
        if op != "erase" and not (_finite(value) and float(value or 0) >= 0):
            raise InputError(f"{where}: value {_shown(value)}; {op} needs a number >= 0")
        if op == "erase" and value is not None and not _finite(value):
            raise InputError(f"{where}: value {_shown(value)}; expected null or a number")
        checked.append({"op": op, "points": points, "radius": radius, "value": value})
    return checked


def _checked_plan(edit: dict[str, Any], where: str) -> dict[str, Any]:
    """A saved road plan, checked: known fields, a list of levels in [0, 1]."""
    unknown = sorted(set(edit) - set(PLAN_FIELDS))
    if unknown:
        raise InputError(f"{where}: unknown field {unknown[0]!r}; expected op and dimming")
    dimming = edit.get("dimming")
    if not (
        isinstance(dimming, list)
        and dimming
        and all(_finite(level) and 0.0 <= float(level) <= 1.0 for level in dimming)
    ):
        raise InputError(
            f"{where}: dimming {_shown(dimming)}; expected a list of levels in [0, 1], one "
            "per light"
        )
    return {key: edit[key] for key in PLAN_FIELDS if key in edit}


def _finite(value: Any) -> bool:
    """Whether ``value`` is a JSON number (not a boolean) that is finite as a float."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:  # an integer too large for a float
        return False


def _json_type(value: Any) -> str:
    names = {dict: "object", list: "list", str: "string", bool: "boolean", type(None): "null"}
    return names.get(type(value), "number")


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def band_share(data: FloatArray) -> FloatArray:
    """Each band's share of the raster's total flux (all Lambertian when there is none)."""
    totals = np.nansum(np.where(data > 0, data, 0.0), axis=(1, 2))
    if totals.sum() <= 0:
        share = np.zeros(data.shape[0])
        share[0] = 1.0
        return share
    return np.asarray(totals / totals.sum())


def _same(a: FloatArray, b: FloatArray) -> np.ndarray:
    return (a == b) | (np.isnan(a) & np.isnan(b))
