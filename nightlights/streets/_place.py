"""Light placement along streets (Chuang 2011, Sec. 3.1, Fig. 8).

Each lit street gets a jittered grid of poles in its sampled arrangement: one row on one side
(single-sided rectangular grid), two rows with poles opposite each other (double-sided
rectangular), two rows alternating sides (triangular, "staggered"), or one row of twin-arm
poles on the median (central). Poles follow the curve: positions are measured along the line,
not its chord, and offset along the local normal.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
from scipy.spatial import cKDTree

from nightlights._resources import check_memory
from nightlights._typing import PathLike
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError
from nightlights.io import as_vector, ensure_projected, write_gpkg
from nightlights.io.outputs import OutputSet
from nightlights.io.styles import poles_style
from nightlights.io.vector import FieldType
from nightlights.streets._checks import check_street_values, finite_vertices, rng_from_seed
from nightlights.streets.schema import ARRANGEMENTS, STREET_CLASSES

#: Fields of the output light layer and their types.
LIGHT_FIELDS: dict[str, FieldType] = {
    "light_id": "int",
    "pole_id": "int",
    "street_id": "str",
    "system_id": "str",
    "heading": "float",
    "mounting_height": "float",
    "arm_length": "float",
    "tilt": "float",
    "side": "str",
    "arrangement": "str",
}

_REQUIRED = ("width", "lit", "arrangement", "spacing", "mounting_height", "system_id")
_DEFAULTS = {"arm_length": 0.0, "setback": 1.0, "tilt": 0.0, "occupancy": 1.0}
_CHECKED = ("width", "spacing", "mounting_height", "arm_length", "setback", "tilt", "occupancy")

#: Luminaires per pole position by arrangement (Chuang 2011, Fig. 8).
LIGHTS_PER_POSITION = {"single_sided": 1, "staggered": 1, "opposite": 2, "central": 2}

#: Peak memory per placed luminaire [B]: resident memory grew by about 1.1 kB per luminaire
#: from 3e5 to 1.2e6 luminaires (positions, shapely points for the pole and its tangent
#: chord, the light table, the pole-merging tree and its neighbour lists, the output layer);
#: rounded up.
BYTES_PER_LIGHT = 1600


#: Largest across-street jitter [m]: a few metres put a pole on the far side of a pavement;
#: more would move it off its street.
MAX_ACROSS_JITTER = 10.0


@dataclass(frozen=True)
class PlacementOptions:
    """Knobs of the placement grid.

    Attributes
    ----------
    along_jitter
        Standard deviation of the along-street jitter as a fraction of the spacing, in
        [0, 0.25) [1].
    across_jitter
        Standard deviation of the across-street jitter, at most
        :data:`MAX_ACROSS_JITTER` [m].
    merge_fraction
        Poles of different streets closer than this fraction of the spacing are merged
        (where streets meet); the pole of the higher street class stays; in [0, 1] [1].
    tangent_step
        Half-length of the chord used to estimate the local street direction, > 0 [m].
    """

    along_jitter: float = 0.05
    across_jitter: float = 0.2
    merge_fraction: float = 0.5
    tangent_step: float = 1.0

    def __post_init__(self) -> None:
        for name in ("along_jitter", "across_jitter", "merge_fraction", "tangent_step"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise InputError(f"placement option {name}={value!r}; expected a number >= 0")
        if self.along_jitter >= 0.25:
            raise InputError(
                f"placement option along_jitter={self.along_jitter}; expected < 0.25 of the "
                "spacing so that poles keep their order along the street"
            )
        if self.across_jitter > MAX_ACROSS_JITTER:
            raise InputError(
                f"placement option across_jitter={self.across_jitter} m; expected at most "
                f"{MAX_ACROSS_JITTER:g} m so that poles stay beside their street"
            )
        if self.merge_fraction > 1:
            raise InputError(
                f"placement option merge_fraction={self.merge_fraction}; expected a fraction "
                "of the spacing in [0, 1]"
            )
        if self.tangent_step == 0:
            raise InputError("placement option tangent_step=0; expected a length > 0 [m]")


def place_lights(
    streets: gpd.GeoDataFrame,
    *,
    rng: np.random.Generator,
    options: PlacementOptions | None = None,
    source: str = "streets",
) -> gpd.GeoDataFrame:
    """Place light systems along lit streets.

    Parameters
    ----------
    streets
        Output of ``streets sample``: lines in a projected CRS [m] with ``width`` [m],
        ``lit``, ``arrangement``, ``spacing`` [m], ``mounting_height`` [m], ``system_id``
        and optionally ``arm_length`` [m], ``setback`` [m], ``tilt`` [deg],
        ``occupancy`` [1], ``street_class`` and ``source_id``.
    rng
        Random generator for the pole count, phase and jitter.
    options
        Grid knobs (:class:`PlacementOptions`).
    source
        Name of the layer, used in messages.

    Returns
    -------
    geopandas.GeoDataFrame
        One point per luminaire at its pole foot, with :data:`LIGHT_FIELDS`. ``heading`` is
        the compass bearing [deg] from the pole towards the carriageway; a central twin-arm
        pole carries two luminaires with opposite headings.

    Notes
    -----
    On a street of length L with spacing s the number of pole positions is
    ``floor(L / s + U)``, ``U ~ Uniform(0, 1)``, so that its expectation is exactly ``L / s``
    even on the short pieces OSM splits streets into; the positions keep spacing s and start
    at a uniform random phase. Opposite and central arrangements put a pole pair (or a
    twin-arm pole) at every position; staggered alternates sides, so consecutive poles on
    one side are 2 s apart. Where a street's ``occupancy`` q is below 1 (a network learned
    from mapped lamps, :func:`~nightlights.streets.learn`), only a stretch of
    ``floor(q n + U)`` successive positions of the n holds poles, at a uniform random start:
    the expected count is q L / s and the poles keep spacing s (mapped streets are often lit
    along part of their length). Poles of different streets closer than
    ``merge_fraction * s`` are merged, keeping the pole of the higher street class.

    Raises
    ------
    InputError
        Missing fields, an unknown arrangement, or an impossible width, spacing, mounting
        height, arm length, setback or tilt (outside
        :data:`~nightlights.streets.schema.VALUE_RANGES`).
    nightlights.errors.ResourceError
        The expected number of luminaires would need more memory than allowed.

    Warns
    -----
    DataQualityWarning
        Unusual values (counted per field); lit streets dropped for NaN or infinite vertex
        coordinates or for not being lines (counted).

    References
    ----------
    Chuang 2011, Sec. 3.1 and Fig. 8 (rectangular and triangular light-point grids).
    """
    options = options or PlacementOptions()
    if streets.crs is None or not streets.crs.is_projected:
        raise InputError("place_lights needs streets in a projected CRS [m]")
    missing = [name for name in _REQUIRED if name not in streets]
    if missing:
        raise InputError(f"streets lack fields {missing}; run `nightlights streets sample` first")
    table = _street_table(streets, source)
    if table.empty:
        return _empty_lights(streets.crs)
    lengths = shapely.length(table.geometry.to_numpy())
    spacing = table["spacing"].to_numpy(float)
    _check_light_count(table, lengths, spacing)
    counts = np.floor(lengths / spacing + rng.random(len(table))).astype(int)
    slack = np.maximum(lengths - np.maximum(counts - 1, 0) * spacing, 0.0)
    phase = rng.random(len(table)) * slack
    street_index = np.repeat(np.arange(len(table)), counts)
    position = np.concatenate([np.arange(n) for n in counts]) if counts.sum() else np.zeros(0)
    along = phase[street_index] + position * spacing[street_index]
    along += rng.normal(0.0, options.along_jitter, along.size) * spacing[street_index]
    along = np.clip(along, 0.0, lengths[street_index])
    occupancy = table["occupancy"].to_numpy(float)
    if (occupancy < 1.0).any():
        # a lit stretch of floor(q n + U) successive positions (expectation q n) at a
        # uniform random start
        kept = np.floor(occupancy * counts + rng.random(len(table))).astype(int)
        start = np.floor(rng.random(len(table)) * (counts - kept + 1)).astype(int)
        first = start[street_index]
        held = (position >= first) & (position < first + kept[street_index])
        street_index, position, along = street_index[held], position[held], along[held]

    rows = _expand_arrangement(table, street_index, position.astype(int))
    street_of_row = street_index[rows.slot]
    geoms = table.geometry.to_numpy()[street_of_row]
    distance = along[rows.slot]
    point, tangent = _point_and_tangent(geoms, distance, lengths[street_of_row], options)
    normal_left = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    half_width = 0.5 * table["width"].to_numpy(float)[street_of_row]
    setback = table["setback"].to_numpy(float)[street_of_row]
    offset = np.where(rows.side_sign == 0, 0.0, half_width + setback)
    offset = offset + rng.normal(0.0, options.across_jitter, offset.size) * (rows.side_sign != 0)
    pole_xy = point + normal_left * (rows.side_sign * offset)[:, None]
    facing = -normal_left * np.where(rows.side_sign == 0, rows.face_sign, rows.side_sign)[:, None]
    heading = np.degrees(np.arctan2(facing[:, 0], facing[:, 1])) % 360.0

    lights = pd.DataFrame(
        {
            "pole_key": rows.pole,
            "street_id": table["source_id"].to_numpy()[street_of_row],
            "system_id": table["system_id"].to_numpy()[street_of_row],
            "heading": heading,
            "mounting_height": table["mounting_height"].to_numpy(float)[street_of_row],
            "arm_length": table["arm_length"].to_numpy(float)[street_of_row],
            "tilt": table["tilt"].to_numpy(float)[street_of_row],
            "side": np.array(["right", "center", "left"])[rows.side_sign + 1],
            "arrangement": table["arrangement"].to_numpy()[street_of_row],
            "x": pole_xy[:, 0],
            "y": pole_xy[:, 1],
            "_street": street_of_row,
            "_spacing": spacing[street_of_row],
            "_rank": table["_rank"].to_numpy()[street_of_row],
        }
    )
    lights = _merge_poles(lights, options.merge_fraction)
    lights["pole_id"] = pd.factorize(lights["pole_key"])[0]
    lights["light_id"] = np.arange(len(lights))
    geometry = gpd.points_from_xy(lights["x"], lights["y"], crs=streets.crs)
    return gpd.GeoDataFrame(lights[list(LIGHT_FIELDS)], geometry=geometry, crs=streets.crs)


@dataclass(frozen=True, eq=False)
class PlaceResult:
    """What :func:`place` returns.

    Attributes
    ----------
    lights
        One point per luminaire with :data:`LIGHT_FIELDS` (see :func:`place_lights`).
    path
        The GeoPackage written, or None when no output was asked for.
    """

    lights: gpd.GeoDataFrame
    path: Path | None


def place(
    streets: gpd.GeoDataFrame | PathLike,
    output: PathLike | None = None,
    *,
    seed: int | None = None,
    along_jitter: float | None = None,
    across_jitter: float | None = None,
    merge_fraction: float | None = None,
    catalog: str | os.PathLike[str] | None = None,
    options: PlacementOptions | None = None,
) -> PlaceResult:
    """Place light systems along the lit streets.

    Stage ``streets place`` (Chuang 2011, Sec. 3.1, Fig. 8); see :func:`place_lights`.

    Parameters
    ----------
    streets
        Sampled streets (the result of :func:`~nightlights.streets._sample`): a GeoDataFrame
        or a vector file path. A geographic layer is reprojected to its local UTM zone.
    output
        GeoPackage to write (layer ``lights``), atomically; None writes nothing.
    seed
        Random seed; the same seed gives the same lights.
    along_jitter
        Standard deviation of the along-street jitter as a fraction of the spacing [1]
        (default 0.05).
    across_jitter
        Standard deviation of the across-street jitter [m] (default 0.2).
    merge_fraction
        Poles of different streets closer than this fraction of the spacing are merged [1]
        (default 0.5).
    catalog
        Luminaire database folder; every ``system_id`` must exist in it (default: the
        bundled database, when the photometry package provides one).
    options
        All grid knobs at once, instead of ``along_jitter``, ``across_jitter`` and
        ``merge_fraction``.

    Returns
    -------
    PlaceResult
        The lights and the written path (or None).

    Raises
    ------
    InputError
        Both ``options`` and one of the separate knobs are given; a knob is out of range;
        a negative seed; the streets lack sampled fields or hold impossible values; a
        ``system_id`` is not in the luminaire database.
    OutputError
        The output folder is missing or not writable (checked before any work).
    nightlights.errors.ResourceError
        The expected luminaires would need more memory than allowed.
    EmptyInputError
        The layer has no streets.
    CRSError
        The layer has no CRS.

    Examples
    --------
    >>> import geopandas as gpd
    >>> from shapely import LineString
    >>> from nightlights.streets import place
    >>> streets = gpd.GeoDataFrame(
    ...     {
    ...         "source_id": ["a", "b"],
    ...         "width": [8.0, 12.0],
    ...         "lit": [True, True],
    ...         "arrangement": ["single_sided", "opposite"],
    ...         "spacing": [30.0, 40.0],
    ...         "mounting_height": [8.0, 10.0],
    ...         "system_id": ["street_led_small", "road_led_large"],
    ...     },
    ...     geometry=[LineString([(0, 0), (300, 0)]), LineString([(0, 100), (400, 100)])],
    ...     crs="EPSG:3067",
    ... )
    >>> result = place(streets, seed=0, along_jitter=0.0, across_jitter=0.0)
    >>> result.lights.groupby("street_id").size().to_dict()
    {'a': 10, 'b': 20}
    >>> sorted(set(result.lights.loc[result.lights["street_id"] == "b", "side"]))
    ['left', 'right']
    >>> result.path is None
    True
    """
    options = _placement_options(options, along_jitter, across_jitter, merge_fraction)
    rng = rng_from_seed(seed)
    with OutputSet(output, inputs={"streets": streets, "catalog": catalog}) as outputs:
        frame, source = as_vector(streets, name="streets")
        if frame.empty:
            raise EmptyInputError(f"{source}: the layer has no streets")
        if frame.crs is None or not frame.crs.is_projected:
            frame = ensure_projected(frame, source=source)
        lights = place_lights(frame, rng=rng, options=options, source=source)
        _check_system_ids(lights, catalog, source=source)
        path = None
        if output is not None:
            write_gpkg(
                lights,
                outputs.temporary(output),
                layer="lights",
                schema=LIGHT_FIELDS,
                style=poles_style(lights["system_id"].dropna().astype(str).unique()),
            )
            path = Path(output)
    return PlaceResult(lights, path)


def _placement_options(
    options: PlacementOptions | None,
    along_jitter: float | None,
    across_jitter: float | None,
    merge_fraction: float | None,
) -> PlacementOptions:
    """One set of grid knobs from either ``options`` or the separate keywords."""
    knobs = {
        "along_jitter": along_jitter,
        "across_jitter": across_jitter,
        "merge_fraction": merge_fraction,
    }
    given = {name: value for name, value in knobs.items() if value is not None}
    if options is None:
        return PlacementOptions(**given)
    if given:
        raise InputError(
            f"placement options given twice: options={options!r} and {sorted(given)}; "
            "pass either options or the separate keywords"
        )
    return options


@dataclass(frozen=True)
class _ArrangementRows:
    slot: np.ndarray  # index into the pole positions
    side_sign: np.ndarray  # +1 left of the line direction, -1 right, 0 on the centreline
    face_sign: np.ndarray  # for central poles: +1 faces left carriageway, -1 right
    pole: np.ndarray  # pole key: lights with the same key share a pole


def _expand_arrangement(
    table: pd.DataFrame, street_index: np.ndarray, position: np.ndarray
) -> _ArrangementRows:
    arrangement = table["arrangement"].to_numpy()[street_index]
    first_side = table["_first_side"].to_numpy()[street_index]
    slots = np.arange(street_index.size)
    parts = []
    single = arrangement == "single_sided"
    parts.append((slots[single], first_side[single], np.zeros(single.sum(), int), 0))
    staggered = arrangement == "staggered"
    alternate = np.where(position[staggered] % 2 == 0, 1, -1) * first_side[staggered]
    parts.append((slots[staggered], alternate, np.zeros(staggered.sum(), int), 0))
    opposite = arrangement == "opposite"
    for sign, key in ((1, 0), (-1, 1)):
        parts.append(
            (slots[opposite], np.full(opposite.sum(), sign), np.zeros(opposite.sum(), int), key)
        )
    central = arrangement == "central"
    for facing in (1, -1):
        parts.append(
            (slots[central], np.zeros(central.sum(), int), np.full(central.sum(), facing), 0)
        )
    slot = np.concatenate([p[0] for p in parts])
    side = np.concatenate([p[1] for p in parts]).astype(int)
    face = np.concatenate([p[2] for p in parts]).astype(int)
    pole = np.concatenate([p[0] * 2 + p[3] for p in parts])
    order = np.lexsort((face, side, slot))
    return _ArrangementRows(slot[order], side[order], face[order], pole[order])


def _street_table(streets: gpd.GeoDataFrame, source: str) -> gpd.GeoDataFrame:
    table = streets.copy()
    if "source_id" not in table:
        table["source_id"] = table.index.astype(str)
    lit = table["lit"].astype("boolean").fillna(False).to_numpy(bool)
    table = table.loc[lit].copy()
    for name, default in _DEFAULTS.items():
        if name not in table:
            table[name] = default
        table[name] = table[name].where(table[name].notna(), default)
    bad = ~table["arrangement"].isin(ARRANGEMENTS)
    if bad.any():
        raise InputError(
            f"{source}: street {table.loc[bad, 'source_id'].iloc[0]!r}: arrangement "
            f"{table.loc[bad, 'arrangement'].iloc[0]!r}; expected one of {', '.join(ARRANGEMENTS)}"
        )
    check_street_values(table, _CHECKED, source=source)
    for name in _CHECKED:
        table[name] = pd.to_numeric(table[name]).astype(float)
    table = table.loc[~(table.geometry.isna() | table.geometry.is_empty)]
    table = table.explode(index_parts=False)
    lines = (table.geometry.geom_type == "LineString").to_numpy()
    finite = finite_vertices(table.geometry.to_numpy())
    dropped = {
        "not lines": int((~lines).sum()),
        "with NaN or infinite vertex coordinates": int((lines & ~finite).sum()),
    }
    for reason, count in dropped.items():
        if count:
            warnings.warn(
                f"{source}: {count} lit street part(s) {reason} dropped (no lights placed)",
                DataQualityWarning,
                stacklevel=4,
            )
    table = table.loc[lines & finite]
    table = table.loc[shapely.length(table.geometry.to_numpy()) > 0].reset_index(drop=True)
    classes = {name: rank for rank, name in enumerate(STREET_CLASSES)}
    street_class = (
        table["street_class"] if "street_class" in table else pd.Series(None, index=table.index)
    )
    table["_rank"] = street_class.map(classes).fillna(len(classes)).astype(int).to_numpy()
    # Single-sided rows stand on the right of the line direction by default (the kerb side
    # in right-hand traffic); staggered rows start there.
    table["_first_side"] = -1
    return table


def _check_light_count(table: pd.DataFrame, lengths: np.ndarray, spacing: np.ndarray) -> None:
    """Refuse a placement whose expected luminaires would not fit in memory."""
    per_position = table["arrangement"].map(LIGHTS_PER_POSITION).to_numpy(float)
    expected = float(np.sum((lengths / spacing + 1.0) * per_position))
    check_memory(
        expected * BYTES_PER_LIGHT,
        f"placing about {expected:.3g} luminaires ({lengths.sum():.3g} m of lit streets, "
        f"spacing down to {spacing.min():.3g} m)",
        option="check the streets' spacing (a larger spacing places fewer poles)",
    )


def _point_and_tangent(
    geoms: np.ndarray, distance: np.ndarray, length: np.ndarray, options: PlacementOptions
) -> tuple[np.ndarray, np.ndarray]:
    point = shapely.get_coordinates(shapely.line_interpolate_point(geoms, distance))[:, :2]
    step = np.minimum(options.tangent_step, 0.5 * length)
    ahead = shapely.line_interpolate_point(geoms, np.minimum(distance + step, length))
    behind = shapely.line_interpolate_point(geoms, np.maximum(distance - step, 0.0))
    chord = shapely.get_coordinates(ahead)[:, :2] - shapely.get_coordinates(behind)[:, :2]
    norm = np.hypot(chord[:, 0], chord[:, 1])
    norm[norm == 0] = 1.0
    return point, chord / norm[:, None]


def _merge_poles(lights: pd.DataFrame, merge_fraction: float) -> pd.DataFrame:
    """Drop poles closer than ``merge_fraction * spacing`` to a kept pole of another street."""
    if lights.empty or merge_fraction == 0:
        return lights
    poles = (
        lights.groupby("pole_key", sort=False)
        .agg(
            x=("x", "first"),
            y=("y", "first"),
            street=("_street", "first"),
            spacing=("_spacing", "first"),
            rank=("_rank", "first"),
        )
        .reset_index()
    )
    poles = poles.sort_values(["rank", "street", "pole_key"], kind="stable").reset_index(drop=True)
    xy = poles[["x", "y"]].to_numpy()
    tree = cKDTree(xy)
    radius = merge_fraction * poles["spacing"].to_numpy()
    neighbours = tree.query_ball_point(xy, radius)
    keep = np.ones(len(poles), dtype=bool)
    street = poles["street"].to_numpy()
    for index, near in enumerate(neighbours):
        # Poles are visited in priority order; a pole survives unless a pole of another
        # street, already kept and earlier in priority, stands within its radius.
        if any(j < index and keep[j] and street[j] != street[index] for j in near):
            keep[index] = False
    kept_keys = set(poles.loc[keep, "pole_key"])
    return lights.loc[lights["pole_key"].isin(kept_keys)].reset_index(drop=True)


def _empty_lights(crs: object) -> gpd.GeoDataFrame:
    frame = pd.DataFrame(
        {name: pd.Series(dtype=_PANDAS_TYPES[kind]) for name, kind in LIGHT_FIELDS.items()}
    )
    return gpd.GeoDataFrame(frame, geometry=gpd.GeoSeries([], crs=crs), crs=crs)


_PANDAS_TYPES = {"int": "int64", "float": "float64", "str": object, "bool": bool}


def _check_system_ids(
    lights: gpd.GeoDataFrame, catalog: str | os.PathLike[str] | None, *, source: str
) -> None:
    try:
        from ies.library import load_library
    except ImportError:  # the photometry package has no luminaire database yet
        if catalog is not None:
            raise InputError("catalog= needs the ies luminaire database, not installed") from None
        return
    database = load_library(catalog)
    unknown = sorted(set(lights["system_id"]) - set(database.systems))
    if unknown:
        raise InputError(
            f"{source}: light system ids {unknown} are not in the luminaire database "
            f"(known: {', '.join(sorted(database.systems))})"
        )
