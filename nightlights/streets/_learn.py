"""Learn a street-lighting network from mapped street lamps.

Stage ``streets learn`` (beyond Chuang 2011, whose Fig. 10 weights were counted by hand from
GIS datasets): a street layer and a point layer of real lamps (OpenStreetMap
``highway=street_lamp`` nodes, a municipal inventory) become per-street lighting evidence,
and the tables of a base network are fitted to it with the base as prior
(:func:`bayesnets.fit_network`). This module reads the layers, runs the three steps and
writes the network folder and the report; each step is modelled in its own module:

1. **Assignment** (:mod:`nightlights.streets._learn_assign`). Each lamp goes to one street
   within ``max_distance``, junction-aware (a lamp near a junction goes to the street it
   stands along, not to a side street ending there). Streets tagged ``lit=no`` take no
   lamps.
2. **Evidence per street** (:mod:`nightlights.streets._learn_evidence`). From the lamps'
   along-street positions and sides: ``arrangement``, ``spacing``, ``occupancy`` and
   ``mounting_height`` where the lamps suffice, each with its agreement (how far the
   street's own lamps support the value). ``lit`` is true on a street with a lamp and no
   ``lit`` tag; a street without a mapped lamp is *not* evidence of an unlit street (only
   ``lit=no`` is).
3. **Fit** (:mod:`nightlights.streets._learn_fit`). The unobserved fields are imputed from
   the network given each street's evidence and every table is fitted from the streets where
   its own variable is observed, in rounds (stochastic EM).

Lamps are the layer's points (for OpenStreetMap layers, ``highway=street_lamp`` only), their
tagged heights read from :data:`HEIGHT_FIELDS` or GDAL's ``other_tags``. The report gives,
per derived field, the number of streets with evidence and the share of them whose
agreement is at least :data:`AGREEMENT_THRESHOLD`.

Length: just over 600 lines, because the stage checks both layers (geometry types, CRS,
memory) before any work and writes the network folder and the report together.
"""

from __future__ import annotations

import datetime
import os
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely

from bayesnets import BayesNet, write_network
from bayesnets.errors import BayesNetError
from bayesnets.network import CONFIG_NAME
from nightlights._typing import PathLike
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError, OutputError
from nightlights.io import as_vector, write_gpkg
from nightlights.io.jsonfile import dumps_json
from nightlights.io.outputs import refuse_replacing_inputs
from nightlights.io.vector import FieldType
from nightlights.streets._checks import check_lines, finite_vertices, rng_from_seed
from nightlights.streets._fit import network_folder
from nightlights.streets._learn_assign import (
    CENTRE_TOLERANCE,
    DEFAULT_MAX_DISTANCE,
    LampAssignment,
    assign_lamps,
)
from nightlights.streets._learn_evidence import (
    DERIVED_FIELDS,
    street_lamp_evidence,
)

# the rules' constants, read here by the tests and the benchmarks
from nightlights.streets._learn_evidence import MIN_GAP as MIN_GAP
from nightlights.streets._learn_evidence import PAIRING_FRACTION as PAIRING_FRACTION
from nightlights.streets._learn_fit import (
    DEFAULT_ITERATIONS,
    check_learn_memory,
    learn_lighting_network,
    spacing_ratio_states,
    with_occupancy,
)
from nightlights.streets._mapping import parse_length, parse_packed_tags
from nightlights.streets._sample import network_by_location, resolve_network
from nightlights.streets.schema import (
    ARRANGEMENTS,
    STREET_CLASSES,
    VALUE_RANGES,
    observed_field,
)

__all__ = [
    "AGREEMENT_THRESHOLD",
    "CENTRE_TOLERANCE",
    "DEFAULT_MAX_DISTANCE",
    "LampAssignment",
    "LearnReport",
    "LearnResult",
    "assign_lamps",
    "learn",
    "learn_lighting_network",
    "spacing_ratio_states",
    "street_lamp_evidence",
    "with_occupancy",
]

#: A street's evidence agrees when at least this share of its lamps (gaps) agree [1].
AGREEMENT_THRESHOLD = 0.75
#: Fields of a lamp layer holding the mounting height, in order of preference (OSM
#: ``height`` on a ``highway=street_lamp`` node, in a column or GDAL's ``other_tags``).
HEIGHT_FIELDS = ("mounting_height", "height")

#: Files of the network folder besides the tables: the per-street evidence (layer
#: ``streets``) and the lamps with their streets (layer ``lamps``).
EVIDENCE_FILE = "evidence_streets.gpkg"
LAMPS_FILE = "evidence_lamps.gpkg"
REPORT_FILE = "learn_report.json"

#: Fields of the per-street evidence layer and their types.
EVIDENCE_SCHEMA: dict[str, FieldType] = {
    "source_id": "str",
    "street_class": "str",
    "lamps": "int",
    "lamps_left": "int",
    "lamps_right": "int",
    "lamps_centre": "int",
    "same_side_gaps": "int",
    "median_gap": "float",
    "arrangement": "str",
    "spacing": "float",
    "unusual_spacing": "float",
    "positions": "int",
    "occupancy": "float",
    "mounting_height": "float",
    "lit": "bool",
    "arrangement_agreement": "float",
    "spacing_agreement": "float",
    "occupancy_agreement": "float",
    "mounting_height_agreement": "float",
    **{observed_field(name): "bool" for name in DERIVED_FIELDS},
}

#: Fields of the assigned-lamp layer and their types.
LAMP_SCHEMA: dict[str, FieldType] = {
    "street_id": "str",
    "distance": "float",
    "along": "float",
    "offset": "float",
    "side": "str",
    "interior": "bool",
    "height": "float",
}


@dataclass
class FieldEvidence:
    """Evidence of one derived field.

    Attributes
    ----------
    streets
        Streets with a derived value [1].
    agreeing
        Of those, streets whose own lamps agree with the value (agreement at least
        :data:`AGREEMENT_THRESHOLD`) [1].
    summary
        Value counts (arrangement) or the 10th, 50th and 90th percentiles [field unit].
    """

    streets: int = 0
    agreeing: int = 0
    summary: dict[str, float] = field(default_factory=dict)

    @property
    def agreement(self) -> float:
        """Share of evidence streets whose lamps agree [1]; NaN without evidence."""
        return self.agreeing / self.streets if self.streets else float("nan")


@dataclass
class LearnReport:
    """What the lamps gave.

    Attributes
    ----------
    lamps
        Lamps in the layer [1].
    assigned
        Lamps assigned to a street within the distance [1].
    interior
        Assigned lamps that project onto their street's interior [1].
    streets
        Streets in the layer [1].
    streets_with_lamps
        Streets with at least one assigned lamp (their ``lit`` is known) [1].
    lit_from_lamps
        Streets whose ``lit`` came from their lamps (no ``lit`` value in the layer) [1].
    unlit_tagged
        Streets tagged ``lit=no``, which take no lamps [1].
    fields
        Derived field -> :class:`FieldEvidence`.
    max_distance
        Reach of a lamp [m].
    """

    lamps: int = 0
    assigned: int = 0
    interior: int = 0
    streets: int = 0
    streets_with_lamps: int = 0
    lit_from_lamps: int = 0
    unlit_tagged: int = 0
    fields: dict[str, FieldEvidence] = field(default_factory=dict)
    max_distance: float = DEFAULT_MAX_DISTANCE

    def as_dict(self) -> dict[str, Any]:
        """The report as JSON-ready values."""
        out: dict[str, Any] = {
            key: getattr(self, key)
            for key in (
                "lamps",
                "assigned",
                "interior",
                "streets",
                "streets_with_lamps",
                "lit_from_lamps",
                "unlit_tagged",
                "max_distance",
            )
        }
        out["fields"] = {
            name: {
                "streets": value.streets,
                "agreeing": value.agreeing,
                "agreement": None if value.streets == 0 else round(value.agreement, 4),
                "summary": value.summary,
            }
            for name, value in self.fields.items()
        }
        return out


@dataclass(frozen=True, eq=False)
class LearnResult:
    """What :func:`learn` returns.

    Attributes
    ----------
    network
        The learned network; ``streets sample`` takes it (or its folder) as ``network``.
    report
        Counts and agreement of the evidence (:class:`LearnReport`).
    evidence
        The streets with their lamp counts and derived fields (see
        :func:`street_lamp_evidence`).
    lamps
        The lamps with the street they were assigned to (``street_id``, empty when out of
        reach), ``distance``, ``along``, ``offset`` [m], ``side`` and ``interior``.
    path
        The network folder written, or None.
    """

    network: BayesNet
    report: LearnReport
    evidence: gpd.GeoDataFrame
    lamps: gpd.GeoDataFrame
    path: Path | None


def learn(
    streets: gpd.GeoDataFrame | PathLike,
    lamps: gpd.GeoDataFrame | PathLike,
    out_dir: PathLike | None = None,
    *,
    network: str | os.PathLike[str] | BayesNet | None = None,
    max_distance: float = DEFAULT_MAX_DISTANCE,
    prior: float = 1.0,
    iterations: int = DEFAULT_ITERATIONS,
    seed: int | None = None,
    lamps_layer: str | None = None,
    name: str | None = None,
    overwrite: bool = False,
) -> LearnResult:
    """Learn a street-lighting network from mapped street lamps.

    Stage ``streets learn``: assign lamps to streets, derive per-street lighting fields
    where the evidence suffices, and fit the base network's tables to them with the base as
    prior (see the module notes for the rules).

    Parameters
    ----------
    streets
        Normalised streets (the result of :func:`~nightlights.streets._normalize`): lines in
        a projected CRS [m] with the canonical fields and their ``_observed`` flags. A
        GeoDataFrame or a vector file path.
    lamps
        Points of real lamps: a GeoDataFrame or any vector file (an OSM file's ``points``
        layer by default). Where the layer has a ``highway`` field (OpenStreetMap), only
        ``highway=street_lamp`` points are lamps. Heights come from a ``mounting_height``
        or ``height`` field, or ``height`` in OSM's ``other_tags``.
    out_dir
        Network folder to write (tables, ``network.toml``, ``learn_report.json``,
        ``evidence_streets.gpkg`` and ``evidence_lamps.gpkg``); must not exist or be
        empty unless ``overwrite``. Written to a temporary folder first and renamed.
        None writes nothing.
    network
        Base network (object, catalogue name or folder); default: the catalogue network for
        where the streets lie (as ``streets sample`` chooses it).
    max_distance
        Largest lamp-to-street distance [m].
    prior
        Prior strength in pseudo-observations per parent combination [1].
    iterations
        Rounds of imputation and fitting (see :func:`learn_lighting_network`) [1].
    seed
        Random seed of the imputation; the same seed gives the same network.
    lamps_layer
        Layer of the lamp file (default: ``points`` for OSM files, else the first).
    name
        Name of the learned network (default: the folder's name, else ``<base>_learned``).
    overwrite
        Replace an existing network folder (one holding ``network.toml``).

    Returns
    -------
    LearnResult
        The network, the report, the evidence layers and the written folder (or None).

    Raises
    ------
    InputError
        ``max_distance`` not positive and finite; layers without a projected CRS (the
        lamps are reprojected to the streets' CRS); streets that are not lines; a negative
        seed.
    EmptyInputError
        No streets, no lamps, or no street with enough lamps to derive a field.
    OutputError
        ``out_dir`` exists and is not an empty folder (or, with ``overwrite``, not a network
        folder); its parent folder is missing; it is an input (the base ``network`` folder) or
        holds one (whatever ``overwrite``).
    bayesnets.errors.BayesNetError
        A value the base network cannot map.

    Examples
    --------
    >>> import geopandas as gpd
    >>> from shapely import LineString, Point
    >>> from nightlights.streets import learn
    >>> streets = gpd.GeoDataFrame(
    ...     {"source_id": ["a"], "street_class": ["local"], "street_class_observed": [True]},
    ...     geometry=[LineString([(0, 0), (200, 0)])], crs="EPSG:3067")
    >>> lamps = gpd.GeoDataFrame(
    ...     geometry=[Point(x, -6) for x in range(10, 200, 20)], crs="EPSG:3067")
    >>> result = learn(streets, lamps, network="europe", seed=0)
    >>> row = result.evidence.iloc[0]
    >>> row["arrangement"], float(row["spacing"])
    ('single_sided', 20.0)
    >>> result.report.fields["spacing"].streets
    1
    """
    if not (isinstance(max_distance, int | float) and np.isfinite(max_distance)) or (
        max_distance <= 0
    ):
        raise InputError(f"max_distance={max_distance!r}; expected a distance > 0 [m]")
    if not np.isfinite(prior) or prior < 0:
        raise InputError(f"prior={prior!r}; expected a non-negative pseudo-count")
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise InputError(f"iterations={iterations!r}; expected an integer >= 1")
    rng = rng_from_seed(seed)
    target = Path(out_dir) if out_dir is not None else None
    if target is not None:
        # the folder is replaced whole: it must be no input and hold none
        refuse_replacing_inputs([target], {"streets": streets, "lamps": lamps, "network": network})
        _check_target(target, overwrite)
    frame, source = as_vector(streets, name="streets")
    if frame.empty:
        raise EmptyInputError(f"{source}: the layer has no streets")
    if frame.crs is None or not frame.crs.is_projected:
        raise InputError(
            f"{source}: streets must be in a projected CRS [m] (run `nightlights streets "
            "normalize` first)"
        )
    check_lines(frame, source)
    points, lamp_source = _read_lamps(lamps, lamps_layer, frame.crs)
    frame = frame.reset_index(drop=True)
    if network is None:
        # the base network for where the streets lie, as streets sample chooses it
        network, _ = network_by_location(frame, source=str(source))
    base = resolve_network(network)
    check_learn_memory(points.geometry.to_numpy(), frame, base, float(max_distance))
    rank = _street_rank(frame)
    lit = frame["lit"].astype("boolean") if "lit" in frame else pd.Series(pd.NA, index=frame.index)
    unlit = (lit == False).fillna(False).to_numpy(bool)  # noqa: E712 (nullable boolean)
    assignment = assign_lamps(
        points.geometry.to_numpy(),
        frame.geometry.to_numpy(),
        max_distance=float(max_distance),
        street_rank=rank,
        allowed=~unlit,
    )
    evidence = street_lamp_evidence(
        assignment,
        len(frame),
        heights=_lamp_heights(points),
        lengths=shapely.length(frame.geometry.to_numpy()),
    )
    if (
        not evidence["arrangement_observed"].any()
        and not evidence["mounting_height_observed"].any()
    ):
        raise EmptyInputError(
            f"{lamp_source}: no street has two lamps on one side within {max_distance:g} m "
            f"of {source}; nothing to learn from"
        )
    if target is not None and name is None:
        name = target.name
    report = _report(frame, evidence, assignment, unlit, float(max_distance))
    try:
        learned = learn_lighting_network(
            frame, evidence, base, prior=prior, iterations=iterations, rng=rng, name=name
        )
    except BayesNetError as exc:
        raise type(exc)(f"{source}: {exc}") from exc
    learned = replace(
        learned,
        metadata={
            "learned_from_streets": _file_label(source),
            "learned_from_lamps": _file_label(lamp_source),
            "base_network": base.name,
            "base_region": str(base.metadata.get("region", "")),
            "lamps_assigned": report.assigned,
            "streets_with_spacing": report.fields["spacing"].streets,
            "max_distance_m": float(max_distance),
            "prior": float(prior),
            "iterations": iterations,
            "seed": -1 if seed is None else int(seed),
            "learned_on": datetime.date.today().isoformat(),
        },
    )
    evidence_layer = _evidence_layer(frame, evidence)
    lamp_layer = _lamp_layer(points, frame, assignment)
    if target is not None:
        with network_folder(target) as tmp:
            assert tmp is not None  # a folder for a target
            write_network(learned, tmp)
            (tmp / REPORT_FILE).write_text(
                dumps_json(report.as_dict(), indent=2) + "\n", encoding="utf-8"
            )
            write_gpkg(evidence_layer, tmp / EVIDENCE_FILE, layer="streets", schema=EVIDENCE_SCHEMA)
            write_gpkg(lamp_layer, tmp / LAMPS_FILE, layer="lamps", schema=LAMP_SCHEMA)
    return LearnResult(learned, report, evidence_layer, lamp_layer, target)


def _file_label(source: str) -> str:
    """A file's name (no folders: the metadata travels with the network), or the label of an
    in-memory layer."""
    return source if source.startswith("in-memory") else Path(source).name


def _check_target(target: Path, overwrite: bool) -> None:
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"{target}: parent folder {parent} does not exist")
    if not target.exists() or (target.is_dir() and not any(target.iterdir())):
        return
    if not target.is_dir():
        raise OutputError(f"{target}: exists and is not a folder")
    if not overwrite:
        raise OutputError(f"{target}: exists and is not an empty folder; give overwrite=True")
    if not (target / CONFIG_NAME).exists():
        raise OutputError(
            f"{target}: not a network folder (no {CONFIG_NAME}); overwrite=True replaces only those"
        )


def _read_lamps(
    lamps: gpd.GeoDataFrame | PathLike, layer: str | None, crs: Any
) -> tuple[gpd.GeoDataFrame, str]:
    """The lamp points in the streets' CRS (OSM: ``highway=street_lamp`` only)."""
    if layer is None and not isinstance(lamps, gpd.GeoDataFrame):
        lower = str(lamps).lower()
        if lower.endswith((".pbf", ".osm", ".osm.gz", ".osm.bz2")):
            layer = "points"
    points, source = as_vector(lamps, layer=layer, name="lamps")
    if points.crs is None:
        raise InputError(f"{source}: the lamp layer has no CRS")
    if "highway" in points:
        points = points.loc[points["highway"].astype(str) == "street_lamp"]
    points = points.loc[~(points.geometry.isna() | points.geometry.is_empty)]
    points = points.explode(index_parts=False)  # a multi-point is one lamp per point
    kept = (points.geometry.geom_type == "Point").to_numpy() & finite_vertices(
        points.geometry.to_numpy()
    )
    if (~kept).any():
        warnings.warn(
            f"{source}: {int((~kept).sum())} lamp feature(s) that are not points with finite "
            "coordinates dropped",
            DataQualityWarning,
            stacklevel=3,
        )
    points = points.loc[kept]
    if points.empty:
        raise EmptyInputError(f"{source}: no lamp points (highway=street_lamp for OSM layers)")
    return points.to_crs(crs).reset_index(drop=True), source


def _lamp_heights(points: gpd.GeoDataFrame) -> np.ndarray:
    """Tagged mounting height per lamp [m], NaN where untagged or implausible."""
    raw = pd.Series([None] * len(points), index=points.index, dtype=object)
    for name in HEIGHT_FIELDS:
        if name in points:
            raw = raw.where(raw.notna(), points[name].astype(object))
    if "other_tags" in points:
        packed = points["other_tags"].map(lambda text: parse_packed_tags(text).get("height"))
        raw = raw.where(raw.notna(), packed)
    heights = np.array([parse_length(v) for v in raw], dtype=float)
    limits = VALUE_RANGES["mounting_height"]
    heights[np.isfinite(heights) & limits.impossible(np.nan_to_num(heights))] = np.nan
    return heights


def _street_rank(frame: pd.DataFrame) -> np.ndarray:
    ranks = {name: rank for rank, name in enumerate(STREET_CLASSES)}
    if "street_class" not in frame:
        return np.zeros(len(frame))
    return frame["street_class"].map(ranks).fillna(len(ranks)).to_numpy(float)


def _report(
    frame: pd.DataFrame,
    evidence: pd.DataFrame,
    assignment: LampAssignment,
    unlit: np.ndarray,
    max_distance: float,
) -> LearnReport:
    has_lamp = evidence["lamps"].to_numpy() > 0
    tagged = frame["lit"].notna().to_numpy() if "lit" in frame else np.zeros(len(frame), dtype=bool)
    report = LearnReport(
        lamps=len(assignment.street),
        assigned=int(assignment.assigned.sum()),
        interior=int((assignment.assigned & assignment.interior).sum()),
        streets=len(frame),
        streets_with_lamps=int(has_lamp.sum()),
        lit_from_lamps=int((has_lamp & ~tagged).sum()),
        unlit_tagged=int(unlit.sum()),
        max_distance=max_distance,
    )
    for name in DERIVED_FIELDS:
        if name not in evidence:
            continue
        seen = evidence[observed_field(name)].to_numpy(bool)
        agreement = evidence[f"{name}_agreement"].to_numpy(float)[seen]
        values = evidence.loc[seen, name]
        if name == "arrangement":
            summary = {a: float((values == a).sum()) for a in ARRANGEMENTS}
        elif seen.any():
            p10, p50, p90 = np.percentile(values.to_numpy(float), [10, 50, 90])
            summary = {
                "p10": round(float(p10), 2),
                "median": round(float(p50), 2),
                "p90": round(float(p90), 2),
            }
        else:
            summary = {}
        report.fields[name] = FieldEvidence(
            streets=int(seen.sum()),
            agreeing=int((agreement >= AGREEMENT_THRESHOLD).sum()),
            summary=summary,
        )
    return report


def _evidence_layer(frame: gpd.GeoDataFrame, evidence: pd.DataFrame) -> gpd.GeoDataFrame:
    out = evidence.copy()
    out.insert(
        0,
        "source_id",
        frame["source_id"].astype(str).to_numpy()
        if "source_id" in frame
        else frame.index.astype(str),
    )
    out.insert(
        1, "street_class", frame["street_class"].to_numpy() if "street_class" in frame else None
    )
    tagged = frame["lit"].astype("boolean") if "lit" in frame else pd.Series(pd.NA, index=out.index)
    out["lit"] = tagged.where(tagged.notna() | (out["lamps"] == 0), True).to_numpy()
    return gpd.GeoDataFrame(out, geometry=frame.geometry.to_numpy(), crs=frame.crs)


def _lamp_layer(
    points: gpd.GeoDataFrame, frame: gpd.GeoDataFrame, assignment: LampAssignment
) -> gpd.GeoDataFrame:
    ids = (
        frame["source_id"].astype(str).to_numpy()
        if "source_id" in frame
        else (frame.index.astype(str).to_numpy())
    )
    street_id = np.where(assignment.assigned, ids[np.maximum(assignment.street, 0)], None)
    side = np.array(["right", "centre", "left"], dtype=object)[assignment.side + 1]
    layer = pd.DataFrame(
        {
            "street_id": street_id,
            "distance": assignment.distance,
            "along": assignment.along,
            "offset": assignment.offset,
            "side": np.where(assignment.assigned, side, None),
            "interior": assignment.interior,
            "height": _lamp_heights(points),
        }
    )
    return gpd.GeoDataFrame(layer, geometry=points.geometry.to_numpy(), crs=frame.crs)
