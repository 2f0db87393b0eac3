"""Exceptions and warnings of the ies photometry package (independent of nightlights)."""

from __future__ import annotations


class PhotometryError(ValueError):
    """Root of every error the ies package raises on purpose."""


class PhotometryParseError(PhotometryError):
    """A photometric file is malformed.

    Parameters
    ----------
    message : str
        What is wrong and what was expected.
    source : str
        File name (or ``"<string>"``) the text came from.
    line : int or None
        1-based line number of the offending token, None when unknown [1].
    token : str or None
        The offending token as it appears in the file, None at end of file.
    """

    def __init__(
        self, message: str, *, source: str, line: int | None = None, token: str | None = None
    ) -> None:
        self.source = source
        self.line = line
        self.token = token
        where = source if line is None else f"{source}, line {line}"
        shown = "" if token is None else f" (token {token!r})"
        super().__init__(f"{where}: {message}{shown}")


class LuminaireDatabaseError(PhotometryError):
    """The luminaire database (``systems.toml``) is malformed or names an unknown system."""


class PhotometryWarning(UserWarning):
    """Root of the package's warnings (e.g. declared and integrated lumens disagree)."""


class FluxMismatchWarning(PhotometryWarning):
    """Declared lumens and the integral of the candela distribution differ by more than 5 %."""
