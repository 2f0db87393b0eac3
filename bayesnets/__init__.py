"""Discrete Bayesian networks held as folders of CSV tables (Chuang 2011, Sec. 3.3).

A network is a folder with one CSV table per variable (``VAR,PARENT1,...,weight``) and a
``network.toml`` that binds variables to DataFrame fields. :func:`read_network` validates
it, :func:`likelihood_weighted_sample` / :func:`sample_frame` fill missing values by
likelihood-weighted sampling, :func:`fit_network` estimates tables from data, and
:mod:`bayesnets.catalog` ships geo-typical street-lighting networks. The package does not
depend on ``nightlights``.
"""

from bayesnets.binding import MISSING, Binding
from bayesnets.catalog import catalog_names, default_network_name, load_network
from bayesnets.fit import fit_network
from bayesnets.inference import evidence_probability, exact_marginals
from bayesnets.network import BayesNet, build_network, read_network, write_network
from bayesnets.sampling import (
    DEFAULT_CANDIDATES,
    decode_samples,
    encode_frame,
    likelihood_weighted_sample,
    relax_evidence,
    sample_frame,
)
from bayesnets.tables import VariableTable, parse_table, read_table

__all__ = [
    "DEFAULT_CANDIDATES",
    "MISSING",
    "BayesNet",
    "Binding",
    "VariableTable",
    "build_network",
    "catalog_names",
    "decode_samples",
    "default_network_name",
    "encode_frame",
    "evidence_probability",
    "exact_marginals",
    "fit_network",
    "likelihood_weighted_sample",
    "load_network",
    "parse_table",
    "read_network",
    "read_table",
    "relax_evidence",
    "sample_frame",
    "write_network",
]
