"""Exceptions of the bayesnets package (independent of nightlights)."""

from __future__ import annotations


class BayesNetError(ValueError):
    """Root of every error the bayesnets package raises on purpose."""


class NetworkDefinitionError(BayesNetError):
    """A network's CSV tables are malformed: cycles, missing rows, inconsistent states."""


class ImpossibleEvidenceError(BayesNetError):
    """Evidence has zero probability under the network."""


class BayesNetWarning(UserWarning):
    """Root of the package's warnings."""
