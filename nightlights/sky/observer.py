"""Who looks at the sky: :class:`Observer`, a position, its CRS, an eye height and a name.

Every sky stage takes its observers as these objects (as pvlib's stages take a ``Location``):
:func:`~nightlights.sky.skyglow`, the inverse maps, the dimming plan, the many-observer summary,
the explore session and the night-sky render. An observer is made from coordinates in any CRS
(:class:`Observer`), from longitude and latitude (:meth:`Observer.from_lonlat`), from a point
(:meth:`Observer.from_point`) or from each point of a vector layer
(:meth:`Observer.from_layer`), and is placed in a scene's projected CRS by
:meth:`Observer.position` (or :func:`positions`, many at once).

The eye height is above the ground: over a DEM the observer stands on the terrain at (x, y).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from pyproj import CRS, Transformer
from pyproj.exceptions import ProjError

from nightlights._typing import FloatArray, PathLike
from nightlights.errors import CRSError, InputError

if TYPE_CHECKING:
    import geopandas as gpd

__all__ = ["OBSERVER_HEIGHT", "Observer", "positions"]

#: Default eye height above the ground [m]: a standing adult (the eye of the ISO 7250 standing
#: adult, about 1.5-1.7 m; 1.7 m is the figure the toolkit has always used).
OBSERVER_HEIGHT = 1.7
#: The CRS of :meth:`Observer.from_lonlat`.
LONLAT_CRS = "EPSG:4326"


def _as_crs(crs: Any, where: str = "observer") -> CRS | None:
    if crs is None:
        return None
    if isinstance(crs, CRS):
        return crs
    try:
        return CRS.from_user_input(crs)
    except Exception as exc:  # pyproj raises its own CRSError
        raise CRSError(f"{where} CRS {crs!r} is not a CRS: {exc}") from exc


@dataclass(frozen=True)
class Observer:
    """An observer of the night sky: where, in which CRS, how high the eye, and a name.

    Parameters
    ----------
    x, y
        Position in ``crs`` [m, or deg for a geographic CRS: x longitude, y latitude].
    crs
        CRS of ``x``, ``y`` (anything :meth:`pyproj.CRS.from_user_input` reads); None: the
        CRS of the scene's emission raster.
    height
        Eye height above the ground (above the terrain over a DEM) [m].
    name
        A name for outputs and messages (None: none, or the stage numbers the observers).

    Raises
    ------
    InputError
        Coordinates that are not finite numbers, a negative or non-finite height, longitude or
        latitude out of range in a geographic CRS.
    CRSError
        ``crs`` is not a CRS.

    Examples
    --------
    >>> from nightlights.sky import Observer
    >>> Observer(1000.0, 2000.0, height=0.0)
    Observer(x=1000.0, y=2000.0, crs=None, height=0.0, name=None)
    >>> site = Observer.from_lonlat(24.03, 49.84, name="Lviv")
    >>> [round(v, 1) for v in site.position("EPSG:32635")]
    [286459.2, 5525072.9]
    """

    x: float
    y: float
    crs: Any = None  # a pyproj CRS (or None) once made; anything CRS.from_user_input reads
    height: float = OBSERVER_HEIGHT
    name: str | None = None

    def __post_init__(self) -> None:
        try:
            x, y = float(self.x), float(self.y)
        except (TypeError, ValueError):
            raise InputError(
                f"observer ({self.x!r}, {self.y!r}); expected two finite numbers"
            ) from None
        if not (np.isfinite(x) and np.isfinite(y)):
            raise InputError(f"observer ({x!r}, {y!r}); expected two finite numbers")
        try:
            height = float(self.height)
        except (TypeError, ValueError):
            raise InputError(f"observer height {self.height!r}; expected a number [m]") from None
        if not (np.isfinite(height) and height >= 0):
            raise InputError(f"observer height {height} m; expected a finite value >= 0")
        crs = _as_crs(self.crs)
        if crs is not None and crs.is_geographic and not (-360 <= x <= 360 and -90 <= y <= 90):
            raise InputError(
                f"observer ({x:g}, {y:g}) in {crs.name}: expected longitude within +-360 deg "
                "and latitude within +-90 deg (X,Y = lon,lat)"
            )
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "y", y)
        object.__setattr__(self, "height", height)
        object.__setattr__(self, "crs", crs)
        if self.name is not None:
            object.__setattr__(self, "name", str(self.name))

    def __repr__(self) -> str:
        crs = None if self.crs is None else self.crs.to_string()
        return (
            f"Observer(x={self.x!r}, y={self.y!r}, crs={crs!r}, height={self.height!r}, "
            f"name={self.name!r})"
        )

    # --- construction -------------------------------------------------------------------

    @classmethod
    def from_lonlat(
        cls,
        longitude: float,
        latitude: float,
        *,
        height: float = OBSERVER_HEIGHT,
        name: str | None = None,
    ) -> Observer:
        """An observer at a longitude and latitude (WGS 84, EPSG:4326).

        Parameters
        ----------
        longitude, latitude
            Position [deg].
        height
            Eye height above the ground [m].
        name
            Optional name.

        Returns
        -------
        Observer
        """
        return cls(longitude, latitude, LONLAT_CRS, height, name)

    @classmethod
    def from_point(
        cls,
        point: Any,
        crs: Any = None,
        *,
        height: float = OBSERVER_HEIGHT,
        name: str | None = None,
    ) -> Observer:
        """An observer at a point: a shapely ``Point`` or an ``(x, y)`` pair.

        Parameters
        ----------
        point
            The position, in ``crs``.
        crs
            Its CRS (None: the scene's).
        height
            Eye height above the ground [m].
        name
            Optional name.

        Returns
        -------
        Observer
        """
        if hasattr(point, "geom_type"):
            if point.geom_type != "Point" or point.is_empty:
                raise InputError(f"observer geometry {point.geom_type}; expected a point")
            return cls(point.x, point.y, crs, height, name)
        try:
            x, y = point
        except (TypeError, ValueError):
            raise InputError(f"observer {point!r}; expected a point or (x, y)") from None
        return cls(x, y, crs, height, name)

    @classmethod
    def from_layer(
        cls,
        layer: gpd.GeoDataFrame | PathLike,
        *,
        layer_name: str | None = None,
        crs: Any = None,
        height: float = OBSERVER_HEIGHT,
        names: Sequence[str] | None = None,
    ) -> tuple[Observer, ...]:
        """One observer per point of a vector layer (GeoDataFrame or any file GDAL reads).

        Parameters
        ----------
        layer
            Points; a ``name`` column names the observers.
        layer_name
            Layer of a file (default: its first).
        crs
            CRS of a layer that has none; refused when the layer has another.
        height
            Eye height above the ground of every observer [m].
        names
            One name per point, instead of the ``name`` column.

        Returns
        -------
        tuple of Observer
            In the layer's order, in the layer's CRS.

        Raises
        ------
        InputError
            A feature that is not a point, an empty layer, a name count that differs.
        CRSError
            A layer without a CRS and no ``crs``, or a ``crs`` that differs from the layer's.
        """
        import geopandas as gpd

        from nightlights.io.vector import as_vector

        if not isinstance(layer, gpd.GeoDataFrame | str | os.PathLike):
            raise InputError(
                f"observers layer of type {type(layer).__name__}; expected a GeoDataFrame or "
                "a path to a vector file"
            )
        frame, where = as_vector(layer, layer=layer_name, name="observers")
        given = _as_crs(crs)
        if frame.crs is not None and given is not None and not given.equals(frame.crs):
            raise InputError(
                f"{where}: the layer is in {frame.crs.name} but crs is {crs}; give crs only "
                "for a layer without a CRS"
            )
        if frame.crs is None and given is None:
            raise CRSError(f"{where}: the observers' layer has no CRS; give crs")
        layer_crs = frame.crs if frame.crs is not None else given
        empty = frame.geometry.is_empty | frame.geometry.isna()
        if empty.any() or not frame.geom_type.eq("Point").all():
            bad = int(np.nonzero(empty.to_numpy() | ~frame.geom_type.eq("Point").to_numpy())[0][0])
            raise InputError(
                f"{where}: feature {bad} is a {frame.geom_type.iloc[bad] or 'empty geometry'}; "
                "expected points"
            )
        if len(frame) == 0:
            raise InputError(f"{where}: no observer")
        labels: list[str] | None = None
        if names is not None:
            labels = [str(v) for v in names]
            if len(labels) != len(frame):
                raise InputError(f"{len(labels)} names for {len(frame)} observers")
        elif "name" in frame:
            labels = [str(v) for v in frame["name"]]
        xs, ys = frame.geometry.x.to_numpy(), frame.geometry.y.to_numpy()
        out = []
        for index in range(len(frame)):
            try:
                out.append(
                    cls(xs[index], ys[index], layer_crs, height, labels[index] if labels else None)
                )
            except InputError as exc:
                raise type(exc)(f"{where}: feature {index}: {exc}") from None
        return tuple(out)

    def replace(self, **changes: Any) -> Observer:
        """A copy with some fields changed (``height=0.0``, ``name="roof"``)."""
        return dataclasses.replace(self, **changes)

    # --- placing ------------------------------------------------------------------------

    def position(self, crs: Any) -> tuple[float, float]:
        """The observer's (x, y) in ``crs`` [m] (unchanged when the observer has no CRS).

        Raises
        ------
        CRSError
            The observer cannot be placed in ``crs``.
        """
        if self.crs is None:
            return self.x, self.y
        target = _as_crs(crs, "target")
        try:
            transformer = Transformer.from_crs(self.crs, target, always_xy=True)
            tx, ty = transformer.transform(self.x, self.y, errcheck=True)
        except ProjError as exc:
            raise CRSError(
                f"observer ({self.x:g}, {self.y:g}) cannot be placed from {self.crs.name} into "
                f"the raster's CRS: {exc}"
            ) from exc
        if not (np.isfinite(tx) and np.isfinite(ty)):
            raise CRSError(
                f"observer ({self.x:g}, {self.y:g}) in {self.crs.name} has no position in the "
                "raster's CRS"
            )
        return float(tx), float(ty)

    def lonlat(self, crs: Any = None) -> tuple[float, float]:
        """Longitude and latitude [deg]; ``crs`` is the scene's, for an observer without one."""
        own = self.crs if self.crs is not None else _as_crs(crs)
        if own is None:
            raise CRSError(
                f"observer ({self.x:g}, {self.y:g}) has no CRS; give one to place it on the Earth"
            )
        if own.equals(CRS.from_user_input(LONLAT_CRS)):
            return self.x, self.y
        return Observer(self.x, self.y, own).position(LONLAT_CRS)


def positions(observers: Sequence[Observer], crs: Any, where: str = "observers") -> FloatArray:
    """The ``(n, 2)`` positions of many observers in ``crs`` [m], one transformation per CRS.

    Parameters
    ----------
    observers
        The observers.
    crs
        The target CRS (the scene's).
    where
        How messages name the observers.

    Returns
    -------
    numpy.ndarray
        ``(n, 2)`` (x, y).
    """
    target = _as_crs(crs, "target")
    out = np.array([[o.x, o.y] for o in observers], dtype=float).reshape(-1, 2)
    groups: dict[str, list[int]] = {}
    for index, observer in enumerate(observers):
        if observer.crs is not None and not observer.crs.equals(target):
            groups.setdefault(observer.crs.to_wkt(), []).append(index)
    for wkt, members in groups.items():
        source = CRS.from_wkt(wkt)
        try:
            transformer = Transformer.from_crs(source, target, always_xy=True)
            x, y = transformer.transform(out[members, 0], out[members, 1], errcheck=True)
        except ProjError as exc:
            raise CRSError(
                f"{where}: the observers cannot be placed from {source.name} into the "
                f"emission's CRS: {exc}"
            ) from exc
        out[members] = np.column_stack([x, y])
    if not np.isfinite(out).all():
        raise CRSError(f"{where}: some observers have no position in the emission's CRS")
    return out
