"""Exceptions and warnings of the bayesnets package (independent of nightlights).

Every message names the file (and line, where there is one), the bad value and what was
expected, so that a command-line front end can print it on one line.
"""

from __future__ import annotations


class BayesNetError(ValueError):
    """Root of every error the bayesnets package raises on purpose."""


class NetworkDefinitionError(BayesNetError):
    """A network's CSV tables are malformed: cycles, missing rows, inconsistent states."""


class TableFormatError(NetworkDefinitionError):
    """A CSV table cannot be parsed: bad header, wrong column count, duplicate rows."""


class InvalidWeightError(NetworkDefinitionError):
    """A weight is negative, not finite, or not a number."""


class UnknownParentError(NetworkDefinitionError):
    """A table names a parent variable that has no table of its own."""


class CyclicNetworkError(NetworkDefinitionError):
    """The parent relation of the tables contains a cycle."""


class InconsistentStatesError(NetworkDefinitionError):
    """A table uses a parent state that the parent's own table does not define."""


class MissingParentCombinationError(NetworkDefinitionError):
    """A combination of parent states has no row with a positive weight."""


class BindingError(NetworkDefinitionError):
    """``network.toml`` is malformed or binds fields inconsistently with the tables."""


class EvidenceError(BayesNetError):
    """An observed value cannot be mapped onto a state of its variable."""


class ImpossibleEvidenceError(BayesNetError):
    """Evidence has zero probability under the network."""


class CatalogError(BayesNetError):
    """A catalogue network name is unknown."""


class BayesNetWarning(UserWarning):
    """Root of the package's warnings."""


class EvidenceRelaxedWarning(BayesNetWarning):
    """Impossible evidence was relaxed by dropping observed variables."""


class FitWarning(BayesNetWarning):
    """A table could not be estimated from the data and was kept from the base network."""
