"""Checks shared by the street stages: seeds, line geometries, vertex coordinates and value
ranges.

Impossible values (outside the allowed range of
:data:`~nightlights.streets.schema.VALUE_RANGES`) are errors that name the street and the
value; legal but surprising ones are counted in one :class:`DataQualityWarning` per field.
"""

from __future__ import annotations

import operator
import warnings
from collections.abc import Iterable

import numpy as np
import pandas as pd
import shapely

from bayesnets import BayesNet
from bayesnets.errors import BindingError
from nightlights.errors import DataQualityWarning, InputError
from nightlights.streets.schema import VALUE_RANGES


def rng_from_seed(seed: object) -> np.random.Generator:
    """A random generator from a seed, refusing what numpy would reject with a traceback.

    Parameters
    ----------
    seed
        None (fresh entropy) or an integer >= 0.

    Returns
    -------
    numpy.random.Generator
        The generator.

    Raises
    ------
    InputError
        A negative or non-integer seed.

    Examples
    --------
    >>> rng_from_seed(-1)
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: seed -1; expected an integer >= 0
    """
    if isinstance(seed, bool | np.bool_):
        raise InputError(f"seed {seed!r}; expected an integer >= 0")
    if seed is not None:
        try:
            value = operator.index(seed)  # type: ignore[arg-type]
        except TypeError:
            raise InputError(f"seed {seed!r}; expected an integer >= 0") from None
        if value < 0:
            raise InputError(f"seed {seed!r}; expected an integer >= 0")
    return np.random.default_rng(seed)  # type: ignore[arg-type]


def check_lines(frame: pd.DataFrame, source: str) -> None:
    """Refuse a street layer with geometries other than lines (points, polygons).

    Parameters
    ----------
    frame
        The streets (a GeoDataFrame); missing geometries are left to the stage.
    source
        Name of the layer, used in the message.

    Raises
    ------
    InputError
        A geometry that is not a LineString or MultiLineString: the message names the first
        such type and how many features have it.

    Examples
    --------
    >>> import geopandas as gpd
    >>> from shapely import Point
    >>> check_lines(gpd.GeoDataFrame(geometry=[Point(0, 0)]), "stops.gpkg")
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: stops.gpkg: the streets layer holds Point geometries (1 of 1 \
features); expected lines (LineString or MultiLineString), the normalised streets of \
`nightlights streets normalize`
    """
    kinds = frame.geometry.geom_type
    wrong = kinds.notna() & ~kinds.isin(["LineString", "MultiLineString"])
    if wrong.any():
        found = str(kinds[wrong].iloc[0])
        count = int((kinds == found).sum())
        raise InputError(
            f"{source}: the streets layer holds {found} geometries ({count} of {len(frame)} "
            "features); expected lines (LineString or MultiLineString), the normalised streets "
            "of `nightlights streets normalize`"
        )


def finite_vertices(geometries: np.ndarray) -> np.ndarray:
    """True for each geometry whose vertices all have finite x and y.

    Parameters
    ----------
    geometries
        Shapely geometries (None counts as finite: it is dropped elsewhere).

    Returns
    -------
    numpy.ndarray
        ``bool`` per geometry.

    Examples
    --------
    >>> from shapely import LineString
    >>> finite_vertices(np.array([LineString([(0, 0), (1, 1)]),
    ...                           LineString([(0, 0), (float("nan"), 1), (2, 2)])])).tolist()
    [True, False]
    """
    geometries = np.asarray(geometries, dtype=object)
    coordinates, owner = shapely.get_coordinates(geometries, return_index=True)
    bad = ~np.isfinite(coordinates).all(axis=1)
    ok = np.ones(len(geometries), dtype=bool)
    ok[owner[bad]] = False
    return ok


def check_street_values(
    table: pd.DataFrame, names: Iterable[str], *, source: str, id_field: str = "source_id"
) -> None:
    """Refuse impossible values of numeric street fields; warn about unusual ones.

    Parameters
    ----------
    table
        Streets; ``id_field`` names a street in messages.
    names
        Fields to check, each with a range in :data:`VALUE_RANGES`; absent fields are
        skipped.
    source
        Name of the layer, used in messages.
    id_field
        Field holding the street id (default ``source_id``; the row label without it).

    Raises
    ------
    InputError
        A value is missing, not finite or outside the allowed range; the message names the
        first such street, the value, the number of streets affected and the range.

    Warns
    -----
    DataQualityWarning
        Values outside the usual range, counted per field.
    """
    ids = table[id_field] if id_field in table else pd.Series(table.index, index=table.index)
    for name in names:
        if name not in table:
            continue
        limits = VALUE_RANGES[name]
        values = pd.to_numeric(table[name], errors="coerce").to_numpy(float)
        impossible = limits.impossible(values)
        if impossible.any():
            first = int(np.flatnonzero(impossible)[0])
            raw = table[name].iloc[first]
            raise InputError(
                f"{source}: street {ids.iloc[first]!r}: {name}={_show(raw)}"
                f"{_more(int(impossible.sum()))}; expected {limits.expected}"
            )
        unusual = limits.unusual(values)
        if unusual.any():
            shown = ", ".join(f"{v:g}" for v in np.unique(values[unusual])[:5])
            warnings.warn(
                f"{source}: {name}: {int(unusual.sum())} street(s) with unusual values "
                f"({shown}; usually {limits.usual})",
                DataQualityWarning,
                stacklevel=3,
            )


def _show(value: object) -> str:
    """A value as a user wrote it: numbers plainly, text quoted."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.number):
        return repr(value)
    return f"{float(value):g}"


def _more(count: int) -> str:
    return f" (and {count - 1} more street(s))" if count > 1 else ""


def check_network_values(network: BayesNet, names: Iterable[str]) -> None:
    """Refuse a network whose numeric states decode to impossible field values.

    Parameters
    ----------
    network
        Network with field bindings.
    names
        Fields to check, each with a range in :data:`VALUE_RANGES`; fields the network
        does not bind are skipped.

    Raises
    ------
    bayesnets.errors.BindingError
        A state of a bound numeric variable decodes to a value outside its allowed range.
    """
    wanted = set(names)
    for binding in network.bindings.values():
        if binding.field not in wanted or not binding.numbers:
            continue
        limits = VALUE_RANGES[binding.field]
        impossible = limits.impossible(binding.numbers)
        if impossible.any():
            k = int(np.flatnonzero(impossible)[0])
            where = f" ({network.source})" if network.source else ""
            raise BindingError(
                f"network {network.name!r}{where}: variable {binding.variable} state "
                f"{binding.states[k]!r} gives {binding.field}={binding.numbers[k]:g}; "
                f"expected {limits.expected}"
            )
