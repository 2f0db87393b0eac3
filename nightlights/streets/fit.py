"""Estimate a street-lighting network from a layer whose lighting is known.

Stage ``streets fit`` (beyond Chuang 2011, whose Fig. 10 weights were counted by hand):
given streets with known lighting fields (e.g. streets joined with mapped lamps), estimate
the tables of a base network's structure with pgmpy and a Dirichlet prior centred on the
base network (:func:`bayesnets.fit_network`), and write the result as a new network folder
that ``streets sample --network DIR`` accepts.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd

from bayesnets import BayesNet, fit_network, write_network
from bayesnets.errors import BayesNetError
from nightlights.errors import EmptyInputError, OutputError
from nightlights.io import read_vector
from nightlights.streets.sample import resolve_network
from nightlights.streets.schema import observed_field

__all__ = ["fit_lighting_network", "fit_streets", "known_values"]


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
        the prior; None for the catalogue default.
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
    net = resolve_network(base)
    fields = [binding.field for binding in net.bindings.values()]
    frame = known_values(streets, fields)
    if frame.empty or frame.notna().to_numpy().sum() == 0:
        raise EmptyInputError("no known values of the network's fields to fit tables from")
    # Values the network cannot map are errors in fit too: they name field and record.
    return fit_network(frame.replace({np.nan: None}), net, prior=prior, name=name)


def fit_streets(
    src: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    network: str | os.PathLike[str] | None = None,
    prior: float = 1.0,
    name: str | None = None,
) -> Path:
    """Stage ``streets fit``: estimate a network from ``src`` and write it to ``out_dir``.

    Parameters
    ----------
    src
        Street layer with known lighting fields (any vector format).
    out_dir
        Output network folder; must not exist or be empty. Written to a temporary folder
        first and renamed, so a failure leaves nothing behind.
    network
        Base network (catalogue name or folder); default: the catalogue default.
    prior
        Prior strength in pseudo-observations per parent combination [1].
    name
        Name of the fitted network (default: the output folder's name).

    Returns
    -------
    pathlib.Path
        ``out_dir``.
    """
    target = Path(out_dir)
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise OutputError(f"{target}: exists and is not an empty folder")
    streets = read_vector(src)
    if streets.empty:
        raise EmptyInputError(f"{src}: no features to fit a network from")
    try:
        fitted = fit_lighting_network(streets, network, prior=prior, name=name or target.name)
    except BayesNetError as exc:
        raise type(exc)(f"{src}: {exc}") from exc
    except EmptyInputError as exc:
        raise EmptyInputError(f"{src}: {exc}") from exc
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"{target}: parent folder {parent} does not exist")
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=parent))
    try:
        write_network(fitted, tmp)
        if target.exists():
            target.rmdir()
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)
    return target
