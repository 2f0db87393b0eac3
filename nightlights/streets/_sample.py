"""Fill missing street and lighting properties by sampling a Bayesian network.

Stage ``streets sample`` (Chuang 2011, Sec. 3.3): every canonical street field observed on
a segment (``<field>_observed`` true) is evidence; every missing street field and every
lighting field is drawn by likelihood-weighted sampling of a geo-typical network from
:mod:`bayesnets.catalog` (or a user's network folder). The pole spacing is derived from
the sampled spacing ratio: ``spacing = spacing_ratio * mounting_height`` [m]. Without a
network, :func:`sample` picks one from where the layer lies
(:func:`~nightlights.streets._location.network_for_location`).
"""

from __future__ import annotations

import logging
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd

from bayesnets import BayesNet, load_network, sample_frame
from bayesnets.errors import BayesNetError
from bayesnets.sampling import DEFAULT_CANDIDATES, OnConflict, sampling_memory
from nightlights._resources import check_memory
from nightlights._typing import PathLike
from nightlights.errors import DataQualityWarning, InputError
from nightlights.io import as_vector, write_gpkg
from nightlights.io.outputs import OutputSet
from nightlights.io.styles import streets_style
from nightlights.io.vector import FieldType
from nightlights.streets._checks import check_network_values, rng_from_seed
from nightlights.streets._location import (
    FALLBACK_NETWORK,
    REGION_BOXES,
    layer_location,
    network_for_location,
)
from nightlights.streets.schema import (
    ARRANGEMENTS,
    LIGHTING_FIELDS,
    STREET_FIELDS,
    VALUE_RANGES,
    observed_field,
)

__all__ = [
    "DEFAULT_CANDIDATES",
    "OUTPUT_SCHEMA",
    "SampleResult",
    "fill_lighting",
    "lighting_summary",
    "network_by_location",
    "network_for_streets",
    "resolve_network",
    "sample",
]

logger = logging.getLogger(__name__)

#: Fields the sampled layer gets besides the canonical ones: the sampled spacing ratio [1];
#: the occupancy [1], the share of the pole positions at the street's spacing that hold a
#: pole (sampled where the network binds it, as networks learned from mapped lamps do; 1,
#: every position, where it does not: the design guides' assumption); and the name of the
#: network that filled the layer (provenance).
EXTRA_FIELDS: dict[str, FieldType] = {
    "spacing_ratio": "float",
    "occupancy": "float",
    "network": "str",
}

#: Field types of the sampled layer (besides the input's other fields).
OUTPUT_SCHEMA: dict[str, FieldType] = {
    **STREET_FIELDS,
    **{observed_field(name): "bool" for name in STREET_FIELDS},
    **LIGHTING_FIELDS,
    **EXTRA_FIELDS,
}

_NETWORK_FIELDS = tuple(name for name in (*STREET_FIELDS, *LIGHTING_FIELDS) if name != "spacing")


def network_for_streets(
    streets: pd.DataFrame, network: str | os.PathLike[str] | BayesNet | None
) -> BayesNet:
    """The network to use for ``streets``: ``network``, or where it is None and the layer
    has a CRS, the catalogue network for where the layer lies (:func:`network_by_location`);
    a table without a CRS gets the catalogue default.

    Parameters
    ----------
    streets
        Street layer (a GeoDataFrame with a CRS, or a table).
    network
        Network object, catalogue name, network folder, or None.

    Returns
    -------
    bayesnets.BayesNet
        The network.
    """
    if network is None and isinstance(streets, gpd.GeoDataFrame) and streets.crs is not None:
        network, _ = network_by_location(streets)
    return resolve_network(network)


def resolve_network(network: str | os.PathLike[str] | BayesNet | None) -> BayesNet:
    """A network object from a catalogue name, a folder, or None (the default network).

    Parameters
    ----------
    network
        Network object (returned as it is), catalogue name, network folder, or None.

    Returns
    -------
    bayesnets.BayesNet
        The network.

    Raises
    ------
    bayesnets.errors.CatalogError
        Unknown catalogue name (the message lists the catalogue).
    """
    if isinstance(network, BayesNet):
        return network
    return load_network(network)


def fill_lighting(
    streets: gpd.GeoDataFrame,
    network: str | os.PathLike[str] | BayesNet | None = None,
    *,
    candidates: int = DEFAULT_CANDIDATES,
    rng: np.random.Generator,
    on_conflict: OnConflict = "error",
    progress: bool = False,
) -> gpd.GeoDataFrame:
    """Fill missing street fields and add lighting fields by likelihood-weighted sampling.

    Parameters
    ----------
    streets
        Normalised streets: canonical fields of :data:`STREET_FIELDS` (missing values
        allowed) with ``<field>_observed`` flags. A field without a flag counts as observed
        where it is not missing. Lighting fields with an ``_observed`` flag are evidence too.
    network
        Network object, catalogue name or folder; None for the catalogue network for where
        the layer lies (:func:`network_by_location`; the catalogue default for a table
        without a CRS).
    candidates
        Likelihood-weighting candidates per segment [1] (Chuang 2011, Sec. 3.3).
    rng
        Random generator; the same seed gives the same layer.
    on_conflict
        ``"error"`` or ``"relax"`` impossible evidence (see
        :func:`bayesnets.likelihood_weighted_sample`).
    progress
        Show a progress bar.

    Returns
    -------
    geopandas.GeoDataFrame
        ``streets`` with every street field filled (observed values kept as they were,
        flags kept), the lighting fields of :data:`LIGHTING_FIELDS` and ``spacing_ratio``
        [1]; ``spacing = spacing_ratio * mounting_height`` [m]; ``occupancy`` [1] (1 unless
        the network binds it, see :data:`EXTRA_FIELDS`); ``network``, the name of
        the network used. An empty layer gives an empty layer with these columns.

    Raises
    ------
    bayesnets.errors.BayesNetError
        Impossible evidence (``on_conflict="error"``), a value the network cannot map, a
        network missing a field this stage needs, or one whose states decode to impossible
        values (:data:`~nightlights.streets.schema.VALUE_RANGES`).
    nightlights.errors.ResourceError
        Sampling would need more memory than allowed.

    References
    ----------
    Chuang 2011, Sec. 3.2-3.3.
    """
    net = network_for_streets(streets, network)
    check_network_values(net, VALUE_RANGES)
    bound = {binding.field for binding in net.bindings.values()}
    missing = [name for name in _NETWORK_FIELDS if name not in bound]
    if missing or "spacing_ratio" not in bound:
        raise BayesNetError(
            f"network {net.name!r} binds no variable to fields "
            f"{[*missing, *(['spacing_ratio'] if 'spacing_ratio' not in bound else [])]}; "
            "streets sample needs every street and lighting field"
        )
    out = streets.copy()
    evidence = pd.DataFrame(index=out.index)
    for name in sorted(bound):
        if name not in out:
            continue
        flag = observed_field(name)
        if flag in out:
            observed = out[flag].astype("boolean").fillna(False).to_numpy(bool)
        elif name in STREET_FIELDS:
            observed = out[name].notna().to_numpy()
        else:
            continue
        evidence[name] = out[name].astype(object).where(observed, None)
    labels = (
        list(out["source_id"].astype(str)) if "source_id" in out else [str(i) for i in out.index]
    )
    check_memory(
        sampling_memory(net, len(out), candidates),
        f"sampling {len(out)} street segments with {candidates} candidates each",
        option="candidates=",
    )
    sampled = sample_frame(
        net,
        evidence,
        candidates=candidates,
        rng=rng,
        on_conflict=on_conflict,
        labels=labels,
        progress=progress,
    )
    for name, kind in STREET_FIELDS.items():
        flag = observed_field(name)
        filled = _typed(sampled[name], kind)
        if name in out:
            keep = out[name].notna().to_numpy().copy()
            if flag in out:
                keep &= out[flag].astype("boolean").fillna(False).to_numpy(bool)
            filled = filled.where(~keep, _typed(out[name], kind))
        else:
            keep = np.zeros(len(out), bool)
        out[name] = filled.to_numpy()
        out[flag] = keep
    for name, kind in LIGHTING_FIELDS.items():
        if name == "spacing":
            continue
        out[name] = _typed(sampled[name], kind).to_numpy()
    out["spacing_ratio"] = sampled["spacing_ratio"].to_numpy(float)
    out["spacing"] = out["spacing_ratio"].to_numpy(float) * out["mounting_height"].to_numpy(float)
    out["occupancy"] = (
        pd.to_numeric(sampled["occupancy"], errors="coerce").to_numpy(float)
        if "occupancy" in bound
        else np.ones(len(out))
    )
    out["network"] = pd.Series([net.name] * len(out), index=out.index, dtype=object)
    logger.info("sampled %d street segments with network %r", len(out), net.name)
    return out


def _typed(values: pd.Series, kind: str) -> pd.Series:
    if kind == "float":
        return pd.to_numeric(values, errors="coerce").astype("float64")
    if kind == "int":
        return pd.to_numeric(values, errors="coerce").round().astype("Int64")
    if kind == "bool":
        return values.astype(object).map(_as_bool).astype("boolean")
    return values.astype(object)


def _as_bool(value: object) -> object:
    if value is None or (isinstance(value, float) and np.isnan(value)) or value is pd.NA:
        return None
    if isinstance(value, str):
        return value.strip().lower() in ("true", "t", "yes", "y", "1")
    return bool(value)


@dataclass(frozen=True, eq=False)
class SampleResult:
    """What :func:`sample` returns.

    Attributes
    ----------
    streets
        The streets with every street field filled and the lighting fields added (see
        :func:`fill_lighting`).
    path
        The GeoPackage written, or None when no output was asked for.
    network
        Name of the network that filled the streets (also the ``network`` field of
        :attr:`streets`).
    location
        WGS84 ``(longitude, latitude)`` [deg] of the centre of the layer's extent when the
        network was chosen by location (no network given); None when it was given.
    """

    streets: gpd.GeoDataFrame
    path: Path | None
    network: str
    location: tuple[float, float] | None = None


def network_by_location(
    frame: gpd.GeoDataFrame, *, source: str = "streets"
) -> tuple[str, tuple[float, float]]:
    """Catalogue network for a street layer from where it lies.

    The centre of the layer's extent is transformed to WGS84 and looked up in the boxes of
    :data:`~nightlights.streets._location.REGION_BOXES`: North America gives
    ``north_america``, Europe ``europe``, China, Japan, Korea and Taiwan ``east_asia``,
    anywhere else the ``generic`` blend, with a
    :class:`~nightlights.errors.DataQualityWarning` that names it and how to choose another
    (none for an empty layer, which has no position and gets ``generic``).

    Parameters
    ----------
    frame
        Street layer with a CRS.
    source
        Name of the layer in messages.

    Returns
    -------
    tuple
        The catalogue network name and the ``(longitude, latitude)`` [deg] it was chosen
        for.

    Raises
    ------
    InputError
        The layer has no CRS.
    """
    longitude, latitude = layer_location(frame, source=source)
    name = network_for_location(longitude, latitude)
    if name == FALLBACK_NETWORK and not np.isnan(longitude):
        warnings.warn(
            f"{source}: the layer lies at ({longitude:.2f}, {latitude:.2f}) deg (lon, lat), "
            f"outside the regions with a sourced network ({', '.join(REGION_BOXES)}); "
            f"sampling with the {FALLBACK_NETWORK!r} network (a blend of europe and "
            "north_america); choose another with network=",
            DataQualityWarning,
            stacklevel=3,
        )
    logger.info("network %r chosen for %s at (%.3f, %.3f)", name, source, longitude, latitude)
    return name, (longitude, latitude)


def sample(
    streets: gpd.GeoDataFrame | PathLike,
    output: PathLike | None = None,
    *,
    network: str | os.PathLike[str] | BayesNet | None = None,
    candidates: int = DEFAULT_CANDIDATES,
    seed: int | None = None,
    on_conflict: OnConflict = "error",
    progress: bool = False,
) -> SampleResult:
    """Fill missing street fields and add lighting fields by sampling a Bayesian network.

    Stage ``streets sample`` (Chuang 2011, Sec. 3.3); see :func:`fill_lighting`.

    Parameters
    ----------
    streets
        Normalised streets (the result of :func:`~nightlights.streets._normalize`): lines
        in a projected CRS [m] with the canonical fields, their ``_observed`` flags and
        ``source_id``. A GeoDataFrame or a vector file path.
    output
        GeoPackage to write (layer ``streets``), atomically; nothing is written on failure.
        None writes nothing.
    network
        Network object, catalogue network name (``europe``, ``north_america``,
        ``east_asia``, ``generic``, ``helsinki``) or network folder. None chooses a catalogue
        network from where the layer lies (:func:`network_by_location`): North America
        ``north_america``, Europe ``europe``, China, Japan, Korea and Taiwan ``east_asia``,
        elsewhere ``generic`` with a warning.
    candidates
        Likelihood-weighting candidates per segment [1].
    seed
        Random seed; the same seed gives the same streets.
    on_conflict
        ``"error"`` or ``"relax"`` for impossible evidence.
    progress
        Show a progress bar.

    Returns
    -------
    SampleResult
        The filled streets, the written path (or None), the network's name and, when it
        was chosen by location, the layer's position.

    Warns
    -----
    DataQualityWarning
        No network given and the layer lies outside North America and Europe: the
        ``generic`` network is used.

    Raises
    ------
    InputError
        The input has no CRS or a geographic one; a negative seed; fewer than one
        candidate.
    OutputError
        The output folder is missing or not writable (checked before any work).
    nightlights.errors.ResourceError
        Sampling would need more memory than allowed (see
        :func:`bayesnets.sampling.sampling_memory`).
    bayesnets.errors.BayesNetError
        Unknown network name (the message lists the catalogue), impossible evidence, values
        the network cannot map. The message names the input file.

    Examples
    --------
    >>> import geopandas as gpd
    >>> from shapely import LineString
    >>> from nightlights.streets import normalize, sample
    >>> raw = gpd.GeoDataFrame(
    ...     {"highway": ["primary", "residential", "footway"], "lit": ["yes", "yes", None]},
    ...     geometry=[
    ...         LineString([(0, 0), (200, 0)]),
    ...         LineString([(0, 60), (150, 60)]),
    ...         LineString([(0, 90), (80, 90)]),
    ...     ],
    ...     crs="EPSG:3067",
    ... )
    >>> result = sample(normalize(raw).streets, network="europe", seed=1)
    >>> lit = result.streets
    >>> list(lit["street_class"]), list(lit["lit_observed"])
    (['arterial', 'local', 'path'], [True, True, False])
    >>> bool((lit["spacing"] == lit["spacing_ratio"] * lit["mounting_height"]).all())
    True
    >>> result.path is None, result.network, result.location
    (True, 'europe', None)
    """
    rng = rng_from_seed(seed)
    if isinstance(candidates, bool) or not isinstance(candidates, int) or candidates < 1:
        raise InputError(f"candidates={candidates!r}; expected an integer >= 1")
    with OutputSet(output, inputs={"streets": streets, "network": network}) as outputs:
        frame, source = as_vector(streets, name="streets")
        if frame.crs is None or not frame.crs.is_projected:
            raise InputError(
                f"{source}: streets must be in a projected CRS [m] (run `nightlights streets "
                "normalize` first)"
            )
        location = None
        if network is None:
            network, location = network_by_location(frame, source=str(source))
        try:
            net = resolve_network(network)
            filled = fill_lighting(
                frame,
                net,
                candidates=candidates,
                rng=rng,
                on_conflict=on_conflict,
                progress=progress,
            )
        except BayesNetError as exc:
            raise type(exc)(f"{source}: {exc}") from exc
        path = None
        if output is not None:
            schema = {name: kind for name, kind in OUTPUT_SCHEMA.items() if name in filled}
            if "source_id" in filled:
                schema["source_id"] = "str"
            write_gpkg(
                filled,
                outputs.temporary(output),
                layer="streets",
                schema=schema,
                style=streets_style(ARRANGEMENTS),
            )
            path = Path(output)
    return SampleResult(filled, path, net.name, location)


def lighting_summary(streets: pd.DataFrame) -> dict[str, dict[str, int]]:
    """Counts of segments per arrangement and per light system (lit segments only).

    Parameters
    ----------
    streets
        Output of :func:`fill_lighting`.

    Returns
    -------
    dict
        ``{"arrangement": {name: count}, "system_id": {id: count}}``, plus ``"lit"``
        with the numbers of lit and unlit segments.
    """
    lit = streets["lit"].astype("boolean").fillna(False).to_numpy(bool) if len(streets) else []
    summary: dict[str, dict[str, int]] = {
        "lit": {"lit": int(np.sum(lit)), "unlit": int(len(streets) - np.sum(lit))}
    }
    for name in ("arrangement", "system_id"):
        counts = streets.loc[lit, name].value_counts() if len(streets) else pd.Series()
        summary[name] = {str(k): int(v) for k, v in sorted(counts.items())}
    return summary
