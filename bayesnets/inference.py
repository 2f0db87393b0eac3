"""Exact inference: probability of evidence (numpy) and marginals (pgmpy).

:func:`evidence_probability` sums the joint distribution over the ancestors of the
evidence only (the other variables sum to one and drop out), as one ``numpy.einsum``
contraction. It is used to tell impossible evidence from unlucky candidate draws and to
choose which evidence to relax. :func:`exact_marginals` runs pgmpy's variable
elimination and is the reference the sampler is validated against.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from bayesnets.network import BayesNet


def evidence_probability(network: BayesNet, evidence: Mapping[str, int]) -> float:
    """Probability of the evidence, P(e), under ``network``.

    Parameters
    ----------
    network
        The network.
    evidence
        Variable -> observed state index.

    Returns
    -------
    float
        P(e) [1]; 1 for empty evidence.

    Notes
    -----
    .. math:: P(e) = \\sum_{x_A} \\prod_{v \\in A \\cup E} P(x_v \\mid x_{pa(v)})

    with A the unobserved ancestors of the evidence E; descendants that are not evidence
    are barren and sum out to one.
    """
    if not evidence:
        return 1.0
    relevant = network.ancestors(frozenset(evidence))
    letters = {name: _letter(i) for i, name in enumerate(sorted(relevant))}
    operands: list[np.ndarray] = []
    subscripts: list[str] = []
    for name in network.variables:
        if name not in relevant:
            continue
        family = (name, *network.parents[name])
        table = network.tables[name]
        index: list[int | slice] = []
        kept = []
        for variable in family:
            if variable in evidence:
                index.append(int(evidence[variable]))
            else:
                index.append(slice(None))
                kept.append(letters[variable])
        operands.append(np.asarray(table[tuple(index)]))
        subscripts.append("".join(kept))
    expression = ",".join(subscripts) + "->"
    return float(np.einsum(expression, *operands, optimize="greedy"))


def _letter(index: int) -> str:
    alphabet = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
    if index >= len(alphabet):
        raise ValueError("evidence_probability supports up to 52 relevant variables")
    return alphabet[index]


def exact_marginals(
    network: BayesNet,
    evidence: Mapping[str, int] | None = None,
    variables: Iterable[str] | None = None,
) -> dict[str, np.ndarray]:
    """Posterior marginal of each variable given evidence, by pgmpy variable elimination.

    Parameters
    ----------
    network
        The network.
    evidence
        Variable -> observed state index.
    variables
        Variables to report (default: every unobserved variable).

    Returns
    -------
    dict
        Variable -> probability of each state, in the network's state order [1].
    """
    from pgmpy.inference import VariableElimination

    evidence = dict(evidence or {})
    engine = VariableElimination(network.to_pgmpy())
    named = {v: network.states[v][i] for v, i in evidence.items()}
    wanted = [v for v in (variables or network.variables) if v not in evidence]
    result = {}
    for variable in wanted:
        factor = engine.query([variable], evidence=named or None, show_progress=False)
        order = [factor.state_names[variable].index(s) for s in network.states[variable]]
        result[variable] = np.asarray(factor.values)[order]
    return result
