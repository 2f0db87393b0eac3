"""Checks of a parsed project as a whole, made before any stage runs.

Each check raises one :class:`~nightlights.project._schema.ProjectError` line that names the
key (``stages.place``, ``observers.points.harbour``) and what would be allowed.
"""

from __future__ import annotations

import importlib.util
import math
import re
from pathlib import Path
from typing import Any

from pyproj import CRS, Geod, Transformer
from pyproj.exceptions import CRSError as ProjCRSError

from nightlights.errors import InputError
from nightlights.project._schema import (
    PER_OBSERVER,
    SKY_STAGES,
    STREET_STAGES,
    UPSTREAM,
    Observer,
    ProjectError,
    ProjectFile,
    builtin_mappings,
    network_names,
    reach,
)

#: Observer names become parts of file names.
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
_GEOD = Geod(ellps="WGS84")


def check_project(parsed: ProjectFile, label: str) -> tuple[Observer, ...]:
    """Check ``parsed`` as a whole; return its observers.

    Parameters
    ----------
    parsed
        The tables, paths absolute.
    label
        The project file, for messages.

    Returns
    -------
    tuple of Observer
        The observers (empty when no stage needs them).

    Raises
    ------
    ProjectError
        The first problem found, in one line.
    """
    try:
        _check_inputs(parsed)
        _check_stage_chain(parsed)
        _check_options(parsed)
        observers = _observers(parsed)
        _check_observer_names(parsed, observers)
        if observers:
            _check_reach(parsed, observers)
    except ProjectError as exc:
        raise ProjectError(f"{label}: {exc}") from None
    return observers


# --- inputs ----------------------------------------------------------------------------------


def _check_inputs(parsed: ProjectFile) -> None:
    inputs = parsed.inputs
    given = [name for name in ("streets", "emission", "viirs") if getattr(inputs, name)]
    if len(given) != 1:
        which = ", ".join(given) if given else "none"
        raise ProjectError(f"inputs: give exactly one of streets, emission, viirs (given: {which})")
    for name in ("streets", "emission", "viirs", "dem"):
        path = getattr(inputs, name)
        if path is not None and not path.is_file():
            raise ProjectError(f"inputs.{name}: {path} does not exist")
    if inputs.catalog is not None and not inputs.catalog.is_dir():
        raise ProjectError(f"inputs.catalog: {inputs.catalog} is not a folder")

    if inputs.mapping not in builtin_mappings() and not Path(inputs.mapping).is_file():
        raise ProjectError(
            f"inputs.mapping = {inputs.mapping!r}: neither a built-in mapping "
            f"({', '.join(builtin_mappings())}) nor a mapping file"
        )
    if (
        inputs.network is not None
        and inputs.network not in network_names()
        and not Path(inputs.network).is_dir()
    ):
        raise ProjectError(
            f"inputs.network = {inputs.network!r}: neither a catalogue network "
            f"({', '.join(network_names())}) nor a network folder"
        )
    observers = parsed.observers
    if observers is not None and observers.file is not None and not observers.file.is_file():
        raise ProjectError(f"observers.file: {observers.file} does not exist")


# --- which stages may run together -------------------------------------------------------------


def _check_stage_chain(parsed: ProjectFile) -> None:
    stages = parsed.stages
    chosen = stages.chosen()
    if not chosen:
        raise ProjectError("stages: no stage given; add a table per stage, e.g. [stages.normalize]")
    inputs = parsed.inputs
    source = "streets" if inputs.streets else "emission" if inputs.emission else "viirs"
    for stage in chosen:
        if stage in STREET_STAGES and source != "streets":
            raise ProjectError(
                f"stages.{stage}: reads the streets, but the project's input is inputs.{source}; "
                f"remove [stages.{stage}] or give inputs.streets"
            )
        if stage == "emission-viirs" and source != "viirs":
            raise ProjectError(
                f"stages.emission-viirs: reads inputs.viirs, but the project's input is "
                f"inputs.{source}; remove [stages.emission-viirs] or give inputs.viirs"
            )
        upstream = UPSTREAM.get(stage)
        if upstream is not None and upstream not in chosen:
            raise ProjectError(
                f"stages.{stage}: needs the output of stages.{upstream}; add [stages.{upstream}]"
            )
        if stage in SKY_STAGES:
            needed = {"streets": "emission", "viirs": "emission-viirs"}.get(source)
            if needed is not None and needed not in chosen:
                raise ProjectError(
                    f"stages.{stage}: needs the emission raster; add [stages.{needed}] "
                    "or give inputs.emission"
                )
    if source == "viirs" and "emission-viirs" not in chosen:
        raise ProjectError("stages: inputs.viirs needs [stages.emission-viirs]")
    reduce = stages.inverse_reduce
    if reduce is not None and reduce.by not in chosen:
        raise ProjectError(
            f"stages.inverse-reduce.by = {reduce.by!r}: that stage does not run; "
            f"add [stages.{reduce.by}] (allowed: "
            f"{', '.join(s for s in ('inverse-q', 'inverse-s') if s in chosen) or 'none'})"
        )
    if "observers" in chosen and importlib.util.find_spec("nightlights.sky.observers") is None:
        raise ProjectError(
            "stages.observers: this installation has no many-observers stage "
            "(nightlights.sky.observers); remove [stages.observers]"
        )


# --- option values that need more than their type --------------------------------------------


def _check_options(parsed: ProjectFile) -> None:
    stages = parsed.stages
    crs_keys: list[tuple[str, str | None, bool]] = [
        ("observers.crs", parsed.observers.crs if parsed.observers else None, False)
    ]
    if stages.normalize is not None:
        crs_keys += [
            ("stages.normalize.crs", stages.normalize.crs, False),
            ("stages.normalize.target-crs", stages.normalize.target_crs, True),
        ]
    if stages.emission_viirs is not None:
        crs_keys.append(
            ("stages.emission-viirs.target-crs", stages.emission_viirs.target_crs, True)
        )
    for key, text, projected in crs_keys:
        if text is None:
            continue
        crs = _crs(key, text)
        if projected and not crs.is_projected:
            raise ProjectError(f"{key} = {text!r}: expected a projected CRS in metres")
    if parsed.kernel is not None:
        for stage in ("skyglow", "inverse-q", "inverse-s", "darkness"):
            options = stages.options(stage)
            if options is None:
                continue
            for key in ("n_azimuth", "n_elevation", "n_distance"):
                if getattr(options, key) is not None:
                    name = key.replace("_", "-")
                    raise ProjectError(
                        f"stages.{stage}.{name}: the [kernel] table fixes the grid "
                        f"(kernel.{name}); remove one of the two"
                    )
    if parsed.kernel is not None and not parsed.kernel.uplight and stages.emission is not None:
        raise ProjectError(
            "kernel.uplight = false: stages.emission writes an uplight band that only a kernel "
            "with uplight tables reads; set kernel.uplight = true"
        )
    if parsed.kernel is not None and parsed.kernel.r_min >= parsed.kernel.r_max:
        raise ProjectError(
            f"kernel.r-min = {parsed.kernel.r_min:g}: must be below kernel.r-max "
            f"({parsed.kernel.r_max:g})"
        )
    irradiance = stages.irradiance
    if irradiance is not None:
        from ies.spectra import SENSORS

        for sensor in irradiance.sensor:
            if sensor not in SENSORS:
                raise ProjectError(
                    f"stages.irradiance.sensor = {sensor!r}: unknown; allowed: {', '.join(SENSORS)}"
                )
        _library_check(
            "stages.irradiance.threshold",
            lambda: _influence_threshold(irradiance.threshold, irradiance.max_radius),
        )
    emission = stages.emission
    if emission is not None and isinstance(emission.albedo, str):
        if not Path(emission.albedo).is_file():
            raise ProjectError(
                f"stages.emission.albedo = {emission.albedo!r}: expected a number in [0, 1] "
                "or an albedo raster that exists"
            )
    inverse_s = stages.inverse_s
    if inverse_s is not None:
        from nightlights.inverse import SkyRegion

        _library_check("stages.inverse-s.region", lambda: SkyRegion.parse(inverse_s.region))
    reduce = stages.inverse_reduce
    if reduce is not None:
        qa, qb = reduce.qa, reduce.qb
        if type(qa) is not type(qb):
            raise ProjectError(
                "stages.inverse-reduce.qa, qb: give both as values or both as percentiles "
                f"(given {qa!r}, {qb!r})"
            )
        percent = isinstance(qa, str)
        low = float(qa[:-1]) if isinstance(qa, str) else qa
        high = float(qb[:-1]) if isinstance(qb, str) else qb
        if not low < high or (percent and high > 100):
            raise ProjectError(
                f"stages.inverse-reduce.qa = {qa!r}, qb = {qb!r}: expected qa < qb"
                + (" <= 100%" if percent else "")
            )


def _influence_threshold(text: str, max_radius: float) -> Any:
    from nightlights.ground import InfluenceThreshold

    return InfluenceThreshold.parse(text, max_radius=max_radius)


def _library_check(key: str, check: Any) -> None:
    try:
        check()
    except (InputError, ValueError) as exc:
        raise ProjectError(f"{key}: {exc}") from None


def _crs(key: str, text: str) -> CRS:
    try:
        return CRS.from_user_input(text)
    except (ProjCRSError, TypeError, ValueError):
        raise ProjectError(
            f"{key} = {text!r}: not a coordinate reference system; expected e.g. EPSG:3067, "
            "a WKT or a PROJ string"
        ) from None


# --- observers -------------------------------------------------------------------------------


def _needs_observers(parsed: ProjectFile) -> bool:
    return any(s in parsed.stages.chosen() for s in (*PER_OBSERVER, "observers"))


def _observers(parsed: ProjectFile) -> tuple[Observer, ...]:
    table = parsed.observers
    if not _needs_observers(parsed):
        return ()
    if table is None or (table.points is None) == (table.file is None):
        raise ProjectError(
            "observers: the sky stages need observers; give observers.points "
            "({ name = [x, y], ... }) or observers.file (a point layer), not both"
        )
    if table.points is not None:
        if not table.points:
            raise ProjectError("observers.points: empty; give at least one name = [x, y]")
        for name, xy in table.points.items():
            if not all(math.isfinite(v) for v in xy):
                raise ProjectError(f"observers.points.{name} = {list(xy)}: expected finite x, y")
        return tuple(
            Observer(name, float(x), float(y), table.crs, table.height)
            for name, (x, y) in table.points.items()
        )
    assert table.file is not None
    return _observers_from_file(table.file, table.layer, table.name_field, table.crs, table.height)


def _observers_from_file(
    path: Path, layer: str | None, name_field: str, crs_text: str | None, height: float
) -> tuple[Observer, ...]:
    from nightlights.io import read_vector

    try:
        frame = read_vector(path, layer=layer)
    except InputError as exc:
        raise ProjectError(f"observers.file: {exc}") from None
    if frame.empty:
        raise ProjectError(f"observers.file: {path} has no features")
    if name_field not in frame.columns:
        fields = ", ".join(str(c) for c in frame.columns if c != "geometry")
        raise ProjectError(
            f"observers.name-field = {name_field!r}: {path} has no such field; fields: {fields}"
        )
    kinds = set(frame.geometry.geom_type)
    if kinds != {"Point"}:
        raise ProjectError(
            f"observers.file: {path} holds {', '.join(sorted(map(str, kinds)))}; expected points"
        )
    if frame.crs is not None and crs_text is not None:
        raise ProjectError(
            f"observers.crs: {path} has its own CRS ({frame.crs.to_string()}); remove observers.crs"
        )
    crs = frame.crs.to_wkt() if frame.crs is not None else crs_text
    names = [str(n) for n in frame[name_field]]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ProjectError(
            f"observers.file: {path}: field {name_field!r} repeats {', '.join(duplicates)}; "
            "names must be unique"
        )
    return tuple(
        Observer(name, float(p.x), float(p.y), crs, height)
        for name, p in zip(names, frame.geometry, strict=True)
    )


def _check_observer_names(parsed: ProjectFile, observers: tuple[Observer, ...]) -> None:
    names = [o.name for o in observers]
    for name in names:
        if not _NAME.match(name):
            raise ProjectError(
                f"observers: name {name!r}: expected letters, digits, '_', '-' or '.' "
                "(it becomes part of file names)"
            )
    allowed = ", ".join(names)
    stages = parsed.stages
    for stage in PER_OBSERVER:
        options = stages.options(stage)
        wanted = None if options is None else options.observer
        for name in [wanted] if isinstance(wanted, str) else wanted or []:
            if name not in names:
                raise ProjectError(
                    f"stages.{stage}.observer = {name!r}: no such observer; allowed: {allowed}"
                )
    skyglow = stages.skyglow
    if skyglow is not None and isinstance(skyglow.projection, dict):
        for name in skyglow.projection:
            if name not in names:
                raise ProjectError(
                    f"stages.skyglow.projection.{name}: no such observer; allowed: {allowed}"
                )
    reduce = stages.inverse_reduce
    if reduce is not None:
        by = stages.options(reduce.by)
        wanted = by.observer
        ran = names if wanted is None else [wanted] if isinstance(wanted, str) else wanted
        if reduce.observer is None and len(ran) > 1:
            raise ProjectError(
                f"stages.inverse-reduce.observer: missing; {reduce.by} runs for "
                f"{', '.join(ran)}: name the one whose raster dims the emission"
            )
        if reduce.observer is not None and reduce.observer not in ran:
            raise ProjectError(
                f"stages.inverse-reduce.observer = {reduce.observer!r}: {reduce.by} does not "
                f"run for it; allowed: {', '.join(ran)}"
            )


def _data_extent(parsed: ProjectFile) -> tuple[tuple[float, float, float, float], CRS, str]:
    """The data's bounds, CRS and key (``inputs.streets``...)."""
    inputs = parsed.inputs
    if inputs.streets is not None:
        import pyogrio

        from nightlights.io.vector import _OSM_SUFFIXES

        normalize = parsed.stages.normalize
        layer = normalize.layer if normalize is not None else None
        if layer is None and inputs.streets.name.lower().endswith(_OSM_SUFFIXES):
            layer = "lines"
        try:
            info = pyogrio.read_info(inputs.streets, layer=layer, force_total_bounds=True)
        except Exception as exc:  # pyogrio's and GDAL's errors: an unreadable layer
            raise ProjectError(f"inputs.streets: {inputs.streets}: cannot read: {exc}") from None
        crs_text = info.get("crs") or (normalize.crs if normalize is not None else None)
        if crs_text is None:
            raise ProjectError(
                f"inputs.streets: {inputs.streets} has no CRS; give stages.normalize.crs"
            )
        bounds = tuple(float(v) for v in info["total_bounds"])
        return bounds, CRS.from_user_input(crs_text), "inputs.streets"  # type: ignore[return-value]
    import rasterio
    from rasterio.errors import RasterioIOError

    key = "inputs.emission" if inputs.emission is not None else "inputs.viirs"
    path = inputs.emission if inputs.emission is not None else inputs.viirs
    try:
        with rasterio.open(path) as src:
            if src.crs is None:
                raise ProjectError(f"{key}: {path} has no CRS")
            return tuple(src.bounds), CRS.from_user_input(src.crs.to_wkt()), key
    except RasterioIOError as exc:
        raise ProjectError(f"{key}: {path}: cannot read: {exc}") from None


def _check_reach(parsed: ProjectFile, observers: tuple[Observer, ...]) -> None:
    """Refuse an observer farther from the data than the kernel reaches (geodesic)."""
    bounds, data_crs, key = _data_extent(parsed)
    if not all(math.isfinite(v) for v in bounds):
        raise ProjectError(f"{key}: the data has no extent (no features?)")
    lonlat = CRS.from_epsg(4326)
    west, south, east, north = Transformer.from_crs(
        data_crs, lonlat, always_xy=True
    ).transform_bounds(*bounds)
    limit = reach(parsed)
    whose = "the [kernel] table's r-max" if parsed.kernel is not None else "any kernel's range"
    for observer in observers:
        where = (
            f"observers.points.{observer.name}"
            if parsed.observers is not None and parsed.observers.points is not None
            else f"observers.file ({observer.name})"
        )
        source = _crs(f"{where} (observers.crs)", observer.crs) if observer.crs else data_crs
        if source.is_geographic and not (-360 <= observer.x <= 360 and -90 <= observer.y <= 90):
            raise ProjectError(
                f"{where} = [{observer.x:g}, {observer.y:g}]: not a longitude, latitude in "
                f"{source.name}; check observers.crs"
            )
        lon, lat = Transformer.from_crs(source, lonlat, always_xy=True).transform(
            observer.x, observer.y
        )
        if not (math.isfinite(lon) and math.isfinite(lat)):
            raise ProjectError(
                f"{where} = [{observer.x:g}, {observer.y:g}]: has no position on the Earth in "
                f"{source.name}; check observers.crs"
            )
        near_lon = min(max(lon, west), east)
        near_lat = min(max(lat, south), north)
        gap = _GEOD.inv(lon, lat, near_lon, near_lat)[2]
        if gap > limit:
            raise ProjectError(
                f"{where} = [{observer.x:g}, {observer.y:g}]: lies {gap / 1000:.4g} km from the "
                f"data ({key}), beyond {whose} ({limit / 1000:.4g} km); check the coordinates "
                "and observers.crs"
            )
