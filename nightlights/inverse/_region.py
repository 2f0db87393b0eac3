"""Regions of the sky: the area over which S_i sums the glow, and the targets of the dimming.

Dobashi et al. (2023, Sec. 4.2, Eqs. 13-14) let the user mark a region of the sky panorama and
sum each cell's contribution over the pixels inside it. :class:`SkyRegion` is that region, in
the panorama's own coordinates: azimuth [deg] clockwise from north and elevation [deg] above
the horizon. It is one of

- a polygon ``"az,el az,el ..."`` of at least three distinct vertices, the first repeated at
  the end (or a GeoJSON or WKT file of one polygon whose x is the azimuth and y the elevation);
- a zenith cap ``zenith:R``: every direction with elevation >= 90 - R [deg];
- a horizon band ``horizon:AZ1,AZ2,EL``: azimuth from AZ1 clockwise to AZ2 (through north when
  AZ2 < AZ1), elevation from 0 to EL [deg].

Modelling choices. The azimuth is periodic, so a polygon's edges are drawn on the cylinder:
consecutive vertices are joined along the shorter azimuth arc (``350 -> 10`` crosses north and
spans 20 deg, never 340), and two vertices exactly 180 deg apart in azimuth are refused as
ambiguous. Edges are straight in (azimuth, elevation), not great circles. A ring whose azimuth
winds once round the sky (net change +-360 deg, e.g. ``"0,60 90,60 180,60 270,60 0,60"``)
encloses the zenith: its inside is everything above the curve. A pixel belongs to the region
when its centre (elevation[i], azimuth[j]) lies inside or on the boundary; all three kinds are
closed sets.

The kinds are a registry (:class:`RegionKind`): each names the prefix of its text, the parser
that reads the rest into a :class:`SkyRegion`, the check of a region built directly and the
builder of its pixel mask. A new kind is one :func:`register_region_kind` call; its parser
keeps the numbers it reads in :attr:`SkyRegion.parameters` (:func:`region_numbers` reads them
with the built-in kinds' checks and messages).

Length: about 660 lines, because the region, its three built-in kinds (the polygon's checks on
the azimuth cylinder are most of it) and the registry whose rows they are form one vocabulary
that parsing, checking and masking all read.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import MultiPolygon, Polygon, shape

from nightlights.errors import InputError

__all__ = [
    "RegionKind",
    "SkyRegion",
    "region_kinds",
    "region_numbers",
    "register_region_kind",
    "unregister_region_kind",
]

#: Elevation above the zenith at which a zenith-enclosing ring is closed [deg]; any value over
#: 90 keeps the closing edge away from the curve, pixel centres never reach it.
_ABOVE_ZENITH = 180.0
_SHORTCUT = re.compile(r"^([A-Za-z_][A-Za-z0-9_-]*):(.*)$", re.DOTALL)
_FILE_SUFFIXES = (".geojson", ".json", ".wkt")


@dataclass(frozen=True)
class SkyRegion:
    """A region of the sky in panorama coordinates.

    Build one with :meth:`parse`; direct construction is checked the same way.

    Attributes
    ----------
    kind
        ``"polygon"``, ``"zenith"``, ``"horizon"`` or a registered kind
        (:func:`register_region_kind`).
    text
        The region as the user wrote it (recorded in output tags).
    vertices
        Polygon vertices (azimuth [deg], elevation [deg]), the first repeated at the end.
    radius
        Zenith cap radius R: the cap is elevation >= 90 - R, 0 < R <= 90 [deg].
    azimuths
        Horizon band (AZ1, AZ2): from AZ1 clockwise to AZ2 [deg].
    top
        Horizon band top elevation EL, 0 < EL <= 90 [deg].
    parameters
        The numbers of a registered kind's text, as its parser keeps them [deg].

    Examples
    --------
    A polygon across north covers azimuth 355 and 5 deg, not 180 deg:

    >>> import numpy as np
    >>> region = SkyRegion.parse("350,0 10,0 10,30 350,30 350,0")
    >>> region.mask(np.array([15.0, 45.0]), np.array([5.0, 180.0, 355.0])).tolist()
    [[True, False, True], [False, False, False]]
    >>> SkyRegion.parse("zenith:20").mask(np.array([80.0, 60.0]), np.array([0.0])).tolist()
    [[True], [False]]
    """

    kind: str
    text: str
    vertices: tuple[tuple[float, float], ...] = ()
    radius: float | None = None
    azimuths: tuple[float, float] | None = None
    top: float | None = None
    parameters: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        _region_kind(self.kind).check(self)

    def __str__(self) -> str:
        return self.text

    # --- parsing ---------------------------------------------------------------------------

    @classmethod
    def parse(cls, value: str | os.PathLike[str] | SkyRegion) -> SkyRegion:
        """Read a region from text, a GeoJSON or WKT file, or return a region as it is.

        Parameters
        ----------
        value
            ``"az,el az,el ..."`` (closed polygon), ``"zenith:R"``, ``"horizon:AZ1,AZ2,EL"``
            (angles [deg]), a path to a GeoJSON (geometry, Feature or FeatureCollection of one
            Polygon or one-part MultiPolygon) or WKT file of a polygon with x = azimuth [deg]
            and y = elevation [deg], or a :class:`SkyRegion`.

        Returns
        -------
        SkyRegion

        Raises
        ------
        nightlights.errors.InputError
            Unparsable numbers, an unknown shortcut, an open, self-crossing or degenerate
            polygon, elevations outside [0, 90] deg, a bad radius or band, an unreadable file.
        """
        if isinstance(value, SkyRegion):
            return value
        if isinstance(value, os.PathLike):
            return cls._from_file(Path(value), os.fspath(value))
        if not isinstance(value, str):
            raise InputError(
                f"sky region {value!r}; expected a string, a path or a SkyRegion, not "
                f"{type(value).__name__}"
            )
        text = value.strip()
        if not text:
            raise InputError("sky region ''; expected 'az,el az,el ...', zenith:R or horizon:...")
        if Path(text).is_file():
            return cls._from_file(Path(text), value)
        shortcut = _SHORTCUT.match(text)
        if shortcut is not None:
            return cls._from_shortcut(shortcut.group(1), shortcut.group(2), value)
        if text.lower().endswith(_FILE_SUFFIXES):
            raise InputError(f"sky region file {text!r} does not exist")
        vertices = tuple(_pair(token, value) for token in text.split())
        return cls("polygon", value, vertices=vertices)

    @classmethod
    def _from_shortcut(cls, name: str, argument: str, text: str) -> SkyRegion:
        kind = _KINDS.get(name)
        if kind is None or kind.parse is None:
            forms = ", ".join(k.form for k in _KINDS.values() if k.parse is not None)
            raise InputError(
                f"sky region {text!r}: unknown shortcut {name!r}; expected {forms}, "
                "'az,el az,el ...' or a GeoJSON/WKT file"
            )
        return kind.parse(argument, text)

    @classmethod
    def _from_file(cls, path: Path, text: str) -> SkyRegion:
        try:
            content = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(f"sky region file {text!r}: cannot read it ({exc})") from None
        stripped = content.lstrip()
        if stripped.startswith("{"):
            geometry = _geojson_geometry(stripped, text)
        else:
            try:
                geometry = shapely.from_wkt(stripped.strip())
            except shapely.errors.ShapelyError as exc:
                message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                raise InputError(
                    f"sky region file {text!r}: not GeoJSON or WKT ({message}); expected one "
                    "polygon of (azimuth, elevation)"
                ) from None
        if isinstance(geometry, MultiPolygon) and len(geometry.geoms) == 1:
            geometry = geometry.geoms[0]
        if not isinstance(geometry, Polygon) or geometry.is_empty:
            raise InputError(
                f"sky region file {text!r}: holds a {geometry.geom_type}; expected one polygon "
                "of (azimuth, elevation)"
            )
        if len(geometry.interiors):
            raise InputError(
                f"sky region file {text!r}: the polygon has {len(geometry.interiors)} hole(s); "
                "expected a polygon without holes"
            )
        vertices = tuple((float(x), float(y)) for x, y, *_ in geometry.exterior.coords)
        return cls("polygon", text, vertices=vertices)

    # --- the mask --------------------------------------------------------------------------

    def mask(self, elevation: ArrayLike, azimuth: ArrayLike) -> NDArray[np.bool_]:
        """Which panorama pixels lie in the region.

        Parameters
        ----------
        elevation
            Pixel-centre elevations, shape ``(n_el,)`` [deg].
        azimuth
            Pixel-centre azimuths, clockwise from north, shape ``(n_az,)`` [deg]; any real
            values (taken modulo 360).

        Returns
        -------
        numpy.ndarray of bool
            Shape ``(n_el, n_az)``: True where the centre (elevation[i], azimuth[j]) is inside
            the region or on its boundary.
        """
        el = np.asarray(elevation, dtype=float).reshape(-1)[:, None]
        az = np.asarray(azimuth, dtype=float).reshape(-1)[None, :]
        el, az = np.broadcast_arrays(el, az)
        return np.asarray(_region_kind(self.kind).mask(self, el, az), dtype=bool)

    # --- checks and geometry ---------------------------------------------------------------

    @cached_property
    def _band_span(self) -> tuple[float, float]:
        """(AZ1, span clockwise to AZ2) of a horizon band [deg]."""
        assert self.azimuths is not None
        az1, az2 = self.azimuths
        span = (az2 - az1) % 360.0
        if span == 0.0:
            span = 360.0  # AZ1 != AZ2 checked: e.g. 0,360 is the full circle
        return az1, span

    def _check_band(self) -> None:
        if self.azimuths is None or self.top is None:
            raise InputError(f"sky region {self.text!r}: a horizon band needs azimuths and top")
        az1, az2 = self.azimuths
        if not all(math.isfinite(v) for v in (az1, az2, self.top)):
            raise InputError(f"sky region {self.text!r}: non-finite angle; expected numbers [deg]")
        if az1 == az2:
            raise InputError(
                f"sky region {self.text!r}: AZ1 = AZ2 = {az1:g} deg spans nothing; expected "
                "two different azimuths (0,360 for the full circle)"
            )
        if not 0 < self.top <= 90:
            raise InputError(
                f"sky region {self.text!r}: band top EL = {self.top:g} deg; expected 0 < EL <= 90"
            )

    @cached_property
    def _polygon(self) -> tuple[Polygon, float, float]:
        """The polygon on the unrolled cylinder and its azimuth extent (left, right) [deg].

        A ring that winds round the zenith is unrolled over three turns and closed above the
        zenith; the pixels are tested in its middle turn.
        """
        text = self.text
        ring = np.asarray(self.vertices, dtype=float).reshape(-1, 2)
        if ring.shape[0] < 2 or not np.isfinite(ring).all():
            raise InputError(
                f"sky region {text!r}: {ring.shape[0]} finite vertices; expected a closed ring "
                "'az,el az,el ... az,el' of at least 3 distinct vertices"
            )
        if not np.array_equal(ring[0], ring[-1]):
            raise InputError(
                f"sky region {text!r}: the polygon is open (first vertex {_fmt(ring[0])} != last "
                f"{_fmt(ring[-1])}); expected the first vertex repeated at the end"
            )
        distinct = len({(float(a), float(e)) for a, e in ring[:-1]})
        if distinct < 3:
            raise InputError(
                f"sky region {text!r}: {distinct} distinct vertices; expected at least 3"
            )
        bad = (ring[:, 1] < 0) | (ring[:, 1] > 90)
        if bad.any():
            raise InputError(
                f"sky region {text!r}: elevation {ring[bad][0, 1]:g} deg at vertex "
                f"{_fmt(ring[bad][0])}; expected 0 <= elevation <= 90 deg"
            )
        step = (np.diff(ring[:, 0]) + 180.0) % 360.0 - 180.0  # shorter arc, in [-180, 180)
        half = np.flatnonzero(np.abs(step) == 180.0)
        if half.size:
            i = int(half[0])
            raise InputError(
                f"sky region {text!r}: vertices {_fmt(ring[i])} and {_fmt(ring[i + 1])} are "
                "180 deg apart in azimuth, so the edge could go either way; expected a vertex "
                "between them"
            )
        x = ring[0, 0] + np.concatenate([[0.0], np.cumsum(step)])
        turns = round(float(x[-1] - x[0]) / 360.0)
        if turns == 0:
            polygon = Polygon(np.column_stack([x, ring[:, 1]]))
            left, right = float(x.min()), float(x.max())
        elif abs(turns) == 1:
            polygon, left, right = _zenith_loop(x, ring[:, 1], turns)
        else:
            raise InputError(
                f"sky region {text!r}: the ring winds {abs(turns)} times round the zenith; "
                "expected at most once"
            )
        if polygon.convex_hull.area <= 0:
            raise InputError(f"sky region {text!r}: the polygon encloses no area")
        if not polygon.is_valid:
            reason = shapely.is_valid_reason(polygon)
            raise InputError(
                f"sky region {text!r}: the polygon crosses or touches itself ({reason}); "
                "expected a simple ring"
            )
        if turns == 0 and right - left >= 360.0:
            overlap = polygon.intersection(
                shapely.transform(polygon, lambda p: p + np.array([360.0, 0.0]))
            )
            if overlap.area > 0:
                raise InputError(
                    f"sky region {text!r}: the polygon overlaps itself after a full turn in "
                    "azimuth; expected a simple ring"
                )
        shapely.prepare(polygon)
        return polygon, left, right


def _zenith_loop(x: np.ndarray, el: np.ndarray, turns: int) -> tuple[Polygon, float, float]:
    """The region above a ring that winds once round the zenith, unrolled over three turns."""
    if turns < 0:
        x, el = x[::-1], el[::-1]
    x = x - x[0]
    parts = [np.column_stack([x[:-1] + 360.0 * k, el[:-1]]) for k in (-1, 0, 1)]
    curve = np.concatenate([*parts, [[x[-1] + 360.0, el[-1]]]])
    top = [[curve[-1, 0], _ABOVE_ZENITH], [curve[0, 0], _ABOVE_ZENITH], curve[0]]
    polygon = Polygon(np.concatenate([curve, top]))
    # pixels are shifted by whole turns; the middle turn starts at the original first vertex
    polygon = shapely.transform(polygon, lambda p: p + np.array([x[0], 0.0]))
    return polygon, float(curve[:, 0].min()), float(curve[:, 0].max())


def _pair(token: str, text: str) -> tuple[float, float]:
    """``"az,el"`` -> two finite floats [deg]."""
    parts = token.split(",")
    try:
        if len(parts) != 2:
            raise ValueError(token)
        az, el = (float(p) for p in parts)
    except ValueError:
        raise InputError(
            f"sky region {text!r}: vertex {token!r}; expected 'az,el' in degrees, vertices "
            "separated by spaces"
        ) from None
    if not (math.isfinite(az) and math.isfinite(el)):
        raise InputError(f"sky region {text!r}: vertex {token!r}; expected finite degrees")
    return az, el


def region_numbers(argument: str, count: int, text: str, form: str) -> list[float]:
    """``count`` comma-separated finite numbers of a shortcut's argument, for kind parsers.

    Parameters
    ----------
    argument
        The text after ``kind:`` [deg].
    count
        How many numbers the kind takes [1].
    text
        The whole region text, for messages.
    form
        The kind's form (``zenith:R``), for messages.

    Returns
    -------
    list of float
        The numbers [deg].

    Raises
    ------
    nightlights.errors.InputError
        Not ``count`` finite numbers.

    Examples
    --------
    >>> region_numbers("10,20", 2, "band:10,20", "band:EL1,EL2")
    [10.0, 20.0]
    """
    parts = argument.split(",")
    try:
        if len(parts) != count:
            raise ValueError(argument)
        values = [float(p) for p in parts]
    except ValueError:
        raise InputError(f"sky region {text!r}; expected {form} with numbers in degrees") from None
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"sky region {text!r}; expected {form} with finite degrees")
    return values


def _geojson_geometry(content: str, text: str) -> Any:
    """The one geometry of a GeoJSON geometry, Feature or FeatureCollection."""
    try:
        data = json.loads(content)
    except json.JSONDecodeError as exc:
        raise InputError(f"sky region file {text!r}: not valid JSON ({exc})") from None
    kind = data.get("type") if isinstance(data, dict) else None
    if kind == "FeatureCollection":
        features = data.get("features") or []
        if len(features) != 1:
            raise InputError(
                f"sky region file {text!r}: {len(features)} features; expected one polygon"
            )
        data = features[0]
        kind = data.get("type") if isinstance(data, dict) else None
    if kind == "Feature":
        data = data.get("geometry")
    if not isinstance(data, dict):
        raise InputError(f"sky region file {text!r}: no geometry; expected one polygon")
    try:
        return shape(data)
    except (
        ValueError,
        TypeError,
        KeyError,
        IndexError,
        AttributeError,
        shapely.errors.ShapelyError,
    ) as exc:
        raise InputError(
            f"sky region file {text!r}: unreadable GeoJSON geometry ({exc}); expected one polygon"
        ) from None


def _fmt(vertex: np.ndarray) -> str:
    return f"({vertex[0]:g}, {vertex[1]:g})"


# --- the registry of kinds ------------------------------------------------------------------

#: Parser of a kind: (the text after ``kind:``, the whole text) -> the region.
RegionParser = Callable[[str, str], SkyRegion]
#: Mask builder of a kind: (region, pixel-centre elevations [deg], azimuths [deg], both of
#: shape (n_el, n_az)) -> True inside the region or on its boundary.
RegionMask = Callable[[SkyRegion, NDArray[np.float64], NDArray[np.float64]], NDArray[np.bool_]]


def _no_check(region: SkyRegion) -> None:
    """A kind whose parser checks its numbers needs no further check."""


@dataclass(frozen=True)
class RegionKind:
    """One kind of sky region: the row of the registry :func:`register_region_kind` fills.

    Attributes
    ----------
    name
        The kind, and the prefix of its text (``zenith`` of ``zenith:R``).
    form
        How its text is written, for messages (``zenith:R``).
    doc
        One line on the region it marks.
    parse
        Parser of the text after ``name:`` (:data:`RegionParser`); None for the polygon,
        which vertex text and files give.
    mask
        Builder of the pixel mask (:data:`RegionMask`).
    check
        Check of a region built directly (raises :class:`~nightlights.errors.InputError`).
    """

    name: str
    form: str
    doc: str
    parse: RegionParser | None
    mask: RegionMask
    check: Callable[[SkyRegion], None] = _no_check


_KINDS: dict[str, RegionKind] = {}
_BUILT_IN = ("polygon", "zenith", "horizon")


def register_region_kind(
    name: str,
    *,
    form: str,
    parse: RegionParser,
    mask: RegionMask,
    doc: str,
    check: Callable[[SkyRegion], None] | None = None,
    replace: bool = False,
) -> RegionKind:
    """Add a kind of sky region: ``name:...`` texts then parse into regions of that kind.

    Parameters
    ----------
    name
        The kind and its text's prefix: a letter, then letters, digits, ``_`` or ``-``.
    form
        How its text is written, for messages (``ring:EL1,EL2``).
    parse
        (argument after ``name:``, whole text) -> :class:`SkyRegion` of this kind, its
        numbers in :attr:`SkyRegion.parameters` (:func:`region_numbers`).
    mask
        (region, elevations, azimuths) -> boolean mask, shapes ``(n_el, n_az)``
        (:data:`RegionMask`).
    doc
        One line on the region it marks.
    check
        Check of a region built directly; default none.
    replace
        Replace a registered kind of that name (never a built-in one).

    Returns
    -------
    RegionKind
        The registered row.

    Raises
    ------
    nightlights.errors.InputError
        A bad name, or a name already taken.

    Examples
    --------
    >>> import numpy as np
    >>> kind = register_region_kind(
    ...     "above",
    ...     form="above:EL",
    ...     doc="every direction at or above elevation EL",
    ...     parse=lambda argument, text: SkyRegion(
    ...         "above", text, parameters=tuple(region_numbers(argument, 1, text, "above:EL"))
    ...     ),
    ...     mask=lambda region, el, az: el >= region.parameters[0],
    ... )
    >>> SkyRegion.parse("above:70").mask(np.array([80.0, 60.0]), np.array([0.0])).tolist()
    [[True], [False]]
    >>> unregister_region_kind("above")
    """
    if not (isinstance(name, str) and _SHORTCUT.match(f"{name}:")):
        raise InputError(
            f"sky region kind {name!r}; expected a letter, then letters, digits, _ or -"
        )
    if name in _KINDS and (not replace or name in _BUILT_IN):
        why = "a built-in kind" if name in _BUILT_IN else "registered (replace=True)"
        raise InputError(f"sky region kind {name!r} is already {why}")
    kind = RegionKind(name, form, doc, parse, mask, check or _no_check)
    _KINDS[name] = kind
    return kind


def unregister_region_kind(name: str) -> None:
    """Remove a kind added by :func:`register_region_kind` (never a built-in one).

    Parameters
    ----------
    name
        The kind.

    Raises
    ------
    nightlights.errors.InputError
        A built-in or unknown kind.
    """
    if name in _BUILT_IN or name not in _KINDS:
        what = "a built-in kind" if name in _BUILT_IN else "not registered"
        raise InputError(f"sky region kind {name!r} is {what}; cannot unregister it")
    del _KINDS[name]


def region_kinds() -> tuple[str, ...]:
    """The registered kinds, built-in first (``polygon``, ``zenith``, ``horizon``)."""
    return tuple(_KINDS)


def _region_kind(name: str) -> RegionKind:
    kind = _KINDS.get(name)
    if kind is None:
        raise InputError(f"sky region kind {name!r}; expected one of {', '.join(_KINDS)}")
    return kind


# --- the built-in kinds -----------------------------------------------------------------


def _polygon_mask(
    region: SkyRegion, el: NDArray[np.float64], az: NDArray[np.float64]
) -> NDArray[np.bool_]:
    polygon, left, right = region._polygon
    inside = np.zeros(el.shape, dtype=bool)
    wrapped = az % 360.0
    for turn in range(math.floor((left - 360.0) / 360.0), math.ceil(right / 360.0) + 1):
        inside |= shapely.intersects_xy(polygon, wrapped + 360.0 * turn, el)
    return inside


def _check_polygon(region: SkyRegion) -> None:
    region._polygon  # noqa: B018 (checks the ring)


def _zenith(argument: str, text: str) -> SkyRegion:
    (radius,) = region_numbers(argument, 1, text, "zenith:R")
    return SkyRegion("zenith", text, radius=radius)


def _zenith_mask(
    region: SkyRegion, el: NDArray[np.float64], az: NDArray[np.float64]
) -> NDArray[np.bool_]:
    assert region.radius is not None
    return np.asarray(el >= 90.0 - region.radius)


def _check_zenith(region: SkyRegion) -> None:
    radius = region.radius
    if radius is None or not (math.isfinite(radius) and 0 < radius <= 90):
        raise InputError(
            f"sky region {region.text!r}: zenith radius {radius!r} deg; expected 0 < R <= 90 deg"
        )


def _horizon(argument: str, text: str) -> SkyRegion:
    az1, az2, top = region_numbers(argument, 3, text, "horizon:AZ1,AZ2,EL")
    return SkyRegion("horizon", text, azimuths=(az1, az2), top=top)


def _horizon_mask(
    region: SkyRegion, el: NDArray[np.float64], az: NDArray[np.float64]
) -> NDArray[np.bool_]:
    assert region.azimuths is not None and region.top is not None
    start, span = region._band_span
    return np.asarray(((az - start) % 360.0 <= span) & (el >= 0.0) & (el <= region.top))


_KINDS["polygon"] = RegionKind(
    "polygon",
    "'az,el az,el ...'",
    "a closed polygon of (azimuth, elevation) vertices, or a GeoJSON/WKT file of one",
    None,
    _polygon_mask,
    _check_polygon,
)
_KINDS["zenith"] = RegionKind(
    "zenith",
    "zenith:R",
    "the cap of every direction with elevation >= 90 - R [deg]",
    _zenith,
    _zenith_mask,
    _check_zenith,
)
_KINDS["horizon"] = RegionKind(
    "horizon",
    "horizon:AZ1,AZ2,EL",
    "azimuth AZ1 clockwise to AZ2, elevation 0 to EL [deg]",
    _horizon,
    _horizon_mask,
    lambda region: region._check_band(),
)
