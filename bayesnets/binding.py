"""Binding of table columns (DataFrame fields) to network variables.

``network.toml`` says, per variable, which field holds its observed value and how values
and states translate. Kinds:

``category``
    The state is the field's string value.
``bool``
    States ``T`` and ``F`` (Chuang 2011, Fig. 10) for true and false values.
``int``
    State labels are integers. An observed value maps to the equal state, or to the
    nearest state when ``nearest = true``.
``float``
    State labels are numbers; as ``int`` otherwise.
``bins``
    A numeric observed value maps to the state whose interval ``[edges[i], edges[i+1])``
    contains it; a sampled state decodes to its representative value (``values``, or the
    label parsed as a number).

Variables without a field are hidden (intermediate) variables.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np
import pandas as pd

from bayesnets.errors import BindingError, EvidenceError

KINDS = ("category", "bool", "int", "float", "bins")

#: Code of an unobserved value in evidence arrays.
MISSING = -1


@dataclass(frozen=True)
class Binding:
    """How one variable reads and writes a DataFrame field.

    Attributes
    ----------
    variable
        Network variable.
    field
        DataFrame field (column) name.
    kind
        One of ``category``, ``bool``, ``int``, ``float``, ``bins``.
    states
        The variable's states, in table order.
    numbers
        Numeric value of each state (``int``, ``float``, ``bins``) [field unit].
    edges
        Interval edges of the states (``bins`` only), increasing, ``len(states) + 1``
        [field unit].
    nearest
        Map a numeric observed value that matches no state to the nearest state.
    """

    variable: str
    field: str
    kind: str
    states: tuple[str, ...]
    numbers: tuple[float, ...] = ()
    edges: tuple[float, ...] = ()
    nearest: bool = False

    def encode(
        self, values: Sequence[Any] | pd.Series, *, labels: Sequence[Any] | None = None
    ) -> np.ndarray:
        """State codes of observed ``values``; missing values (None, NaN, NA) give -1.

        Parameters
        ----------
        values
            Observed field values [field unit].
        labels
            Record labels used in error messages (default: positions).

        Returns
        -------
        numpy.ndarray
            ``int16`` state index per value, :data:`MISSING` where missing.

        Raises
        ------
        EvidenceError
            A value matches no state (unknown category, number outside the bins, number
            without an equal state and ``nearest`` off).
        """
        series = pd.Series(values, copy=False).reset_index(drop=True)
        missing = series.isna().to_numpy()
        codes = np.full(len(series), MISSING, dtype=np.int16)
        present = ~missing
        if not present.any():
            return codes
        observed = series[present]
        if self.kind in ("category", "bool"):
            if self.kind == "bool":
                observed = observed.map(_bool_state)
            lookup = {state: index for index, state in enumerate(self.states)}
            mapped = observed.astype(str).map(lookup)
            bad = mapped.isna().to_numpy()
            if bad.any():
                self._reject(observed[bad], labels, f"expected one of {list(self.states)}")
            codes[present] = mapped.to_numpy(dtype=np.int64)
            return codes
        numeric = pd.to_numeric(observed, errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(numeric)
        if bad.any():
            self._reject(observed[bad], labels, "expected a finite number")
        if self.kind == "bins":
            edges = np.asarray(self.edges)
            index = np.searchsorted(edges, numeric, side="right") - 1
            bad = (index < 0) | (index >= len(self.states))
            if bad.any():
                self._reject(
                    observed[bad], labels, f"expected a value in [{edges[0]}, {edges[-1]})"
                )
            codes[present] = index
            return codes
        numbers = np.asarray(self.numbers)
        distance = np.abs(numeric[:, None] - numbers[None, :])
        index = np.argmin(distance, axis=1)  # ties go to the first (table order) state
        exact = distance[np.arange(len(index)), index] <= 1e-9 * np.maximum(1.0, np.abs(numeric))
        if not self.nearest and not exact.all():
            self._reject(
                observed[~exact],
                labels,
                f"expected one of {list(self.states)} (set nearest = true to round)",
            )
        codes[present] = index
        return codes

    def decode(self, codes: np.ndarray) -> np.ndarray:
        """Field values of state ``codes`` (all codes must be valid states).

        Returns
        -------
        numpy.ndarray
            ``object`` strings (``category``), ``bool``, ``int64`` (``int``) or
            ``float64`` (``float``, ``bins``: the representative value) [field unit].
        """
        codes = np.asarray(codes)
        if self.kind == "category":
            return np.asarray(self.states, dtype=object)[codes]
        if self.kind == "bool":
            return np.asarray([state == "T" for state in self.states], dtype=bool)[codes]
        if self.kind == "int":
            return np.asarray(self.numbers, dtype=np.int64)[codes]
        return np.asarray(self.numbers, dtype=float)[codes]

    def _reject(self, bad: pd.Series, labels: Sequence[Any] | None, expected: str) -> None:
        positions = list(bad.index[:5])
        names = [labels[p] for p in positions] if labels is not None else positions
        shown = ", ".join(
            f"{name}: {value!r}" for name, value in zip(names, bad.iloc[:5], strict=True)
        )
        raise EvidenceError(
            f"field {self.field!r} (variable {self.variable}): {len(bad)} value(s) match no "
            f"state (records {shown}{', ...' if len(bad) > 5 else ''}); {expected}"
        )


def _bool_state(value: Any) -> str:
    if isinstance(value, str):
        word = value.strip().lower()
        if word in ("t", "true", "yes", "y", "1"):
            return "T"
        if word in ("f", "false", "no", "n", "0"):
            return "F"
        return value
    return "T" if bool(value) else "F"


def parse_binding(
    variable: str, spec: Mapping[str, Any], states: Sequence[str], *, source: str
) -> Binding:
    """Check one ``[variables.NAME]`` entry of ``network.toml`` and build its binding.

    Parameters
    ----------
    variable
        Variable name.
    spec
        The entry: ``field``, ``kind`` and, by kind, ``nearest``, ``edges``, ``values``.
    states
        The variable's states from its table.
    source
        ``network.toml`` path, used in error messages.

    Raises
    ------
    BindingError
        Unknown kind, state labels that do not parse as the kind demands, bins whose
        edges or values do not match the states.
    """
    where = f"{source}, [variables.{variable}]"
    unknown = set(spec) - {"field", "kind", "nearest", "edges", "values", "description", "unit"}
    if unknown:
        raise BindingError(f"{where}: unknown keys {sorted(unknown)}")
    field = spec.get("field")
    if not isinstance(field, str) or not field:
        raise BindingError(f"{where}: 'field' must be a non-empty string, got {field!r}")
    kind = spec.get("kind", "category")
    if kind not in KINDS:
        raise BindingError(f"{where}: kind {kind!r}; expected one of {', '.join(KINDS)}")
    states = tuple(states)
    nearest = bool(spec.get("nearest", False))
    if kind == "category":
        return Binding(variable, field, kind, states)
    if kind == "bool":
        if not set(states) <= {"T", "F"}:
            raise BindingError(f"{where}: bool variable has states {list(states)}; expected T, F")
        return Binding(variable, field, kind, states)
    if kind in ("int", "float"):
        numbers = tuple(_state_number(state, where, kind) for state in states)
        return Binding(variable, field, kind, states, numbers=numbers, nearest=nearest)
    edges = _numbers(spec.get("edges", ()), where, "edges")
    if len(edges) != len(states) + 1 or any(not b > a for a, b in pairwise(edges)):
        raise BindingError(
            f"{where}: bins need {len(states) + 1} increasing edges for states "
            f"{list(states)}, got {list(edges)}"
        )
    if "values" in spec:
        numbers = _numbers(spec["values"], where, "values")
        if not all(np.isfinite(numbers)):
            raise BindingError(f"{where}: values {list(numbers)} must be finite numbers")
        if len(numbers) != len(states):
            raise BindingError(
                f"{where}: {len(numbers)} values for {len(states)} states {list(states)}"
            )
    else:
        numbers = tuple(_state_number(state, where, "bins") for state in states)
    return Binding(variable, field, kind, states, numbers=numbers, edges=edges)


def _numbers(values: Any, where: str, key: str) -> tuple[float, ...]:
    """``values`` as floats (a list of numbers), or a :class:`BindingError` naming ``key``."""
    if not isinstance(values, list | tuple) or not all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in values
    ):
        raise BindingError(f"{where}: {key} = {values!r}; expected a list of numbers")
    return tuple(float(v) for v in values)


def _state_number(state: str, where: str, kind: str) -> float:
    try:
        number = float(state)
    except ValueError:
        raise BindingError(
            f"{where}: state {state!r} is not a number; a {kind} variable needs numeric "
            "state labels" + (" (or 'values')" if kind == "bins" else "")
        ) from None
    if not np.isfinite(number):
        raise BindingError(f"{where}: state {state!r} is not a finite number")
    if kind == "int" and number != int(number):
        raise BindingError(f"{where}: state {state!r} is not an integer")
    return number
