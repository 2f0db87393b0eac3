"""Estimate a street-lighting network from a layer whose lighting is known.

Stage ``streets fit`` (beyond Chuang 2011, whose Fig. 10 weights were counted by hand):
given streets with known lighting fields (e.g. streets joined with mapped lamps), estimate
the tables of a base network's structure with pgmpy and a Dirichlet prior centred on the
base network (:func:`bayesnets.fit_network`), and write the result as a new network folder
that ``streets sample --network DIR`` accepts.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd

from bayesnets import BayesNet, fit_network, write_network
from bayesnets.errors import BayesNetError
from nightlights._typing import PathLike
from nightlights.errors import EmptyInputError, OutputError
from nightlights.io import as_vector
from nightlights.io.outputs import refuse_replacing_inputs
from nightlights.streets._sample import network_by_location, network_for_streets
from nightlights.streets.schema import observed_field

__all__ = ["FitResult", "fit", "fit_lighting_network", "known_values"]


def known_values(streets: gpd.GeoDataFrame | pd.DataFrame, fields: list[str]) -> pd.DataFrame:
    """The values of ``fields`` that are known, missing elsewhere.

    A value is known where it is not missing and, if the layer has a
    ``<field>_observed`` flag, the flag is true (sampled values are not data). A missing
    ``spacing_ratio`` is derived as ``spacing / mounting_height`` where both are known.

    Parameters
    ----------
    streets
        Street layer.
    fields
        Fields to extract.

    Returns
    -------
    pandas.DataFrame
        One column per field present in ``streets`` (object dtype, None where unknown).
    """
    frame = pd.DataFrame(index=streets.index)
    for name in fields:
        if name not in streets:
            continue
        known = streets[name].notna().to_numpy().copy()
        flag = observed_field(name)
        if flag in streets:
            known &= streets[flag].astype("boolean").fillna(False).to_numpy(bool)
        frame[name] = streets[name].astype(object).where(known, None)
    if "spacing_ratio" in fields and {"spacing", "mounting_height"} <= set(streets.columns):
        derived = pd.to_numeric(streets["spacing"], errors="coerce") / pd.to_numeric(
            streets["mounting_height"], errors="coerce"
        )
        current = frame["spacing_ratio"] if "spacing_ratio" in frame else None
        if current is None:
            frame["spacing_ratio"] = derived.astype(object).where(derived.notna(), None)
        else:
            frame["spacing_ratio"] = current.where(current.notna(), derived)
    return frame


def fit_lighting_network(
    streets: gpd.GeoDataFrame | pd.DataFrame,
    base: str | os.PathLike[str] | BayesNet | None = None,
    *,
    prior: float = 1.0,
    name: str | None = None,
) -> BayesNet:
    """Estimate the tables of ``base`` from the known values in ``streets``.

    Parameters
    ----------
    streets
        Layer with canonical street fields and known lighting fields.
    base
        Network (object, catalogue name or folder) giving structure, states, bindings and
        the prior; None for the catalogue network for where the layer lies (the catalogue
        default for a table without a CRS).
    prior
        Prior strength in pseudo-observations per parent combination [1]; 0 is maximum
        likelihood.
    name
        Name of the fitted network.

    Returns
    -------
    bayesnets.BayesNet
        The fitted network.
    """
    net = network_for_streets(streets, base)
    fields = [binding.field for binding in net.bindings.values()]
    frame = known_values(streets, fields)
    if frame.empty or frame.notna().to_numpy().sum() == 0:
        raise EmptyInputError("no known values of the network's fields to fit tables from")
    # Values the network cannot map are errors in fit too: they name field and record.
    return fit_network(frame.replace({np.nan: None}), net, prior=prior, name=name)


@dataclass(frozen=True, eq=False)
class FitResult:
    """What :func:`fit` returns.

    Attributes
    ----------
    network
        The fitted network; :func:`~nightlights.streets._sample` takes it as ``network``.
    path
        The network folder written, or None when no output was asked for.
    """

    network: BayesNet
    path: Path | None


def fit(
    streets: gpd.GeoDataFrame | PathLike,
    output: PathLike | None = None,
    *,
    network: str | os.PathLike[str] | BayesNet | None = None,
    prior: float = 1.0,
    name: str | None = None,
) -> FitResult:
    """Estimate a street-lighting network from streets whose lighting is known.

    Stage ``streets fit``; see :func:`fit_lighting_network`.

    Parameters
    ----------
    streets
        Street layer with known lighting fields: a GeoDataFrame or any vector file.
    output
        Network folder to write; must not exist or be empty. Written to a temporary folder
        first and renamed, so a failure leaves nothing behind. None writes nothing.
    network
        Base network (object, catalogue name or folder); default: the catalogue network for
        where the streets lie (as ``streets sample`` chooses it), or the catalogue default for
        a table without a CRS.
    prior
        Prior strength in pseudo-observations per parent combination [1].
    name
        Name of the fitted network (default: the output folder's name, or
        ``<base>_fitted`` without an output).

    Returns
    -------
    FitResult
        The fitted network and the written folder (or None).

    Raises
    ------
    OutputError
        ``output`` is an input or holds one, exists and is not an empty folder, or its
        parent folder is missing or not writable (checked before any work).
    EmptyInputError
        The layer has no features, or no known values of the network's fields.
    bayesnets.errors.BayesNetError
        A value the network cannot map. The message names the input file.

    Examples
    --------
    >>> import warnings
    >>> import geopandas as gpd
    >>> from shapely import LineString
    >>> from nightlights.streets import fit
    >>> surveyed = gpd.GeoDataFrame(
    ...     {
    ...         "street_class": ["local", "local", "arterial"],
    ...         "lit": [True, True, True],
    ...         "mounting_height": [6.0, 6.0, 10.0],
    ...         "spacing": [21.0, 24.0, 35.0],
    ...     },
    ...     geometry=[LineString([(0, y), (100, y)]) for y in (0, 50, 100)],
    ...     crs="EPSG:3067",
    ... )
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")  # most parent combinations have no data here
    ...     result = fit(surveyed, network="europe", name="surveyed")
    >>> result.network.name, result.path
    ('surveyed', None)
    """
    target = Path(output) if output is not None else None
    refuse_replacing_inputs([target], {"streets": streets, "network": network})
    if target is not None and target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise OutputError(f"{target}: exists and is not an empty folder")
    with network_folder(target) as tmp:
        frame, source = as_vector(streets, name="streets")
        if frame.empty:
            raise EmptyInputError(f"{source}: no features to fit a network from")
        if name is None and target is not None:
            name = target.name
        if network is None and frame.crs is not None:
            # the base network for where the streets lie, as streets sample chooses it
            network, _ = network_by_location(frame, source=str(source))
        try:
            fitted = fit_lighting_network(frame, network, prior=prior, name=name)
        except BayesNetError as exc:
            raise type(exc)(f"{source}: {exc}") from exc
        except EmptyInputError as exc:
            raise EmptyInputError(f"{source}: {exc}") from exc
        if tmp is not None:
            write_network(fitted, tmp)
    return FitResult(fitted, target)


@contextlib.contextmanager
def network_folder(target: Path | None) -> Iterator[Path | None]:
    """A temporary folder beside ``target``, made before the work starts (so that a missing
    or read-only parent folder fails at once) and swapped onto ``target`` at the end (an
    existing folder there is moved aside and removed: the callers check first that it may
    be replaced); on any error it is removed and ``target`` is left as it was."""
    if target is None:
        yield None
        return
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"{target}: parent folder {parent} does not exist")
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=parent))
    except OSError as exc:
        raise OutputError(f"{target}: cannot write to folder {parent} ({exc.strerror})") from exc
    old = None
    try:
        yield tmp
        try:
            if target.exists():
                old = Path(tempfile.mkdtemp(prefix=f".{target.name}.old.", dir=parent))
                os.replace(target, old / "network")
            os.replace(tmp, target)
        except OSError as exc:
            raise OutputError(
                f"{target}: cannot write the network folder ({exc.strerror})"
            ) from exc
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
