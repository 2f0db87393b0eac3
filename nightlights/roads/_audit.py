"""Audit a street layer's lighting against its lighting classes: the ``streets audit`` stage.

Each segment of the street layer gets a lighting class (a ``lighting_class`` field, else the
class selection table), sections and calculation points along it
(:mod:`nightlights.roads._layout`), the light of every luminaire at every point
(:mod:`nightlights.roads._influence`), its quality figures, requirements, margins and pass or
fail (:mod:`nightlights.roads._rating`). The output is the street layer with those fields,
styled by status, and a summary: the share of the rated street length that keeps its class,
overall and per class.

Modelling choices beyond those of the modules named above:

- a segment without a usable ``spacing`` takes the median gap between the lights placed on it
  (``street_id`` of the light layer against ``source_id`` of the street layer); a segment
  with neither is not rated;
- ``lanes`` defaults to the carriageway width over :data:`DEFAULT_LANE_WIDTH`, at least 1;
- a segment shorter than its spacing is rated as one section of its own length, with a
  warning (the standard's field assumes a whole spacing);
- without an r-table the luminance classes use :func:`~nightlights.roads.synthetic_rtable`,
  an analytic stand-in, with a warning: the CIE surfaces are not bundled.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from nightlights.errors import DataQualityWarning, EmptyInputError, InputError
from nightlights.ground.luminaires import Luminaires, load_database, resolve_luminaires
from nightlights.io import as_vector, ensure_projected, write_gpkg
from nightlights.io.jsonfile import dumps_json
from nightlights.io.outputs import OutputSet
from nightlights.io.styles import compliance_style
from nightlights.io.vector import FieldType
from nightlights.roads._audit_energy import ENERGY_FIELDS, EnergyOptions, segment_energy
from nightlights.roads._classes import CRITERIA, read_requirements
from nightlights.roads._influence import RoadInfluence, road_influence
from nightlights.roads._layout import StreetFields, lay_out
from nightlights.roads._metrics import REFERENCE_AGE
from nightlights.roads._rating import FIGURES, rate_segments, section_figures
from nightlights.roads._rtables import RTable, read_rtable, synthetic_rtable
from nightlights.roads._selection import ClassSelection, select_classes

__all__ = ["AuditResult", "AuditSummary", "EnergyOptions", "RoadModel", "audit", "road_model"]

#: Lane width assumed where the layer gives no lane count [m] (a common urban lane).
DEFAULT_LANE_WIDTH = 3.5
#: Statuses of the ``status`` field.
STATUSES = ("pass", "fail", "not rated")


@dataclass(frozen=True)
class RoadModel:
    """A street layer ready to rate: segments, classes, sections, luminaires and matrices.

    Attributes
    ----------
    segments
        The (exploded) street layer in a projected CRS, one row per line.
    classes
        Lighting class per segment (None where not rated).
    reason
        Why a segment is not rated (empty where rated).
    requirements
        Requirements by class.
    luminaires
        The lights, in the order of the influence matrices' columns.
    influence
        The per-luminaire contributions at every calculation point.
    rtable
        The r-table used.
    """

    segments: gpd.GeoDataFrame
    classes: pd.Series
    reason: np.ndarray
    requirements: Mapping[str, Mapping[str, float]]
    luminaires: Luminaires
    influence: RoadInfluence
    rtable: RTable

    @property
    def fields(self) -> StreetFields:
        """The sections and calculation points."""
        return self.influence.fields

    def rate(self, dimming: ArrayLike | None = None) -> pd.DataFrame:
        """Figures, requirements, margins and pass/fail per segment at a dimming.

        Parameters
        ----------
        dimming
            Level of every luminaire (n_lights,) in [0, 1]; default all 1.
        """
        figures = section_figures(self.influence, dimming)
        return rate_segments(
            figures, self.fields.segment, len(self.segments), self.classes, self.requirements
        )


@dataclass(frozen=True)
class AuditSummary:
    """How much of a street layer keeps its lighting class.

    Attributes
    ----------
    segments, rated, passed
        Segments in the layer, rated, keeping their class.
    length, rated_length, passed_length
        Street length in the layer, rated, keeping its class [m].
    by_class
        Per class: ``segments``, ``length`` [m], ``passed_length`` [m], ``share`` [1].
    rtable
        Name of the r-table used.
    energy
        Energy totals (:func:`~nightlights.roads._audit_energy.segment_energy`), or None.
    """

    segments: int
    rated: int
    passed: int
    length: float
    rated_length: float
    passed_length: float
    by_class: dict[str, dict[str, float | None]] = field(default_factory=dict)
    rtable: str = ""
    energy: dict[str, Any] | None = None

    @property
    def share(self) -> float:
        """Share of the rated length that keeps its class [1] (NaN when nothing is rated)."""
        return self.passed_length / self.rated_length if self.rated_length > 0 else float("nan")

    def to_dict(self) -> dict[str, Any]:
        """The summary as JSON-ready numbers."""
        return {
            "segments": self.segments,
            "rated": self.rated,
            "passed": self.passed,
            "length_m": round(self.length, 3),
            "rated_length_m": round(self.rated_length, 3),
            "passed_length_m": round(self.passed_length, 3),
            "share_compliant": None if np.isnan(self.share) else round(self.share, 6),
            "by_class": self.by_class,
            "rtable": self.rtable,
            **({} if self.energy is None else {"energy": self.energy}),
        }


@dataclass(frozen=True)
class AuditResult:
    """Result of :func:`audit`.

    Attributes
    ----------
    segments
        The street layer with the class, figures, requirements, margins, ``status``,
        ``binding`` and ``binding_margin`` of every segment.
    summary
        Share of the street length that keeps its class, overall and per class.
    model
        The rated model (reuse it to rate a dimming with :meth:`RoadModel.rate`).
    path
        The written GeoPackage, or None.
    """

    segments: gpd.GeoDataFrame
    summary: AuditSummary
    model: RoadModel
    path: Path | None


def _as_rtable(rtable: RTable | str | os.PathLike[str] | None) -> RTable | None:
    if rtable is None or isinstance(rtable, RTable):
        return rtable
    if isinstance(rtable, str | os.PathLike):
        return read_rtable(rtable)
    raise InputError(f"rtable={rtable!r}; expected an RTable, a path to an r-table or None")


def _classes(
    frame: gpd.GeoDataFrame,
    table: Mapping[str, Any],
    selection: ClassSelection | str | os.PathLike[str] | None,
    source: str,
) -> pd.Series:
    """Lighting class per segment: the selection rules over the street fields, a
    ``lighting_class`` field overriding them; without ``street_class``, the field alone."""
    if "street_class" in frame:
        return select_classes(frame, selection, requirements=table)
    if "lighting_class" not in frame:
        return pd.Series([None] * len(frame), index=frame.index, dtype=object)
    given = frame["lighting_class"].astype(object)
    cleaned = pd.Series(
        [None if pd.isna(c) or str(c).strip() == "" else str(c).strip().upper() for c in given],
        index=frame.index,
        dtype=object,
    )
    unknown = cleaned.notna() & ~cleaned.isin(list(table))
    if unknown.any():
        ids = _ids(frame)[unknown.to_numpy()]
        raise InputError(
            f"{source}: streets {ids[:10].tolist()} have unknown lighting_class "
            f"{sorted(set(cleaned[unknown]))}; expected one of {', '.join(sorted(table))}"
        )
    return cleaned


def _warn_uncomputed(
    classes: pd.Series, table: Mapping[str, Mapping[str, float]], source: str
) -> None:
    """Warn about criteria the classes in use set but the audit does not compute."""
    used = {str(c) for c in classes.dropna()}
    skipped = sorted({name for c in used for name in table.get(c, {}) if name not in FIGURES})
    if skipped:
        warnings.warn(
            f"{source}: the audit does not compute {skipped}; those requirements are not rated",
            DataQualityWarning,
            stacklevel=3,
        )


def _ids(frame: pd.DataFrame) -> np.ndarray:
    if "source_id" in frame:
        return frame["source_id"].astype(str).to_numpy()
    return np.asarray(frame.index.astype(str))


def _numbers(frame: pd.DataFrame, name: str) -> np.ndarray:
    if name not in frame:
        return np.full(len(frame), np.nan)
    return pd.to_numeric(frame[name], errors="coerce").to_numpy(float)


def _spacing_from_lights(segments: gpd.GeoDataFrame, lights: gpd.GeoDataFrame) -> np.ndarray:
    """Median gap between the lights of each segment along it [m] (NaN where unknown)."""
    out = np.full(len(segments), np.nan)
    if "street_id" not in lights or "source_id" not in segments:
        return out
    by_street = lights.groupby(lights["street_id"].astype(str)).groups
    for row, (sid, line) in enumerate(
        zip(segments["source_id"].astype(str), segments.geometry, strict=True)
    ):
        members = by_street.get(sid)
        if members is None or len(members) < 2:
            continue
        along = np.unique(np.round(line.project(lights.geometry.loc[members]).to_numpy(), 3))
        gaps = np.diff(along)
        gaps = gaps[gaps > 0.5]
        if gaps.size:
            out[row] = float(np.median(gaps))
    return out


def road_model(
    lights: gpd.GeoDataFrame | str | os.PathLike[str],
    streets: gpd.GeoDataFrame | str | os.PathLike[str],
    *,
    catalog: str | os.PathLike[str] | None = None,
    rtable: RTable | str | os.PathLike[str] | None = None,
    requirements: str | os.PathLike[str] | Mapping[str, Mapping[str, float]] | None = None,
    selection: ClassSelection | str | os.PathLike[str] | None = None,
    age: float = REFERENCE_AGE,
    reach_heights: float | None = None,
) -> RoadModel:
    """Build the rated model of a street layer and its lights (module docstring).

    Parameters are those of :func:`audit`.
    """
    frame, source = as_vector(streets, name="streets")
    if frame.empty:
        raise EmptyInputError(f"{source}: the layer has no streets")
    light_frame, light_source = as_vector(lights, name="lights")
    if light_frame.empty:
        raise EmptyInputError(f"{light_source}: the layer has no lights")
    if frame.crs is None or not frame.crs.is_projected:
        frame = ensure_projected(frame, source=source)
    if light_frame.crs is None:
        raise InputError(f"{light_source}: the light layer has no CRS")
    if light_frame.crs != frame.crs:
        light_frame = light_frame.to_crs(frame.crs)
    table = (
        dict(requirements) if isinstance(requirements, Mapping) else read_requirements(requirements)
    )
    frame = frame.reset_index(drop=True)
    if "width" not in frame:
        raise InputError(f"{source}: the street layer has no field 'width' (carriageway [m])")
    segments = frame.explode(index_parts=False).reset_index(drop=True)
    segments = segments[segments.geometry.geom_type == "LineString"].reset_index(drop=True)
    classes = _classes(segments, table, selection, source)
    _warn_uncomputed(classes, table, source)

    width = _numbers(segments, "width")
    lanes = _numbers(segments, "lanes")
    lanes = np.where(
        np.isfinite(lanes) & (lanes >= 1),
        np.round(lanes),
        np.maximum(1, np.round(np.nan_to_num(width) / DEFAULT_LANE_WIDTH)),
    ).astype(np.intp)
    spacing = _numbers(segments, "spacing")
    missing = ~(spacing > 0)
    if missing.any():
        spacing = np.where(missing, _spacing_from_lights(segments, light_frame), spacing)
    reason = np.full(len(segments), "", dtype=object)
    reason[classes.isna().to_numpy()] = "no lighting class"
    reason[(reason == "") & ~(width > 0)] = "no carriageway width"
    reason[(reason == "") & ~(spacing > 0)] = "no spacing"
    family = np.full(len(segments), "", dtype="<U11")
    for row in np.flatnonzero(reason == ""):
        needs = table[classes.iloc[row]]
        family[row] = "luminance" if "average_luminance" in needs else "illuminance"
    short = (reason == "") & (segments.length.to_numpy() < spacing)
    if short.any():
        warnings.warn(
            f"{source}: {int(short.sum())} segments are shorter than their spacing "
            f"({_ids(segments)[short][:5].tolist()}); each is rated as one section of its "
            "own length",
            DataQualityWarning,
            stacklevel=2,
        )
    r_table = _as_rtable(rtable)
    if r_table is None:
        r_table = synthetic_rtable()
        if (family == "luminance").any():
            warnings.warn(
                "rtable: no r-table given; road luminance uses the analytic stand-in "
                "synthetic_rtable(), not a CIE surface (pass your copy of R1-R4 or C1-C2)",
                DataQualityWarning,
                stacklevel=2,
            )
    fields = lay_out(
        np.asarray(segments.geometry.to_numpy()), np.nan_to_num(spacing), width, lanes, family
    )
    luminaires = resolve_luminaires(
        light_frame, load_database(catalog), source=light_source, skip_unknown=False
    )
    influence = road_influence(fields, luminaires, r_table, age=age, reach_heights=reach_heights)
    return RoadModel(segments, classes, reason, table, luminaires, influence, r_table)


def _dimming(model: RoadModel, dimming: str | ArrayLike | None, frame: pd.DataFrame) -> Any:
    if dimming is None:
        return None
    if isinstance(dimming, str):
        if dimming not in frame:
            raise InputError(f"dimming={dimming!r}: the light layer has no such field")
        values = pd.to_numeric(frame[dimming], errors="coerce").fillna(1.0).to_numpy(float)
    else:
        values = np.asarray(dimming, dtype=float)
    if values.shape != (len(model.luminaires),):
        raise InputError(
            f"dimming of shape {values.shape}; expected one level per light "
            f"({len(model.luminaires)})"
        )
    if not np.all((values >= 0) & (values <= 1)):
        raise InputError("dimming: levels outside 0-1; expected a fraction of full output")
    return values


def summarise(segments: pd.DataFrame, rtable: str) -> AuditSummary:
    """Counts and lengths by status, overall and per class."""
    length = segments.geometry.length.to_numpy()
    rated = segments["status"].to_numpy() != "not rated"
    passed = segments["status"].to_numpy() == "pass"
    by_class: dict[str, dict[str, float | None]] = {}
    classes = segments["lighting_class"].to_numpy(dtype=object)
    for name in sorted({str(c) for c in classes[rated]}):
        pick = rated & (classes == name)
        total = float(length[pick].sum())
        ok = float(length[pick & passed].sum())
        by_class[name] = {
            "segments": int(pick.sum()),
            "length_m": round(total, 3),
            "passed_length_m": round(ok, 3),
            "share": round(ok / total, 6) if total > 0 else None,
        }
    return AuditSummary(
        segments=len(segments),
        rated=int(rated.sum()),
        passed=int(passed.sum()),
        length=float(length.sum()),
        rated_length=float(length[rated].sum()),
        passed_length=float(length[passed].sum()),
        by_class=by_class,
        rtable=rtable,
    )


def output_schema() -> dict[str, FieldType]:
    """Field types of the audit layer's added fields."""
    schema: dict[str, FieldType] = {"lighting_class": "str", "status": "str", "reason": "str"}
    for name in FIGURES:
        schema[name] = "float"
        schema[f"{name}_required"] = "float"
        schema[f"{name}_margin"] = "float"
    schema.update({"binding": "str", "binding_margin": "float"})
    return schema


def _energy_schema() -> dict[str, FieldType]:
    return dict.fromkeys(ENERGY_FIELDS, "float")


def audit(
    lights: gpd.GeoDataFrame | str | os.PathLike[str],
    streets: gpd.GeoDataFrame | str | os.PathLike[str],
    output: str | os.PathLike[str] | None = None,
    *,
    catalog: str | os.PathLike[str] | None = None,
    rtable: RTable | str | os.PathLike[str] | None = None,
    requirements: str | os.PathLike[str] | Mapping[str, Mapping[str, float]] | None = None,
    selection: ClassSelection | str | os.PathLike[str] | None = None,
    dimming: str | ArrayLike | None = None,
    age: float = REFERENCE_AGE,
    energy: EnergyOptions | None = None,
    summary_json: str | os.PathLike[str] | None = None,
) -> AuditResult:
    """Rate every street segment's lighting against its lighting class (EN 13201-2/-3).

    Parameters
    ----------
    lights
        Light layer (points with ``system_id``, ``heading`` and the optional mounting fields of
        :func:`nightlights.ground.luminaires.resolve_luminaires`) or its path.
    streets
        Street layer (lines with ``width`` [m], optional ``lanes``, ``spacing`` [m],
        ``lighting_class``, ``source_id``) or its path.
    output
        GeoPackage to write (layer ``segments``), or None.
    catalog
        Luminaire database (default: the bundled catalogue).
    rtable
        The road surface's r-table (an :class:`~nightlights.roads.RTable` or a path); None:
        the analytic stand-in, with a warning.
    requirements
        Requirements by class or a TOML path (default: EN 13201-2:2015 Tables 1-3).
    selection
        Class selection rules or their TOML path (default: the shipped rules,
        :func:`~nightlights.roads.read_class_selection`); a ``lighting_class`` field
        overrides them per segment.
    dimming
        Level of every light in [0, 1]: a field of the light layer or an array; default 1.
    age
        Observer's age for the threshold increment [year].
    energy
        Compute each segment's power, annual energy, D_P, D_E and CO2 and their totals
        (:mod:`nightlights.roads._audit_energy`); None: no energy.
    summary_json
        JSON file to write the summary to (with the GeoPackage, all or nothing), or None.

    Returns
    -------
    AuditResult
        The rated segments, the summary, the model and the written path.

    Raises
    ------
    InputError
        Missing fields, unknown classes or systems, bad dimming levels.
    EmptyInputError
        No streets or no lights.
    """
    if energy is not None and not isinstance(energy, EnergyOptions):
        raise InputError(f"energy={energy!r}; expected EnergyOptions or None")
    inputs = {"lights": lights, "streets": streets}
    with OutputSet(output, summary_json, inputs=inputs) as outputs:
        model = road_model(
            lights,
            streets,
            catalog=catalog,
            rtable=rtable,
            requirements=requirements,
            selection=selection,
            age=age,
        )
        light_frame, light_source = as_vector(lights, name="lights")
        light_frame = light_frame.to_crs(model.segments.crs).reset_index(drop=True)
        levels = _dimming(model, dimming, light_frame)
        rating = model.rate(levels)
        segments = model.segments.copy()
        for name in rating.columns:
            segments[name] = rating[name].to_numpy()
        status = np.where(rating["passed"].fillna(False).to_numpy(bool), "pass", "fail")
        status = np.where(rating["passed"].isna().to_numpy(), "not rated", status)
        segments["status"] = status
        reason = model.reason.copy()
        reason[(reason == "") & (status == "not rated")] = "no requirement applies"
        segments["reason"] = reason
        segments = segments.drop(columns=["passed"])
        schema = output_schema()
        totals = None
        if energy is not None:
            fields, totals = segment_energy(
                segments,
                light_frame,
                load_database(catalog),
                energy,
                level=levels,
                source=light_source,
            )
            for name in fields.columns:
                segments[name] = fields[name].to_numpy()
            schema.update(_energy_schema())
        summary = replace(summarise(segments, model.rtable.name), energy=totals)
        path = None
        if output is not None:
            write_gpkg(
                segments,
                outputs.temporary(output),
                layer="segments",
                schema=schema,
                style=compliance_style(),
            )
            path = Path(output)
        if summary_json is not None:
            outputs.temporary(summary_json).write_text(
                dumps_json(summary.to_dict(), indent=2) + "\n", encoding="utf-8"
            )
    return AuditResult(segments, summary, model, path)


#: The quality figures a segment carries (criterion names), for the CLI and docs.
AUDIT_FIGURES = tuple(CRITERIA)
