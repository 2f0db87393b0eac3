"""Strict JSON: every JSON the toolkit writes parses with any JSON parser.

Python's :mod:`json` writes ``NaN``, ``Infinity`` and ``-Infinity`` by default, which RFC 8259
does not allow and strict parsers (browsers' ``JSON.parse``, Go, Rust's serde, ``jq``)
refuse. Here a value that is not a finite number becomes ``null``, and the object that held it
says why in a sibling key ``<key>_null_reason`` (for a list, one reason naming the items), so
that a null never passes for a missing value. :func:`dumps_json` then writes with
``allow_nan=False``: a non-finite number that slipped through is an error, not a file.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

__all__ = ["NULL_REASON_SUFFIX", "dumps_json", "json_ready", "non_finite_reason"]

#: Suffix of the key that says why its sibling is null.
NULL_REASON_SUFFIX = "_null_reason"

#: Why a value is null: given the key that held it and the value [any unit].
Reason = Callable[[str, float], str]


def non_finite_reason(key: str, value: float) -> str:
    """The default reason: which non-finite value it was (strict JSON has none).

    Parameters
    ----------
    key
        The key that held the value.
    value
        The value: NaN, +inf or -inf.

    Examples
    --------
    >>> non_finite_reason("ratio", float("inf"))
    'ratio was +inf, which strict JSON cannot hold'
    """
    shown = "NaN" if math.isnan(value) else ("+inf" if value > 0 else "-inf")
    return f"{key} was {shown}, which strict JSON cannot hold"


def json_ready(value: Any, *, reason: Reason = non_finite_reason) -> Any:
    """A copy of ``value`` that strict JSON can hold: non-finite numbers as None, explained.

    Parameters
    ----------
    value
        Nested dicts, lists, tuples, numbers (numpy's too), strings, booleans, None.
    reason
        Why a value at a key is null (default :func:`non_finite_reason`).

    Returns
    -------
    Any
        The same structure with numpy scalars and arrays as Python values, each non-finite
        number as None and, in the dict that held it, ``<key>_null_reason``.

    Examples
    --------
    >>> json_ready({"after_mag": float("inf"), "flux": [1.0, float("nan")]})
    {'after_mag': None, 'after_mag_null_reason': 'after_mag was +inf, which strict JSON cannot \
hold', 'flux': [1.0, None], 'flux_null_reason': 'item 1: flux was NaN, which strict JSON cannot \
hold'}
    """
    converted, _ = _convert(value, "value", reason)
    return converted


def dumps_json(value: Any, *, reason: Reason = non_finite_reason, **options: Any) -> str:
    """``value`` as strict JSON text (:func:`json_ready`, then ``allow_nan=False``).

    Parameters
    ----------
    value
        What to write.
    reason
        Why a value at a key is null (default :func:`non_finite_reason`).
    **options
        Passed to :func:`json.dumps` (``indent``, ``default``, ``sort_keys``...).

    Returns
    -------
    str
        JSON text without ``NaN`` or ``Infinity``.

    Examples
    --------
    >>> dumps_json({"x": 1.5, "y": float("-inf")})
    '{"x": 1.5, "y": null, "y_null_reason": "y was -inf, which strict JSON cannot hold"}'
    """
    default = options.pop("default", None)
    ready = json_ready(value, reason=reason)
    if default is not None:
        # what only ``default`` can turn into JSON is converted first, then checked again
        ready = json_ready(json.loads(json.dumps(ready, default=default)), reason=reason)
    return json.dumps(ready, allow_nan=False, **options)


def _convert(value: Any, key: str, reason: Reason) -> tuple[Any, str | None]:
    """The JSON-ready value and, when it is null for being non-finite (or a list holding
    such), the reason."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool) or value is None or isinstance(value, str | int):
        return value, None
    if isinstance(value, float):
        return (value, None) if math.isfinite(value) else (None, reason(key, value))
    if isinstance(value, Mapping):
        out: dict[Any, Any] = {}
        for name, item in value.items():
            converted, why = _convert(item, str(name), reason)
            out[name] = converted
            if why is not None and f"{name}{NULL_REASON_SUFFIX}" not in value:
                out[f"{name}{NULL_REASON_SUFFIX}"] = why
        return out, None
    if isinstance(value, list | tuple):
        items = []
        notes = []
        for index, item in enumerate(value):
            converted, why = _convert(item, key, reason)
            items.append(converted)
            if why is not None:
                notes.append(f"item {index}: {why}")
        shown = "; ".join(notes[:3]) + (f"; and {len(notes) - 3} more" if len(notes) > 3 else "")
        return items, shown or None
    return value, None
