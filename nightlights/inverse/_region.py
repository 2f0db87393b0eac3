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
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import MultiPolygon, Polygon, shape

from nightlights.errors import InputError

__all__ = ["SkyRegion"]

#: The kinds of region.
KINDS = ("polygon", "zenith", "horizon")
#: The shortcut kinds a text may start with (``zenith:R``, ``horizon:AZ1,AZ2,EL``).
SHORTCUTS = ("zenith", "horizon")
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
        ``"polygon"``, ``"zenith"`` or ``"horizon"``.
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

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InputError(f"sky region kind {self.kind!r}; expected one of {', '.join(KINDS)}")
        if self.kind == "polygon":
            self._polygon  # noqa: B018 (checks the ring)
        elif self.kind == "zenith":
            radius = self.radius
            if radius is None or not (math.isfinite(radius) and 0 < radius <= 90):
                raise InputError(
                    f"sky region {self.text!r}: zenith radius {radius!r} deg; expected "
                    "0 < R <= 90 deg"
                )
        else:
            self._check_band()

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
        if name == "zenith":
            (radius,) = _numbers(argument, 1, text, "zenith:R")
            return cls("zenith", text, radius=radius)
        if name == "horizon":
            az1, az2, top = _numbers(argument, 3, text, "horizon:AZ1,AZ2,EL")
            return cls("horizon", text, azimuths=(az1, az2), top=top)
        raise InputError(
            f"sky region {text!r}: unknown shortcut {name!r}; expected zenith:R, "
            "horizon:AZ1,AZ2,EL, 'az,el az,el ...' or a GeoJSON/WKT file"
        )

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
        if self.kind == "zenith":
            assert self.radius is not None
            return np.asarray(el >= 90.0 - self.radius)
        if self.kind == "horizon":
            assert self.azimuths is not None and self.top is not None
            start, span = self._band_span
            return np.asarray(((az - start) % 360.0 <= span) & (el >= 0.0) & (el <= self.top))
        polygon, left, right = self._polygon
        inside = np.zeros(el.shape, dtype=bool)
        wrapped = az % 360.0
        for turn in range(math.floor((left - 360.0) / 360.0), math.ceil(right / 360.0) + 1):
            inside |= shapely.intersects_xy(polygon, wrapped + 360.0 * turn, el)
        return inside

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


def _numbers(argument: str, count: int, text: str, form: str) -> list[float]:
    """``count`` comma-separated finite floats of a shortcut [deg]."""
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
