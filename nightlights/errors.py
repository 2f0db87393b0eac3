"""Exceptions and warnings of the nightlights toolkit.

One root, :class:`NightlightsError`, with a subclass per kind of failure. Every message
names the file, the feature or line, the bad value and what was expected, so that the
CLI can print it on one line.
"""

from __future__ import annotations


class NightlightsError(Exception):
    """Root of every error the toolkit raises on purpose."""


class InputError(NightlightsError, ValueError):
    """An input file or value is missing, unreadable or malformed."""


class CRSError(InputError):
    """A layer has no coordinate reference system, or one that cannot be used."""


class EmptyInputError(InputError):
    """An input layer holds no usable features."""


class MappingError(InputError):
    """A field mapping (``streets normalize --mapping``) is malformed."""


class OutputError(NightlightsError, OSError):
    """An output could not be written."""


class OutputExistsError(OutputError, FileExistsError):
    """An output exists and replacing it was not asked for."""


class ResourceError(NightlightsError, MemoryError):
    """A computation would need more memory (or disk) than allowed."""


class NightlightsWarning(UserWarning):
    """Root of the toolkit's warnings."""


class DataQualityWarning(NightlightsWarning):
    """Input data were usable but suspicious (dropped features, unknown values)."""
