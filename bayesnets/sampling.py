"""Likelihood-weighted sampling of a network, vectorised over records (Chuang 2011, Sec. 3.3).

For every record (a street segment, say) the observed variables are *evidence*. Chuang's
sampler draws ``N`` candidates per record by ancestral sampling with the evidence fixed,
weights each candidate by the likelihood of the evidence given its parents,

.. math:: w = \\prod_{v \\in E} P(e_v \\mid x_{pa(v)}),

and keeps one candidate chosen in proportion to its weight (Chuang 2011, Sec. 3.3;
likelihood weighting after Fung & Chang 1990, Shachter & Peot 1990).

This implementation does the same, with three exact shortcuts that change the cost but not
the distribution of the result:

1. Records with the same evidence pattern are one batch: every array operation runs over
   ``records x candidates`` at once, on the flattened CPD arrays, in topological order.
2. Only the unobserved *ancestors* of the evidence influence the weight, so only they are
   drawn ``N`` times; the other variables are drawn once, after the choice, for the chosen
   candidate. If the evidence has no unobserved ancestor the weight is a constant and no
   candidates are drawn at all.
3. The probability of each pattern's evidence, P(e), is computed exactly
   (:func:`bayesnets.inference.evidence_probability`); P(e) = 0 is impossible evidence.

A record whose ``N`` candidates all have weight zero although P(e) > 0 is redrawn with
twice as many candidates, up to :data:`MAX_REDRAW_ROUNDS` times (a documented departure
from plain likelihood weighting that only touches rare evidence).

Length: the sampler, its conflict resolution, the chunked candidate draws and their memory
estimate share the private flattened-table layout and chunk sizes; splitting them would
expose those internals.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd

from bayesnets.binding import MISSING
from bayesnets.errors import (
    EvidenceError,
    EvidenceRelaxedWarning,
    ImpossibleEvidenceError,
)
from bayesnets.inference import evidence_probability
from bayesnets.network import BayesNet

#: Default number of candidates per record, chosen from ``benchmarks/bench_bn_candidates.py``:
#: the marginal error (total variation against exact inference) falls about as 1/N, from
#: 0.11 at N=1 to 0.012 at 64 and 0.007 at 128, close to the 40 000-record noise floor
#: (0.003); on realistic layers few segments need weights, so N=128 costs almost nothing
#: there, and even a layer whose every segment is weighted stays under the 30 s target
#: for 1e6 segments.
DEFAULT_CANDIDATES = 128

#: Candidates drawn per vectorised chunk: bounds memory to a few tens of MB.
CHUNK_CANDIDATES = 1 << 20

#: Rounds of redrawing (with doubling candidates) for records whose candidates all had
#: weight zero although their evidence is possible.
MAX_REDRAW_ROUNDS = 12

OnConflict = Literal["error", "relax"]


@dataclass(frozen=True)
class _Tables:
    """Flattened CPDs: ``flat[v]`` has shape ``(n_states, n_parent_combinations)``."""

    flat: dict[str, np.ndarray]
    cumulative: dict[str, np.ndarray]
    strides: dict[str, tuple[int, ...]]

    @classmethod
    def of(cls, network: BayesNet) -> _Tables:
        flat, cumulative, strides = {}, {}, {}
        for name in network.variables:
            table = network.tables[name]
            flat[name] = table.reshape(table.shape[0], -1)
            cum = np.cumsum(flat[name], axis=0)
            cum[-1] = 1.0  # guard against rounding: every draw u < 1 finds a state
            cumulative[name] = cum
            dims = table.shape[1:]
            strides[name] = tuple(int(np.prod(dims[i + 1 :])) for i in range(len(dims)))
        return cls(flat, cumulative, strides)


def likelihood_weighted_sample(
    network: BayesNet,
    evidence: Mapping[str, Any],
    *,
    size: int | None = None,
    candidates: int = DEFAULT_CANDIDATES,
    rng: np.random.Generator,
    on_conflict: OnConflict = "error",
    record_labels: Sequence[Any] | None = None,
    grouped: bool = True,
    progress: bool = False,
) -> dict[str, np.ndarray]:
    """Draw one sample per record by likelihood weighting with ``candidates`` candidates.

    Parameters
    ----------
    network
        The network.
    evidence
        Variable -> state code per record (``-1`` where unobserved) [1]. Variables not
        listed are unobserved everywhere.
    size
        Number of records; needed only when ``evidence`` is empty.
    candidates
        Candidates per record, N in Chuang 2011 Sec. 3.3 [1]. More candidates bring the
        result closer to the exact posterior when evidence has unobserved ancestors.
    rng
        Random generator; the same seed gives the same samples.
    on_conflict
        ``"error"``: impossible evidence raises :class:`ImpossibleEvidenceError`.
        ``"relax"``: drop evidence variables one at a time, each time the one whose removal
        leaves the most probable remaining evidence (ties: the observation with the lowest
        prior marginal), until the evidence is possible; warn with
        :class:`EvidenceRelaxedWarning`.
    record_labels
        Record ids used in messages (default: positions).
    grouped
        Sample records that share an evidence pattern together (fast). False samples every
        record on its own; the result has the same distribution (reference for tests).
    progress
        Show a progress bar over evidence patterns.

    Returns
    -------
    dict
        Variable -> ``int16`` state code per record [1]; observed codes are unchanged
        unless relaxed.

    Raises
    ------
    EvidenceError
        Codes outside a variable's states, unknown variables, arrays of unequal length.
    ImpossibleEvidenceError
        Evidence with P(e) = 0 and ``on_conflict="error"``, or evidence so unlikely that
        no candidate had a positive weight after all redraw rounds.

    References
    ----------
    Chuang 2011, Sec. 3.3 (N candidates per record, one kept in proportion to likelihood).
    """
    if candidates < 1:
        raise EvidenceError(f"candidates={candidates}; expected a positive integer")
    if on_conflict not in ("error", "relax"):
        raise EvidenceError(f"on_conflict={on_conflict!r}; expected 'error' or 'relax'")
    matrix = _evidence_matrix(network, evidence, size)
    n = matrix.shape[0]
    labels = record_labels if record_labels is not None else range(n)
    if len(labels) != n:
        raise EvidenceError(f"{len(labels)} record labels for {n} records")
    out = np.empty_like(matrix)
    if n == 0:
        return {v: out[:, i] for i, v in enumerate(network.variables)}
    groups = _groups(matrix, grouped)
    patterns = [matrix[rows[0]] for rows in groups]
    patterns = _resolve_conflicts(network, patterns, groups, labels, on_conflict)
    tables = _Tables.of(network)
    with _progress_bar(progress, len(groups)) as advance:
        for rows, pattern in zip(groups, patterns, strict=True):
            observed = {
                v: int(pattern[i]) for i, v in enumerate(network.variables) if pattern[i] >= 0
            }
            values = _sample_pattern(
                network,
                tables,
                observed,
                len(rows),
                candidates,
                rng,
                labels=[labels[r] for r in rows[:5]],
            )
            for i, variable in enumerate(network.variables):
                out[rows, i] = values[variable]
            advance()
    return {v: out[:, i] for i, v in enumerate(network.variables)}


def _evidence_matrix(
    network: BayesNet, evidence: Mapping[str, Any], size: int | None
) -> np.ndarray:
    unknown = set(evidence) - set(network.variables)
    if unknown:
        raise EvidenceError(
            f"network {network.name!r}: evidence for unknown variables {sorted(unknown)}; "
            f"known: {', '.join(network.variables)}"
        )
    lengths = {len(np.asarray(codes)) for codes in evidence.values()}
    if size is not None:
        lengths.add(size)
    if len(lengths) > 1:
        raise EvidenceError(f"evidence arrays (and size) have different lengths {lengths}")
    n = lengths.pop() if lengths else 0
    matrix = np.full((n, len(network.variables)), MISSING, dtype=np.int16)
    for i, variable in enumerate(network.variables):
        if variable not in evidence:
            continue
        codes = np.asarray(evidence[variable])
        k = len(network.states[variable])
        if codes.size and (codes.min() < MISSING or codes.max() >= k):
            raise EvidenceError(
                f"evidence for {variable}: codes in [{codes.min()}, {codes.max()}]; expected "
                f"-1 (unobserved) or 0..{k - 1}"
            )
        matrix[:, i] = codes
    return matrix


def _groups(matrix: np.ndarray, grouped: bool) -> list[np.ndarray]:
    n = matrix.shape[0]
    if not grouped:
        return [np.array([i]) for i in range(n)]
    radix = matrix.max(axis=0).astype(np.int64) + 2  # states + the missing code
    if np.sum(np.log2(radix)) < 62:
        keys = np.zeros(n, dtype=np.int64)
        for column, base in zip(matrix.T, radix, strict=True):
            keys = keys * base + (column.astype(np.int64) + 1)
        _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    else:
        _, inverse, counts = np.unique(matrix, axis=0, return_inverse=True, return_counts=True)
    order = np.argsort(inverse.ravel(), kind="stable")
    return np.split(order, np.cumsum(counts)[:-1])


def _describe(network: BayesNet, observed: Mapping[str, int]) -> str:
    parts = []
    for variable, code in observed.items():
        field = network.field_of(variable)
        state = network.states[variable][code]
        parts.append(f"{field}={state} ({variable})" if field else f"{variable}={state}")
    return ", ".join(parts)


def _format_records(labels: Sequence[Any], count: int) -> str:
    shown = ", ".join(str(label) for label in labels[:5])
    return f"{count} record(s): {shown}{', ...' if count > 5 else ''}"


def relax_evidence(
    network: BayesNet, observed: Mapping[str, int]
) -> tuple[dict[str, int], list[str]]:
    """Drop evidence variables until the evidence is possible.

    Each step drops the variable whose removal leaves the most probable remaining
    evidence; ties go to the observation with the lowest prior marginal probability.

    Parameters
    ----------
    network
        The network.
    observed
        Variable -> observed state code; P(e) may be zero.

    Returns
    -------
    tuple
        The relaxed evidence and the dropped variables in the order dropped.
    """
    kept = dict(observed)
    dropped: list[str] = []
    while kept and evidence_probability(network, kept) == 0.0:

        def score(variable: str) -> tuple[float, float]:
            rest = {v: s for v, s in kept.items() if v != variable}
            prior = evidence_probability(network, {variable: kept[variable]})
            return (evidence_probability(network, rest), -prior)

        worst = max(kept, key=score)
        dropped.append(worst)
        del kept[worst]
    return kept, dropped


def _resolve_conflicts(
    network: BayesNet,
    patterns: list[np.ndarray],
    groups: list[np.ndarray],
    labels: Sequence[Any],
    on_conflict: OnConflict,
) -> list[np.ndarray]:
    impossible: list[int] = []
    for index, pattern in enumerate(patterns):
        observed = {v: int(pattern[i]) for i, v in enumerate(network.variables) if pattern[i] >= 0}
        if observed and evidence_probability(network, observed) == 0.0:
            impossible.append(index)
    if not impossible:
        return patterns
    patterns = list(patterns)
    total = sum(len(groups[i]) for i in impossible)
    all_records = [labels[r] for i in impossible for r in groups[i][:5]][:5]
    if on_conflict == "error":
        first = patterns[impossible[0]]
        observed = {v: int(first[i]) for i, v in enumerate(network.variables) if first[i] >= 0}
        _, dropped = relax_evidence(network, observed)
        culprit = ", ".join(f"{network.field_of(v) or v}" for v in dropped)
        raise ImpossibleEvidenceError(
            f"network {network.name!r}: impossible evidence (probability 0) in "
            f"{_format_records(all_records, total)}; first conflict: "
            f"{_describe(network, observed)}; dropping {culprit} would make it possible "
            "(use on_conflict='relax')"
        )
    summaries = []
    for index in impossible:
        pattern = patterns[index].copy()
        observed = {v: int(pattern[i]) for i, v in enumerate(network.variables) if pattern[i] >= 0}
        _, dropped = relax_evidence(network, observed)
        for variable in dropped:
            pattern[network.variables.index(variable)] = MISSING
        patterns[index] = pattern
        summaries.append(
            (
                len(groups[index]),
                f"{_describe(network, observed)} -> dropped "
                f"{', '.join(network.field_of(v) or v for v in dropped)}",
            )
        )
    summaries.sort(key=lambda item: -item[0])
    shown = "; ".join(f"{text} ({count} records)" for count, text in summaries[:3])
    warnings.warn(
        f"network {network.name!r}: relaxed impossible evidence in "
        f"{_format_records(all_records, total)} ({len(impossible)} evidence patterns; "
        f"most frequent: {shown}{'; ...' if len(summaries) > 3 else ''})",
        EvidenceRelaxedWarning,
        stacklevel=3,
    )
    return patterns


def _draw(
    tables: _Tables,
    variable: str,
    parents: Sequence[np.ndarray],
    n: int,
    rng: np.random.Generator,
) -> np.ndarray:
    config = _config_index(tables, variable, parents, n)
    cumulative = tables.cumulative[variable]
    u = rng.random(n)
    if cumulative.shape[1] == 1:
        return np.searchsorted(cumulative[:, 0], u, side="right").astype(np.int16)
    return (cumulative[:, config] <= u).sum(axis=0, dtype=np.int16)


def _config_index(
    tables: _Tables, variable: str, parents: Sequence[np.ndarray], n: int
) -> np.ndarray:
    config = np.zeros(n, dtype=np.int64)
    for stride, values in zip(tables.strides[variable], parents, strict=True):
        config += stride * values.astype(np.int64)
    return config


def _sample_pattern(
    network: BayesNet,
    tables: _Tables,
    observed: Mapping[str, int],
    m: int,
    candidates: int,
    rng: np.random.Generator,
    *,
    labels: Sequence[Any],
) -> dict[str, np.ndarray]:
    """Samples for ``m`` records that share the evidence ``observed``."""
    hidden_ancestors = network.ancestors(frozenset(observed)) - set(observed)
    weighted = [v for v in observed if set(network.parents[v]) & hidden_ancestors]
    values: dict[str, np.ndarray] = {}
    if (weighted and candidates > 1) or (weighted and _needs_weights(network, observed)):
        chosen = _choose_candidates(
            network,
            tables,
            observed,
            hidden_ancestors,
            weighted,
            m,
            candidates,
            rng,
            labels=labels,
        )
        values.update(chosen)
    for variable in network.variables:
        if variable in values:
            continue
        if variable in observed:
            values[variable] = np.full(m, observed[variable], dtype=np.int16)
            continue
        parents = [values[p] for p in network.parents[variable]]
        values[variable] = _draw(tables, variable, parents, m, rng)
    return values


def _needs_weights(network: BayesNet, observed: Mapping[str, int]) -> bool:
    """With one candidate, weights still matter when some draw can have weight zero."""
    return any(np.any(network.tables[v][observed[v]] == 0) for v in observed if network.parents[v])


def _choose_candidates(
    network: BayesNet,
    tables: _Tables,
    observed: Mapping[str, int],
    hidden_ancestors: set[str],
    weighted: Sequence[str],
    m: int,
    candidates: int,
    rng: np.random.Generator,
    *,
    labels: Sequence[Any],
) -> dict[str, np.ndarray]:
    """Weighted choice among ``candidates`` draws of the evidence's hidden ancestors."""
    order = [v for v in network.variables if v in hidden_ancestors]
    chosen = {v: np.empty(m, dtype=np.int16) for v in order}
    pending = np.arange(m)
    n_candidates = candidates
    for _ in range(MAX_REDRAW_ROUNDS + 1):
        chunk = max(1, CHUNK_CANDIDATES // n_candidates)
        failed = []
        for start in range(0, len(pending), chunk):
            rows = pending[start : start + chunk]
            draws, ok, pick = _weighted_draw(
                network, tables, observed, order, weighted, len(rows), n_candidates, rng
            )
            good = np.flatnonzero(ok)
            for variable in order:
                chosen[variable][rows[good]] = draws[variable][good, pick[good]]
            failed.append(rows[~ok])
        pending = np.concatenate(failed)
        if not pending.size:
            return chosen
        n_candidates *= 2
    probability = evidence_probability(network, observed)
    raise ImpossibleEvidenceError(
        f"network {network.name!r}: evidence {_describe(network, observed)} has probability "
        f"{probability:.3g}; no candidate had a positive weight for "
        f"{_format_records(list(labels), len(pending))} even with {n_candidates // 2} "
        "candidates; increase candidates or relax the evidence"
    )


def _weighted_draw(
    network: BayesNet,
    tables: _Tables,
    observed: Mapping[str, int],
    order: Sequence[str],
    weighted: Sequence[str],
    m: int,
    n_candidates: int,
    rng: np.random.Generator,
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    size = m * n_candidates
    values: dict[str, np.ndarray] = {}

    def value(variable: str) -> np.ndarray:
        if variable in observed:
            return np.full(size, observed[variable], dtype=np.int16)
        return values[variable]

    for variable in order:
        parents = [value(p) for p in network.parents[variable]]
        values[variable] = _draw(tables, variable, parents, size, rng)
    weight = np.ones(size)
    for variable in weighted:
        parents = [value(p) for p in network.parents[variable]]
        config = _config_index(tables, variable, parents, size)
        weight *= tables.flat[variable][observed[variable]][config]
    cumulative = np.cumsum(weight.reshape(m, n_candidates), axis=1)
    total = cumulative[:, -1]
    u = rng.random(m) * total
    pick = np.minimum((cumulative <= u[:, None]).sum(axis=1), n_candidates - 1)
    draws = {v: values[v].reshape(m, n_candidates) for v in order}
    return draws, total > 0, pick


class _progress_bar:
    """Context manager yielding an ``advance()`` callable; a no-op unless enabled."""

    def __init__(self, enabled: bool, total: int) -> None:
        self.enabled = enabled
        self.total = total
        self._progress: Any = None

    def __enter__(self) -> Any:
        if not self.enabled:
            return lambda: None
        from rich.console import Console
        from rich.progress import Progress

        self._progress = Progress(console=Console(stderr=True), transient=True)
        self._progress.__enter__()
        task = self._progress.add_task("sampling evidence patterns", total=self.total)
        return lambda: self._progress.advance(task)

    def __exit__(self, *exc: object) -> None:
        if self._progress is not None:
            self._progress.__exit__(*exc)


def encode_frame(
    network: BayesNet, frame: pd.DataFrame, *, labels: Sequence[Any] | None = None
) -> dict[str, np.ndarray]:
    """Evidence codes from the bound fields of ``frame`` (missing values: -1).

    Fields the frame lacks are unobserved everywhere.

    Raises
    ------
    EvidenceError
        A value matches no state of its variable (the message names field and records).
    """
    evidence = {}
    for variable, binding in network.bindings.items():
        if binding.field in frame:
            evidence[variable] = binding.encode(frame[binding.field], labels=labels)
    return evidence


def decode_samples(
    network: BayesNet, codes: Mapping[str, np.ndarray], index: pd.Index | None = None
) -> pd.DataFrame:
    """Bound fields of sampled ``codes`` as a DataFrame (hidden variables are left out)."""
    return pd.DataFrame(
        {binding.field: binding.decode(codes[v]) for v, binding in network.bindings.items()},
        index=index,
    )


def sampling_memory(network: BayesNet, records: int, candidates: int) -> float:
    """Estimated peak memory of :func:`likelihood_weighted_sample` [B].

    Candidates are drawn in chunks of about :data:`CHUNK_CANDIDATES` draws (at least one
    record's ``candidates`` draws); the variables drawn once per record need arrays over all
    records. Each draw holds an ``int16`` state per variable and, while a variable is drawn,
    its cumulative table gathered per draw (``float64`` per state), the comparison with the
    uniform number and a few ``float64``/``int64`` temporaries (weights, their cumulative
    sum, parent configurations).

    Parameters
    ----------
    network
        The network.
    records
        Number of records [1].
    candidates
        Candidates per record [1].

    Returns
    -------
    float
        Estimated peak memory [B]; the redraw rounds for rare evidence (up to
        :data:`MAX_REDRAW_ROUNDS` doublings of the candidates) are not included.

    Examples
    --------
    >>> from bayesnets.tables import parse_table
    >>> from bayesnets.network import build_network
    >>> net = build_network([parse_table("RAIN,weight\\nT,1\\nF,3")], {})
    >>> f"{sampling_memory(net, 1000, 10**9) / 2**30:.0f} GiB"
    '56 GiB'
    """
    if records <= 0:
        return 0.0
    variables = len(network.variables)
    states = max((len(network.states[v]) for v in network.variables), default=1)
    per_draw = 2 * variables + 9 * states + 40
    chunk_records = max(1, CHUNK_CANDIDATES // max(candidates, 1))
    draws = max(min(records, chunk_records) * float(candidates), float(records))
    return draws * per_draw + records * variables * 12.0


def sample_frame(
    network: BayesNet,
    frame: pd.DataFrame,
    *,
    candidates: int = DEFAULT_CANDIDATES,
    rng: np.random.Generator,
    on_conflict: OnConflict = "error",
    labels: Sequence[Any] | None = None,
    progress: bool = False,
) -> pd.DataFrame:
    """Sample every bound field of ``network`` for each row of ``frame``.

    Non-missing values of bound fields are the evidence.

    Parameters
    ----------
    network
        Network with field bindings.
    frame
        Records; bound fields may be absent or hold missing values.
    candidates
        Candidates per record [1] (see :func:`likelihood_weighted_sample`).
    rng
        Random generator.
    on_conflict
        ``"error"`` or ``"relax"`` (see :func:`likelihood_weighted_sample`).
    labels
        Record ids used in messages (default: the frame's index).
    progress
        Show a progress bar.

    Returns
    -------
    pandas.DataFrame
        One column per bound field, same index as ``frame``; observed fields hold the
        decoded state of their observation (e.g. a bin's representative value).

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from bayesnets.tables import parse_table
    >>> from bayesnets.network import build_network
    >>> net = build_network(
    ...     [parse_table("RAIN,weight\\nT,1\\nF,3"),
    ...      parse_table("WET,RAIN,weight\\nT,T,1\\nF,T,0\\nT,F,1\\nF,F,9")],
    ...     {"variables": {"RAIN": {"field": "rain", "kind": "bool"},
    ...                    "WET": {"field": "wet", "kind": "bool"}}})
    >>> out = sample_frame(net, pd.DataFrame({"wet": [False, None]}),
    ...                    rng=np.random.default_rng(0))
    >>> bool(out["rain"].iloc[0])  # a dry ground rules out rain
    False
    """
    labels = list(frame.index) if labels is None else labels
    evidence = encode_frame(network, frame, labels=labels)
    codes = likelihood_weighted_sample(
        network,
        evidence,
        size=len(frame),
        candidates=candidates,
        rng=rng,
        on_conflict=on_conflict,
        record_labels=labels,
        progress=progress,
    )
    return decode_samples(network, codes, index=frame.index)
