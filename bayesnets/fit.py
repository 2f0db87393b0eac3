"""Estimate a network's tables from data, keeping its structure and bindings.

Beyond Chuang 2011 (whose Fig. 10 weights were counted by hand from GIS datasets): the
counts are taken with pgmpy's estimator, and each table is the posterior mean under a
Dirichlet prior centred on the base network,

.. math:: P(x \\mid u) = \\frac{n(x, u) + \\alpha\\, P_0(x \\mid u)}{n(u) + \\alpha},

with :math:`n` the counts in the data, :math:`P_0` the base table and :math:`\\alpha` the
prior strength in pseudo-observations per parent combination. :math:`\\alpha = 0` is the
maximum-likelihood estimate (parent combinations absent from the data keep the base table).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pandas as pd

from bayesnets.errors import BayesNetError, FitWarning
from bayesnets.network import BayesNet
from bayesnets.sampling import encode_frame


def fit_network(
    frame: pd.DataFrame,
    base: BayesNet,
    *,
    prior: float = 1.0,
    name: str | None = None,
    description: str | None = None,
) -> BayesNet:
    """Estimate the tables of ``base`` from the records of ``frame``.

    Parameters
    ----------
    frame
        Records with the fields bound in ``base``; missing values are allowed (a record
        counts for a table only where the variable and all its parents are known).
    base
        Network giving structure, states, bindings and the prior tables.
    prior
        Prior strength: pseudo-observations per parent combination drawn from the base
        table [1]. 0 gives maximum likelihood.
    name
        Name of the fitted network (default: ``<base>_fitted``).
    description
        Description (default: says what it was fitted from).

    Returns
    -------
    BayesNet
        A network with the same structure and bindings and the estimated tables.

    Warns
    -----
    FitWarning
        A table involves a hidden variable that cannot be derived from the data and is
        kept from the base; or parent combinations without data keep the base table.

    Notes
    -----
    Hidden variables whose table is deterministic (0/1) are derived from their parents,
    so tables conditioned on them (e.g. an arrangement given a width ratio) are still
    estimated.
    """
    with warnings.catch_warnings():
        # pgmpy 1.x announces the move of its estimators; the counting API used here is
        # unchanged.
        warnings.simplefilter("ignore", FutureWarning)
        from pgmpy.estimators import BayesianEstimator
    from pgmpy.models import DiscreteBayesianNetwork

    if not np.isfinite(prior) or prior < 0:
        raise BayesNetError(f"prior={prior}; expected a non-negative pseudo-count")
    codes = encode_frame(base, frame)
    codes = _derive_deterministic(base, codes, len(frame))
    tables: dict[str, np.ndarray] = {}
    kept: list[str] = []
    unseen: dict[str, int] = {}
    for variable in base.variables:
        family = (variable, *base.parents[variable])
        if any(member not in codes for member in family):
            tables[variable] = base.tables[variable]
            kept.append(variable)
            continue
        known = np.all([codes[member] >= 0 for member in family], axis=0)
        data = pd.DataFrame(
            {m: np.asarray(base.states[m], dtype=object)[codes[m][known]] for m in family}
        )
        model = DiscreteBayesianNetwork()
        model.add_node(variable)
        model.add_edges_from((parent, variable) for parent in base.parents[variable])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            estimator = BayesianEstimator(
                model, data, state_names={m: list(base.states[m]) for m in family}
            )
            counts = _ordered_counts(estimator.state_counts(variable), base, variable)
        base_table = base.tables[variable]
        posterior = counts + prior * base_table
        norm = posterior.sum(axis=0)
        empty = norm == 0
        unseen[variable] = int(empty.sum())
        posterior = np.where(empty[np.newaxis], base_table, posterior / np.where(empty, 1, norm))
        tables[variable] = posterior
    if kept:
        warnings.warn(
            f"fit of {base.name!r}: tables {', '.join(kept)} involve hidden variables that the "
            "data cannot give and are kept from the base network",
            FitWarning,
            stacklevel=2,
        )
    missing = {v: n for v, n in unseen.items() if n}
    if missing:
        warnings.warn(
            f"fit of {base.name!r} with prior 0: parent combinations without data keep the "
            f"base table ({', '.join(f'{v}: {n}' for v, n in missing.items())})",
            FitWarning,
            stacklevel=2,
        )
    return replace(
        base,
        name=name or f"{base.name}_fitted",
        description=description
        or f"Tables fitted to {len(frame)} records with a prior of {prior:g} "
        f"pseudo-observations per parent combination on network {base.name!r}.",
        tables=tables,
        default=False,
        source=None,
    )


def _ordered_counts(counts: pd.DataFrame, base: BayesNet, variable: str) -> np.ndarray:
    """Counts as an array of shape ``(n_states, *parent_n_states)`` in the base's order."""
    parents = base.parents[variable]
    states = list(base.states[variable])
    if not parents:
        return counts.reindex(states).to_numpy(dtype=float)[:, 0]
    columns = pd.MultiIndex.from_product([list(base.states[p]) for p in parents], names=parents)
    frame = counts.reindex(index=states, columns=columns, fill_value=0.0)
    return frame.to_numpy(dtype=float).reshape(base.tables[variable].shape)


def _derive_deterministic(
    base: BayesNet, codes: dict[str, np.ndarray], n: int
) -> dict[str, np.ndarray]:
    """Add codes of hidden variables whose tables are 0/1 functions of known parents."""
    codes = dict(codes)
    for variable in base.variables:
        if variable in codes:
            continue
        table = base.tables[variable]
        parents = base.parents[variable]
        if not np.all((table == 0) | (table == 1)) or any(p not in codes for p in parents):
            continue
        flat = table.reshape(table.shape[0], -1).argmax(axis=0)
        known = np.all([codes[p] >= 0 for p in parents], axis=0) if parents else np.ones(n, bool)
        index = np.zeros(n, dtype=np.int64)
        for parent, size in zip(parents, table.shape[1:], strict=True):
            index = index * size + np.where(known, codes[parent], 0)
        codes[variable] = np.where(known, flat[index], -1).astype(np.int16)
    return codes
