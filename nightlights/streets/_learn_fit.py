"""A street-lighting network fitted to per-street lamp evidence by stochastic EM.

The last step of stage ``streets learn`` (:mod:`nightlights.streets._learn`), after the
evidence (:mod:`nightlights.streets._learn_evidence`). The network binds
``spacing_ratio = spacing / mounting_height``, and the ratio's parents (arrangement, and
through the width ratio the width and the mounting height) are rarely all observed. Each
street's unobserved fields are therefore imputed by :data:`IMPUTATION_DRAWS` draws from the
network given the street's evidence (likelihood weighting, as ``streets sample``; the
imputing network's tables floored at :data:`IMPUTATION_FLOOR`), ``spacing_ratio`` is the
observed spacing over the tagged or mean imputed mounting height, and each table is fitted
(:func:`bayesnets.fit_network`, a Dirichlet prior centred on the base) from the streets
where *its own* variable is observed, with the parents as observed or imputed.
:data:`DEFAULT_ITERATIONS` rounds, the first imputing with the base, each further one with
the network of the round before (stochastic EM). Tables of variables never observed (e.g.
mounting height where no lamp is tagged) come out as the base's.

``lit`` is true on a street with a lamp and no ``lit`` value in the layer; a street without
a mapped lamp is *not* evidence of an unlit street (only ``lit=no`` is). The spacing ratio's
states are widened to cover the evidence (:func:`spacing_ratio_states`): the base's
design-guide states (2.5-4) would clip a city whose lamps stand closer. A base without an
occupancy variable gets one (:func:`with_occupancy`, given the street class, prior at 1:
the design guides' pole at every position).
"""

from __future__ import annotations

import os
import warnings
from dataclasses import replace

import geopandas as gpd
import numpy as np
import pandas as pd

from bayesnets import BayesNet, fit_network
from bayesnets.binding import Binding
from bayesnets.errors import BayesNetError, BayesNetWarning
from bayesnets.sampling import sampling_memory
from nightlights._resources import check_memory
from nightlights.errors import InputError
from nightlights.streets._learn_assign import PAIR_BYTES, estimate_pairs
from nightlights.streets._sample import fill_lighting, network_for_streets
from nightlights.streets.schema import STREET_FIELDS, VALUE_RANGES, observed_field

__all__ = [
    "DEFAULT_ITERATIONS",
    "check_learn_memory",
    "learn_lighting_network",
    "spacing_ratio_states",
    "with_occupancy",
]

#: Rounds of imputation and fitting (stochastic EM) [1].
DEFAULT_ITERATIONS = 5
#: Likelihood-weighting candidates per street when imputing unobserved fields [1].
IMPUTATION_CANDIDATES = 64
#: Imputations per street and round (Monte Carlo E-step) [1]; the mounting height that
#: turns a spacing into a spacing ratio is their mean.
IMPUTATION_DRAWS = 8
#: Floor of every bound table of the imputing network [1]: the base's zeros are design
#: rules (e.g. never single-sided when the road is wider than 1.5 mounting heights), not
#: observations; without a floor, a street that breaks a rule could never be imputed into
#: the parent state the rule forbids, and the fit could never learn that it happens.
IMPUTATION_FLOOR = 0.01

#: Variable a learned network adds when its base binds no ``occupancy`` field, its parent,
#: and its states [1]: the share of the pole positions at the street's spacing that hold a
#: pole, in tenths. The prior puts every street class at 1, the design guides' assumption
#: of a pole at every position.
OCCUPANCY_VARIABLE = "OCCUPANCY"
OCCUPANCY_PARENT = "STREET_CLASS"
OCCUPANCY_STATES = tuple(round(0.1 * k, 1) for k in range(1, 11))


#: Steps of the widened spacing-ratio grid: (upper end of the range, step) [1]; about 10 %
#: of the ratio, finer than the base's 0.5 so that rounding moves a spacing by at most ~6 %.
_RATIO_STEPS = ((4.0, 0.25), (8.0, 0.5), (16.0, 1.0), (50.0, 2.0))


def spacing_ratio_states(base_states: tuple[float, ...], ratios: np.ndarray) -> tuple[float, ...]:
    """States of the spacing ratio that cover the base's states and the evidence.

    Parameters
    ----------
    base_states
        The base network's spacing-ratio states [1].
    ratios
        Observed spacing ratios [1] (NaN ignored).

    Returns
    -------
    tuple of float
        Sorted states: the base's plus a grid from the smallest to the largest observed
        ratio (step 0.25 up to 4, 0.5 up to 8, 1 up to 16, 2 beyond), within the allowed
        range of :data:`~nightlights.streets.schema.VALUE_RANGES`.

    Examples
    --------
    >>> spacing_ratio_states((2.5, 3.0), np.array([1.6, 2.2, 4.4]))
    (1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0, 3.25, 3.5, 3.75, 4.0, 4.5)
    """
    values = np.asarray(ratios, dtype=float)
    values = values[np.isfinite(values)]
    states = set(base_states)
    if values.size:
        low, high = float(values.min()), float(values.max())
        limits = VALUE_RANGES["spacing_ratio"]
        start = 0.0
        for end, step in _RATIO_STEPS:
            grid = np.arange(start, end + step / 2, step)
            lower = np.floor(low / step) * step
            upper = np.ceil(high / step) * step
            grid = grid[(grid >= lower) & (grid <= upper) & (grid >= start)]
            states.update(float(g) for g in grid if not limits.impossible(np.array([g]))[0])
            start = end
    return tuple(sorted(states))


def _widen_spacing_ratio(base: BayesNet, ratios: np.ndarray) -> BayesNet:
    """``base`` with the spacing ratio's states widened (new states with prior weight 0)."""
    variable = next((v for v, b in base.bindings.items() if b.field == "spacing_ratio"), None)
    if variable is None:
        raise BayesNetError(f"network {base.name!r} binds no variable to field 'spacing_ratio'")
    binding = base.bindings[variable]
    if binding.kind not in ("float", "int") or base.children[variable]:
        raise BayesNetError(
            f"network {base.name!r}: variable {variable} (spacing_ratio) must be a numeric "
            "leaf to learn spacing from lamps"
        )
    old = tuple(float(n) for n in binding.numbers)
    numbers = spacing_ratio_states(old, ratios)
    if numbers == tuple(sorted(old)):
        return base
    labels = tuple(f"{n:g}" for n in numbers)
    table = base.tables[variable]
    widened = np.zeros((len(numbers), *table.shape[1:]))
    for row, number in enumerate(old):
        widened[numbers.index(number)] = table[row]
    states = dict(base.states)
    states[variable] = labels
    tables = dict(base.tables)
    tables[variable] = widened
    bindings = dict(base.bindings)
    bindings[variable] = Binding(
        variable, binding.field, "float", labels, numbers, (), nearest=True
    )
    return replace(base, states=states, tables=tables, bindings=bindings)


def with_occupancy(network: BayesNet) -> BayesNet:
    """``network`` with an occupancy variable, if it binds none.

    Parameters
    ----------
    network
        A street-lighting network.

    Returns
    -------
    bayesnets.BayesNet
        ``network`` itself when a variable is bound to the ``occupancy`` field; otherwise a
        copy with :data:`OCCUPANCY_VARIABLE` (states :data:`OCCUPANCY_STATES`, parent
        :data:`OCCUPANCY_PARENT` where the network has it) whose table puts every parent
        state at occupancy 1: the design guides' pole at every position, the prior that
        lamp evidence moves.

    Examples
    --------
    >>> from bayesnets import load_network
    >>> net = with_occupancy(load_network("europe"))
    >>> net.bindings["OCCUPANCY"].field, net.parents["OCCUPANCY"]
    ('occupancy', ('STREET_CLASS',))
    >>> float(net.tables["OCCUPANCY"][-1].min())
    1.0
    """
    if any(binding.field == "occupancy" for binding in network.bindings.values()):
        return network
    if OCCUPANCY_VARIABLE in network.variables:
        raise BayesNetError(
            f"network {network.name!r} has a variable {OCCUPANCY_VARIABLE} not bound to the "
            "occupancy field"
        )
    parents = (OCCUPANCY_PARENT,) if OCCUPANCY_PARENT in network.variables else ()
    labels = tuple(f"{n:g}" for n in OCCUPANCY_STATES)
    table = np.zeros((len(labels), *(len(network.states[p]) for p in parents)))
    table[-1] = 1.0
    return replace(
        network,
        variables=(*network.variables, OCCUPANCY_VARIABLE),
        states={**network.states, OCCUPANCY_VARIABLE: labels},
        parents={**network.parents, OCCUPANCY_VARIABLE: parents},
        tables={**network.tables, OCCUPANCY_VARIABLE: table},
        bindings={
            **network.bindings,
            OCCUPANCY_VARIABLE: Binding(
                OCCUPANCY_VARIABLE, "occupancy", "float", labels, OCCUPANCY_STATES, (), nearest=True
            ),
        },
    )


def check_learn_memory(
    lamps: np.ndarray, streets: gpd.GeoDataFrame, network: BayesNet, max_distance: float
) -> None:
    """Refuse a ``streets learn`` whose memory estimate exceeds the limit, before the lamps are
    assigned: the (lamp, street) pairs within reach (:func:`estimate_pairs`, :data:`PAIR_BYTES`
    each), the imputation's stacked copies of the streets (:data:`IMPUTATION_DRAWS` rows per
    street, 64 B per field) and its likelihood-weighted sampling
    (:func:`bayesnets.sampling.sampling_memory`, :data:`IMPUTATION_CANDIDATES` per row).

    Parameters
    ----------
    lamps
        Point geometries [m].
    streets
        The street layer.
    network
        The base network.
    max_distance
        Largest lamp-to-street distance [m].

    Raises
    ------
    ResourceError
        The estimate is over the limit.
    """
    pairs = estimate_pairs(lamps, streets.geometry.to_numpy(), max_distance=max_distance)
    records = IMPUTATION_DRAWS * len(streets)
    estimate = (
        pairs * PAIR_BYTES
        + records * 64.0 * (len(streets.columns) + 2 * len(network.variables))
        + sampling_memory(network, records, IMPUTATION_CANDIDATES)
    )
    check_memory(
        estimate,
        f"learning from {len(lamps)} lamps (about {pairs:.3g} lamp-street pairs within "
        f"{max_distance:g} m) and {len(streets)} streets",
        option="lower max_distance= (or learn from a smaller area)",
    )


def learn_lighting_network(
    streets: gpd.GeoDataFrame | pd.DataFrame,
    evidence: pd.DataFrame,
    base: str | os.PathLike[str] | BayesNet | None = None,
    *,
    prior: float = 1.0,
    iterations: int = DEFAULT_ITERATIONS,
    rng: np.random.Generator,
    name: str | None = None,
) -> BayesNet:
    """Fit ``base`` to streets with lamp evidence, imputing unobserved parents.

    Parameters
    ----------
    streets
        Normalised streets: canonical street fields with ``<field>_observed`` flags.
    evidence
        Per-street evidence, same row order
        (:func:`~nightlights.streets.street_lamp_evidence`, with ``lit`` and
        ``lit_observed`` set from the lamps where the layer has no ``lit`` value).
    base
        Base network: structure, states, bindings and prior; None for the catalogue
        network for where the streets lie (the catalogue default for a table without a
        CRS).
    prior
        Prior strength in pseudo-observations per parent combination [1].
    iterations
        Rounds of imputation and fitting [1]: the first imputes with ``base``, each
        further one with the network fitted in the round before (stochastic EM).
    rng
        Random generator for the imputation.
    name
        Name of the learned network (default ``<base>_learned``).

    Returns
    -------
    bayesnets.BayesNet
        The learned network: the base's structure and bindings, the spacing ratio's states
        widened to the evidence.
    """
    net = network_for_streets(streets, base)
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise InputError(f"iterations={iterations!r}; expected an integer >= 1")
    if isinstance(streets, gpd.GeoDataFrame):
        streets = pd.DataFrame(streets.drop(columns=streets.geometry.name))
    layer = streets.reset_index(drop=True)
    known = _known_fields(layer, evidence)
    spacing = pd.to_numeric(evidence["spacing"], errors="coerce").to_numpy(float)
    draw_input = layer.copy()
    for field_name in ("arrangement", "mounting_height", "lit"):
        draw_input[field_name] = known[field_name]
        draw_input[observed_field(field_name)] = known[field_name].notna().to_numpy()
    tagged_height = known["mounting_height"].astype(float).to_numpy()
    draws = IMPUTATION_DRAWS
    stacked_input = pd.concat([draw_input] * draws, ignore_index=True)
    stacked_known = pd.concat([known] * draws, ignore_index=True)
    model, widened = net, None
    for _ in range(iterations):
        with warnings.catch_warnings():
            # evidence impossible under the imputing network is relaxed for the
            # imputation only; the fit still counts the observed value
            warnings.simplefilter("ignore", BayesNetWarning)
            drawn = fill_lighting(
                stacked_input,
                _floored(model),
                candidates=IMPUTATION_CANDIDATES,
                rng=rng,
                on_conflict="relax",
            ).reset_index(drop=True)
        drawn_height = drawn["mounting_height"].to_numpy(float).reshape(draws, -1)
        height = np.where(np.isfinite(tagged_height), tagged_height, drawn_height.mean(axis=0))
        ratio = spacing / height
        stacked_known["spacing_ratio"] = pd.Series(np.tile(ratio, draws), dtype=object).where(
            np.isfinite(np.tile(ratio, draws)), None
        )
        if widened is None:
            widened = with_occupancy(_widen_spacing_ratio(net, ratio))
        # Monte Carlo E-step: every draw is a record; the prior is scaled by the number of
        # draws so that it weighs as much against the data as with one record per street
        model = replace(widened, tables=_fit_tables(stacked_known, drawn, widened, prior * draws))
    assert widened is not None
    return replace(
        model,
        name=name or f"{net.name}_learned",
        description=(
            f"Learned from mapped street lamps on {len(layer)} streets "
            f"({int(evidence['spacing_observed'].sum())} with spacing evidence) with network "
            f"{net.name!r} as prior ({prior:g} pseudo-observations per parent combination)."
        ),
        default=False,
        source=None,
    )


def _floored(network: BayesNet) -> BayesNet:
    """``network`` with each bound variable's table floored at :data:`IMPUTATION_FLOOR`."""
    tables = dict(network.tables)
    for variable in network.bindings:
        table = network.tables[variable] + IMPUTATION_FLOOR
        tables[variable] = table / table.sum(axis=0, keepdims=True)
    return replace(network, tables=tables)


def _fit_tables(
    known: pd.DataFrame, drawn: pd.DataFrame, network: BayesNet, prior: float
) -> dict[str, np.ndarray]:
    """Each bound variable's table from the records where it is observed, its parents
    observed or imputed; the prior is ``network`` (tables of unobserved variables kept)."""
    complete = pd.DataFrame(index=known.index)
    for binding in network.bindings.values():
        imputed = drawn[binding.field].astype(object) if binding.field in drawn else None
        values = known[binding.field] if binding.field in known else None
        if values is None:
            complete[binding.field] = imputed
        elif imputed is None:
            complete[binding.field] = values
        else:
            complete[binding.field] = values.where(values.notna(), imputed)
    tables = dict(network.tables)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BayesNetWarning)  # tables outside the family kept
        for variable, binding in network.bindings.items():
            observed = known[binding.field] if binding.field in known else None
            if observed is None or observed.notna().sum() == 0:
                continue
            fields = _family_fields(network, variable)
            frame = complete[fields].copy()
            frame[binding.field] = observed
            tables[variable] = fit_network(frame, network, prior=prior).tables[variable]
    return tables


def _family_fields(network: BayesNet, variable: str) -> list[str]:
    """Fields that give ``variable`` and its parents (a hidden parent through its own)."""
    fields: list[str] = []
    for member in (variable, *network.parents[variable]):
        bound = network.field_of(member)
        members = [bound] if bound else [network.field_of(p) for p in network.parents[member]]
        fields.extend(f for f in members if f and f not in fields)
    return fields


def _known_fields(layer: pd.DataFrame, evidence: pd.DataFrame) -> pd.DataFrame:
    """Observed values of every street and lighting field (object dtype, None unknown)."""
    known = pd.DataFrame(index=layer.index)
    for name in STREET_FIELDS:
        if name not in layer:
            known[name] = pd.Series([None] * len(layer), dtype=object)
            continue
        flag = observed_field(name)
        seen = layer[name].notna().to_numpy().copy()
        if flag in layer:
            seen &= layer[flag].astype("boolean").fillna(False).to_numpy(bool)
        known[name] = layer[name].astype(object).where(seen, None)
    lamp_lit = evidence["lamps"].to_numpy() > 0
    known["lit"] = known["lit"].where(known["lit"].notna() | ~lamp_lit, True)
    for name in ("arrangement", "mounting_height", "occupancy"):
        if name not in evidence:
            known[name] = pd.Series([None] * len(layer), dtype=object)
            continue
        values = evidence[name].astype(object).reset_index(drop=True)
        known[name] = values.where(evidence[observed_field(name)].to_numpy(bool), None)
    return known
