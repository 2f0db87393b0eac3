"""Exceptions and warnings of the ies photometry package (independent of nightlights)."""

from __future__ import annotations


class PhotometryError(ValueError):
    """Root of every error the ies package raises on purpose."""


class PhotometryWarning(UserWarning):
    """Root of the package's warnings (e.g. declared and integrated lumens disagree)."""
