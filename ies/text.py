"""Reading photometric text: byte decoding and a numeric token stream with line numbers.

Both LM-63 and EULUMDAT files come from many tools: UTF-8 or latin-1, CRLF or LF line ends,
values wrapped anywhere, separated by spaces or commas, decimals written ``.21``. This module
turns such text into tokens that remember the line they came from, so that a parse error can
name the file, the line and the token.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass

from ies.errors import PhotometryParseError

_SEPARATORS = re.compile(r"[,\s]+")
_WHITESPACE = re.compile(r"\s+")


def decode_photometric_bytes(data: bytes) -> str:
    """Decode the bytes of a photometric file: UTF-8 first, latin-1 if that fails.

    Parameters
    ----------
    data : bytes
        Raw file contents.

    Returns
    -------
    str
        Text with a leading byte-order mark removed.
    """
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    return text.removeprefix("\ufeff")


def read_text(path: str | os.PathLike[str]) -> str:
    """Read and decode a photometric file (see :func:`decode_photometric_bytes`).

    Parameters
    ----------
    path : str or os.PathLike
        File to read.

    Returns
    -------
    str
        The decoded text.
    """
    with open(path, "rb") as handle:
        return decode_photometric_bytes(handle.read())


@dataclass(frozen=True)
class Token:
    """One whitespace- or comma-separated word and the 1-based line it came from."""

    text: str
    line: int


def tokenize(lines: list[str], first_line: int, *, decimal_comma: bool = False) -> list[Token]:
    """Split lines into tokens, remembering line numbers.

    Parameters
    ----------
    lines : list of str
        Lines of text (no line ends).
    first_line : int
        1-based line number of ``lines[0]`` in the file [1].
    decimal_comma : bool
        Read ``,`` as a decimal mark (EULUMDAT, one value per line) instead of a separator.

    Returns
    -------
    list of Token
        Tokens in file order.
    """
    tokens = []
    separators = _WHITESPACE if decimal_comma else _SEPARATORS
    for offset, line in enumerate(lines):
        if decimal_comma:
            line = line.replace(",", ".")
        for word in separators.split(line.strip()):
            if word:
                tokens.append(Token(word, first_line + offset))
    return tokens


class TokenStream:
    """Numbers read one after another from a token list, with file/line-aware errors.

    Parameters
    ----------
    tokens : list of Token
        Tokens to read.
    source : str
        Name of the file, for error messages.
    """

    def __init__(self, tokens: list[Token], source: str) -> None:
        self._tokens = tokens
        self._position = 0
        self.source = source

    @property
    def remaining(self) -> int:
        """Number of tokens not read yet [1]."""
        return len(self._tokens) - self._position

    def peek(self) -> Token | None:
        """The next token without consuming it, None at end [1]."""
        return self._tokens[self._position] if self.remaining else None

    def last_line(self) -> int | None:
        """Line of the last token in the stream, None when empty."""
        return self._tokens[-1].line if self._tokens else None

    def error(self, message: str, token: Token | None = None) -> PhotometryParseError:
        """An error naming the file, the token's line and the token."""
        if token is None:
            return PhotometryParseError(message, source=self.source, line=self.last_line())
        return PhotometryParseError(message, source=self.source, line=token.line, token=token.text)

    def next_token(self, what: str) -> Token:
        """Consume one token; a truncated file raises :class:`PhotometryParseError`."""
        if not self.remaining:
            raise self.error(f"file ends early: expected {what}")
        token = self._tokens[self._position]
        self._position += 1
        return token

    def read_float(self, what: str) -> float:
        """Consume one finite number (``.21``, ``1e3``, ``3.0`` all accepted) [1]."""
        token = self.next_token(what)
        try:
            value = float(token.text)
        except ValueError:
            raise self.error(f"expected a number for {what}", token) from None
        if not math.isfinite(value):
            raise self.error(f"{what} must be finite", token)
        return value

    def read_int(self, what: str) -> int:
        """Consume one integer; ``3.0`` is accepted as 3, ``3.5`` is an error [1]."""
        token = self.next_token(what)
        try:
            value = float(token.text)
        except ValueError:
            raise self.error(f"expected an integer for {what}", token) from None
        if not math.isfinite(value) or value != int(value):
            raise self.error(f"expected an integer for {what}", token)
        return int(value)

    def read_floats(self, count: int, what: str) -> list[float]:
        """Consume ``count`` finite numbers [1]."""
        return [self.read_float(f"{what} (value {k + 1} of {count})") for k in range(count)]

    def last_token(self) -> Token | None:
        """The most recently consumed token [1]."""
        return self._tokens[self._position - 1] if self._position else None

    def token_at(self, index: int) -> Token:
        """The token at absolute position ``index`` [1]."""
        return self._tokens[index]

    @property
    def position(self) -> int:
        """Index of the next token [1]."""
        return self._position
