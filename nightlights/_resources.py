"""Memory bounds: how much a stage may allocate, and a check every stage makes before it does.

Each stage estimates its output size and working memory from its options before it allocates,
and calls :func:`check_memory`; an estimate over the limit is refused with a
:class:`~nightlights.errors.ResourceError` that states the estimate, the limit and the option
that lowers the need. The limit is, in order of precedence, the value given to
:func:`set_memory_limit` (the CLI's ``--max-memory``), the environment variable
``NIGHTLIGHTS_MAX_MEMORY``, or half the memory available to the process (the machine's
physical memory, or less where a control group or ``RLIMIT_AS`` caps the process).

Sizes are written as plain bytes (``"2000000000"``, ``"2e9"``) or with a binary unit
(``"500M"``, ``"8G"``, ``"8GiB"``, ``"1.5T"``; K, M, G, T, P, E are powers of 1024).

Examples
--------
>>> parse_size("8G")
8589934592
>>> format_bytes(7.4e9)
'6.9 GiB'
"""

from __future__ import annotations

import logging
import math
import os
import re
from pathlib import Path

from nightlights.errors import InputError, ResourceError

__all__ = [
    "ENVIRONMENT_VARIABLE",
    "check_memory",
    "format_bytes",
    "memory_limit",
    "parse_size",
    "set_memory_limit",
]

#: Environment variable that sets the memory limit (same syntax as ``--max-memory``).
ENVIRONMENT_VARIABLE = "NIGHTLIGHTS_MAX_MEMORY"

#: Fraction of the available memory allowed by default [1].
DEFAULT_FRACTION = 0.5

_UNITS = {"": 0, "K": 1, "M": 2, "G": 3, "T": 4, "P": 5, "E": 6}
_SIZE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([KMGTPE]?)(?:I?B)?\s*$", re.I)
_CGROUP_LIMITS = (
    Path("/sys/fs/cgroup/memory.max"),  # cgroup v2
    Path("/sys/fs/cgroup/memory/memory.limit_in_bytes"),  # cgroup v1
)

#: A parameter named in a hint (``n_distance=``), as opposed to a phrase.
_PARAMETER = re.compile(r"[a-z_][a-z0-9_]*=")

_override: int | None = None

log = logging.getLogger(__name__)


def parse_size(text: str | int | float, *, source: str = "size") -> int:
    """Parse a memory size such as ``"8G"``, ``"500M"``, ``"2e9"`` or ``4096`` into bytes.

    Parameters
    ----------
    text
        Plain bytes, or a number followed by K, M, G, T, P or E (powers of 1024), optionally
        followed by ``B`` or ``iB``.
    source
        Where the value came from, for the error message (``"memory limit"``).

    Returns
    -------
    int
        The size [B], at least 1.

    Raises
    ------
    InputError
        The text is not a size, or it is zero, negative, not finite or absurdly large.

    Examples
    --------
    >>> parse_size("500M")
    524288000
    >>> parse_size("2e9")
    2000000000
    """
    if isinstance(text, bool):
        raise InputError(f"{source} {text!r}: expected a size such as 8G, 500M or 2e9 bytes")
    if isinstance(text, (int, float)):
        value = float(text)
    else:
        match = _SIZE.match(str(text))
        if match is None:
            raise InputError(f"{source} {text!r}: expected a size such as 8G, 500M or 2e9 bytes")
        value = float(match.group(1)) * 1024.0 ** _UNITS[match.group(2).upper()]
    if not math.isfinite(value) or value < 1 or value >= 2.0**63:
        raise InputError(
            f"{source} {text!r}: expected a size of at least 1 byte and below 8 EiB "
            "(such as 8G, 500M or 2e9)"
        )
    return int(value)


def format_bytes(n: float) -> str:
    """A byte count in binary units with one decimal: ``'512 B'``, ``'6.9 GiB'``.

    Parameters
    ----------
    n
        Number of bytes [B].

    Returns
    -------
    str
        The size for a message.

    Examples
    --------
    >>> format_bytes(512)
    '512 B'
    >>> format_bytes(4 * 1024**3)
    '4.0 GiB'
    >>> format_bytes(2.2e13)
    '20.0 TiB'
    """
    if not math.isfinite(n):
        return f"{n} B"
    size = float(n)
    if abs(size) < 1024:
        return f"{size:.0f} B"
    for unit in ("KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        size /= 1024.0
        if abs(size) < 1024 or unit == "EiB":
            break
    return f"{size:.1f} {unit}"


def available_memory() -> int:
    """Memory available to this process [B]: physical memory, capped by cgroup and RLIMIT_AS.

    Physical memory comes from psutil when it is installed, else from ``os.sysconf``.
    """
    candidates = [_physical_memory()]
    candidates.extend(_cgroup_limits())
    candidates.extend(_address_space_limit())
    return min(candidates)


def _physical_memory() -> int:
    try:
        import psutil
    except ImportError:  # pragma: no cover - psutil comes with distributed
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    return int(psutil.virtual_memory().total)


def _cgroup_limits() -> list[int]:
    limits = []
    for path in _CGROUP_LIMITS:
        try:
            text = path.read_text().strip()
        except OSError:
            continue
        if text.isdigit() and 0 < int(text) < 2**62:
            limits.append(int(text))
    return limits


def _address_space_limit() -> list[int]:
    try:
        import resource
    except ImportError:  # pragma: no cover - Windows
        return []
    soft, _hard = resource.getrlimit(resource.RLIMIT_AS)
    return [] if soft == resource.RLIM_INFINITY or soft <= 0 else [int(soft)]


def memory_limit() -> int:
    """The memory a stage may use [B].

    In order of precedence: the value given to :func:`set_memory_limit`, the environment
    variable ``NIGHTLIGHTS_MAX_MEMORY``, or half the memory available to the process.

    Raises
    ------
    InputError
        ``NIGHTLIGHTS_MAX_MEMORY`` is set but is not a size.
    """
    if _override is not None:
        return _override
    text = os.environ.get(ENVIRONMENT_VARIABLE, "").strip()
    if text:
        return parse_size(text, source=ENVIRONMENT_VARIABLE)
    return int(available_memory() * DEFAULT_FRACTION)


def set_memory_limit(value: int | str | None) -> None:
    """Set the memory limit for this process (the CLI's ``--max-memory``); None resets it.

    Parameters
    ----------
    value
        A size [B] or its text (``"8G"``), or None to fall back to ``NIGHTLIGHTS_MAX_MEMORY``
        or the default.

    Raises
    ------
    InputError
        ``value`` is not a size.
    """
    global _override
    _override = None if value is None else parse_size(value, source="memory limit")


def check_memory(estimate: float, what: str, *, option: str | None = None) -> None:
    """Refuse a computation whose memory estimate exceeds :func:`memory_limit`.

    Parameters
    ----------
    estimate
        Estimated peak memory of the computation (output plus working arrays) [B].
    what
        What needs it, to start the message (``"the irradiance raster of 80000 x 80000
        cells"``).
    option
        How the user lowers the need: a parameter (``"n_distance="``, shown as "lower
        n_distance=") or a phrase used as it is (``"use a coarser resolution="``).

    Raises
    ------
    ResourceError
        The estimate is above the limit (or not finite), with a message that states both and
        how to lower the need or raise the limit.

    Examples
    --------
    >>> set_memory_limit("4G")
    >>> check_memory(1e9, "a small table")
    >>> check_memory(7.4e9, "the kernel table", option="n_distance=")
    Traceback (most recent call last):
    ...
    nightlights.errors.ResourceError: the kernel table needs about 6.9 GiB, more than the \
4.0 GiB allowed; lower n_distance= or raise the limit with NIGHTLIGHTS_MAX_MEMORY
    >>> set_memory_limit(None)
    """
    if math.isfinite(estimate) and estimate <= 0:
        return
    limit = memory_limit()
    # the estimate each stage checks, for ``-v`` and for the benchmark that charts it against
    # the measured peak (benchmarks/bench_memory_estimates.py)
    log.debug("memory estimate: %s needs %.0f B (limit %d B)", what, estimate, limit)
    if math.isfinite(estimate) and estimate <= limit:
        return
    need = (
        f"about {format_bytes(estimate)}"
        if math.isfinite(estimate)
        else "an unbounded amount of memory"
    )
    hint = ""
    if option:
        hint = f"lower {option} or " if _PARAMETER.fullmatch(option) else f"{option} or "
    raise ResourceError(
        f"{what} needs {need}, more than the {format_bytes(limit)} allowed; "
        f"{hint}raise the limit with {ENVIRONMENT_VARIABLE}"
    )
