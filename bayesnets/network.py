"""A discrete Bayesian network held as a folder of CSV tables plus ``network.toml``.

The folder holds one CSV table per variable (see :mod:`bayesnets.tables`) and an optional
``network.toml``::

    name = "europe"
    description = "..."
    default = true

    [metadata]
    region = "Europe"

    [variables.WIDTH]
    field = "width"
    kind = "bins"
    edges = [0, 4.75, 6.75, 8.75, 12, 17.5, inf]

Loading validates the tables against each other (parents exist, no cycle, parent states
are the parents' own states, every parent combination has a positive weight) and
normalises each table per parent combination (Chuang 2011, Sec. 3.3).
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np

from bayesnets.binding import Binding, parse_binding
from bayesnets.errors import (
    BindingError,
    CyclicNetworkError,
    InconsistentStatesError,
    MissingParentCombinationError,
    NetworkDefinitionError,
    TableFormatError,
    UnknownParentError,
)
from bayesnets.tables import TableRow, VariableTable, format_table, read_table

CONFIG_NAME = "network.toml"


@dataclass(frozen=True, eq=False)
class BayesNet:
    """A validated discrete Bayesian network.

    Attributes
    ----------
    name
        Network name.
    variables
        Variable names in a topological order (parents before children).
    states
        Variable -> its states, in table order.
    parents
        Variable -> its parents, in table header order.
    tables
        Variable -> conditional probabilities, shape ``(n_states, *parent_n_states)``,
        summing to one along axis 0 [1].
    bindings
        Variable -> field binding; hidden variables have none.
    description
        Free text.
    default
        Whether this is the default network of a catalogue.
    metadata
        Free-form metadata from ``network.toml``.
    source
        Folder the network was read from, if any.
    """

    name: str
    variables: tuple[str, ...]
    states: Mapping[str, tuple[str, ...]]
    parents: Mapping[str, tuple[str, ...]]
    tables: Mapping[str, np.ndarray]
    bindings: Mapping[str, Binding] = field(default_factory=dict)
    description: str = ""
    default: bool = False
    metadata: Mapping[str, Any] = field(default_factory=dict)
    source: Path | None = None

    def __repr__(self) -> str:
        return f"BayesNet({self.name!r}, {len(self.variables)} variables)"

    @cached_property
    def children(self) -> dict[str, tuple[str, ...]]:
        """Variable -> the variables that have it as a parent."""
        return {
            name: tuple(child for child in self.variables if name in self.parents[child])
            for name in self.variables
        }

    def field_of(self, variable: str) -> str | None:
        """Field bound to ``variable``, or None for a hidden variable."""
        binding = self.bindings.get(variable)
        return binding.field if binding else None

    def ancestors(self, variables: set[str] | frozenset[str]) -> set[str]:
        """``variables`` and all their ancestors."""
        found: set[str] = set()
        stack = list(variables)
        while stack:
            name = stack.pop()
            if name not in found:
                found.add(name)
                stack.extend(self.parents[name])
        return found

    def to_pgmpy(self) -> Any:
        """The network as a pgmpy ``DiscreteBayesianNetwork`` with ``TabularCPD`` s."""
        from pgmpy.factors.discrete import TabularCPD
        from pgmpy.models import DiscreteBayesianNetwork

        model = DiscreteBayesianNetwork()
        model.add_nodes_from(self.variables)
        model.add_edges_from(
            (parent, child) for child in self.variables for parent in self.parents[child]
        )
        cpds = []
        for name in self.variables:
            parents = list(self.parents[name])
            table = self.tables[name]
            cpds.append(
                TabularCPD(
                    name,
                    len(self.states[name]),
                    table.reshape(table.shape[0], -1),
                    evidence=parents or None,
                    evidence_card=[len(self.states[p]) for p in parents] or None,
                    state_names={v: list(self.states[v]) for v in (name, *parents)},
                )
            )
        model.add_cpds(*cpds)
        model.check_model()
        return model


def read_network(path: str | os.PathLike[str]) -> BayesNet:
    """Read and validate a network folder.

    Parameters
    ----------
    path
        Folder holding one ``*.csv`` table per variable and optionally ``network.toml``.

    Returns
    -------
    BayesNet
        The validated network, tables normalised per parent combination.

    Raises
    ------
    NetworkDefinitionError
        The folder is missing or holds no table; or a subclass for malformed tables
        (see :func:`build_network`).

    References
    ----------
    Chuang 2011, Sec. 3.3 (networks as folders of CSV tables).
    """
    folder = Path(path)
    if not folder.is_dir():
        raise NetworkDefinitionError(f"{folder}: not a network folder")
    files = sorted(folder.glob("*.csv"))
    if not files:
        raise NetworkDefinitionError(f"{folder}: no *.csv tables in the network folder")
    tables = [read_table(file) for file in files]
    config_path = folder / CONFIG_NAME
    config: dict[str, Any] = {}
    if config_path.exists():
        try:
            config = tomllib.loads(config_path.read_text(encoding="utf-8"))
        except tomllib.TOMLDecodeError as exc:
            raise BindingError(f"{config_path}: not valid TOML: {exc}") from exc
    return build_network(
        tables, config, name=folder.name, config_source=str(config_path), source=folder
    )


def build_network(
    tables: list[VariableTable],
    config: Mapping[str, Any] | None = None,
    *,
    name: str = "network",
    config_source: str = CONFIG_NAME,
    source: Path | None = None,
) -> BayesNet:
    """Validate parsed tables and a ``network.toml`` mapping; build a :class:`BayesNet`.

    Parameters
    ----------
    tables
        One parsed table per variable.
    config
        Parsed ``network.toml`` (``name``, ``description``, ``default``, ``metadata``,
        ``variables``); None for a network without bindings.
    name
        Name used when ``config`` gives none.
    config_source
        Path of ``network.toml``, used in error messages.
    source
        Folder the tables came from.

    Raises
    ------
    TableFormatError
        Two tables define the same variable.
    UnknownParentError
        A parent has no table.
    CyclicNetworkError
        The parent relation has a cycle (the message names it).
    InconsistentStatesError
        A row uses a parent state the parent's table does not define.
    MissingParentCombinationError
        A parent combination has no row, or only rows of weight zero.
    BindingError
        ``network.toml`` binds an unknown variable or is malformed.
    """
    by_name: dict[str, VariableTable] = {}
    for table in tables:
        if table.variable in by_name:
            raise TableFormatError(
                f"{table.source}, line 1: variable {table.variable} is already defined by "
                f"{by_name[table.variable].source}"
            )
        by_name[table.variable] = table
    for table in tables:
        for parent in table.parents:
            if parent not in by_name:
                raise UnknownParentError(
                    f"{table.source}, line 1: parent {parent!r} of {table.variable} has no "
                    f"table; known variables: {', '.join(sorted(by_name))}"
                )
    order = _topological_order(by_name)
    states = {name_: table.states() for name_, table in by_name.items()}
    probabilities = {name_: _normalised_table(by_name[name_], states) for name_ in order}
    config = dict(config or {})
    bindings = _parse_bindings(config, states, config_source)
    return BayesNet(
        name=str(config.get("name", name)),
        variables=tuple(order),
        states={v: states[v] for v in order},
        parents={v: by_name[v].parents for v in order},
        tables=probabilities,
        bindings=bindings,
        description=str(config.get("description", "")),
        default=bool(config.get("default", False)),
        metadata=dict(config.get("metadata", {})),
        source=source,
    )


def _topological_order(tables: Mapping[str, VariableTable]) -> list[str]:
    order: list[str] = []
    mark: dict[str, int] = {}  # 1 = on the current path, 2 = done

    def visit(name: str, path: list[str]) -> None:
        if mark.get(name) == 2:
            return
        if mark.get(name) == 1:
            cycle = [*path[path.index(name) :], name]
            files = ", ".join(tables[v].source for v in cycle[:-1])
            raise CyclicNetworkError(
                f"cycle {' -> '.join(cycle)} (each is a parent of the next; tables {files}, "
                "line 1); a network must be acyclic"
            )
        mark[name] = 1
        for parent in tables[name].parents:
            visit(parent, [*path, name])
        mark[name] = 2
        order.append(name)

    for name in tables:
        visit(name, [])
    return order


def _normalised_table(table: VariableTable, states: Mapping[str, tuple[str, ...]]) -> np.ndarray:
    shape = (len(states[table.variable]), *(len(states[p]) for p in table.parents))
    weights = np.zeros(shape)
    index_of = {
        v: {s: i for i, s in enumerate(states[v])} for v in (table.variable, *table.parents)
    }
    for row in table.rows:
        index = [index_of[table.variable][row.state]]
        for parent, state in zip(table.parents, row.parent_states, strict=True):
            if state not in index_of[parent]:
                raise InconsistentStatesError(
                    f"{table.source}, line {row.line}: parent {parent} has no state {state!r}; "
                    f"expected one of {list(states[parent])} (the states of {parent}'s table)"
                )
            index.append(index_of[parent][state])
        weights[tuple(index)] = row.weight
    totals = weights.sum(axis=0)
    for combination in product(*(range(n) for n in shape[1:])):
        if totals[combination] > 0:
            continue
        named = ", ".join(
            f"{parent}={states[parent][i]}"
            for parent, i in zip(table.parents, combination, strict=True)
        )
        lines = _rows_with(
            table.rows, tuple(states[p][i] for p, i in zip(table.parents, combination, strict=True))
        )
        detail = f"rows on lines {lines} all have weight 0" if lines else "no row gives it"
        raise MissingParentCombinationError(
            f"{table.source}: parent combination {named or '(none)'} of {table.variable}: "
            f"{detail}; expected at least one row with a positive weight"
        )
    return weights / totals[np.newaxis]


def _rows_with(rows: tuple[TableRow, ...], parent_states: tuple[str, ...]) -> list[int]:
    return [row.line for row in rows if row.parent_states == parent_states]


def _parse_bindings(
    config: Mapping[str, Any], states: Mapping[str, tuple[str, ...]], source: str
) -> dict[str, Binding]:
    known = {"name", "description", "default", "metadata", "variables"}
    unknown = set(config) - known
    if unknown:
        raise BindingError(f"{source}: unknown keys {sorted(unknown)}; expected {sorted(known)}")
    variables = config.get("variables", {})
    if not isinstance(variables, Mapping):
        raise BindingError(f"{source}: [variables] must be a table of tables")
    bindings: dict[str, Binding] = {}
    fields: dict[str, str] = {}
    for variable, spec in variables.items():
        if variable not in states:
            raise BindingError(
                f"{source}: [variables.{variable}] names no table; known variables: "
                f"{', '.join(sorted(states))}"
            )
        if not isinstance(spec, Mapping):
            raise BindingError(f"{source}: [variables.{variable}] must be a table")
        if "field" not in spec:
            continue  # documented hidden variable
        binding = parse_binding(variable, spec, states[variable], source=source)
        if binding.field in fields:
            raise BindingError(
                f"{source}: field {binding.field!r} is bound to both {fields[binding.field]} "
                f"and {variable}"
            )
        fields[binding.field] = variable
        bindings[variable] = binding
    return bindings


def network_tables(network: BayesNet) -> list[VariableTable]:
    """The network's tables as :class:`VariableTable` s (normalised weights)."""
    tables = []
    for name in network.variables:
        parents = network.parents[name]
        table = network.tables[name]
        rows: list[TableRow] = []
        for index in product(*(range(n) for n in table.shape)):
            rows.append(
                TableRow(
                    network.states[name][index[0]],
                    tuple(network.states[p][i] for p, i in zip(parents, index[1:], strict=True)),
                    float(table[index]),
                    len(rows) + 2,
                )
            )
        tables.append(VariableTable(name, parents, tuple(rows), f"{name}.csv"))
    return tables


def write_network(network: BayesNet, path: str | os.PathLike[str]) -> Path:
    """Write ``network`` as a folder of CSV tables plus ``network.toml``.

    Parameters
    ----------
    network
        Network to write.
    path
        Output folder; created if missing. Existing tables of the same names are replaced.

    Returns
    -------
    pathlib.Path
        The folder.
    """
    folder = Path(path)
    folder.mkdir(parents=True, exist_ok=True)
    for table in network_tables(network):
        (folder / f"{table.variable}.csv").write_text(format_table(table), encoding="utf-8")
    (folder / CONFIG_NAME).write_text(format_config(network), encoding="utf-8")
    return folder


def format_config(network: BayesNet) -> str:
    """``network.toml`` text for ``network`` (name, description, metadata, bindings)."""
    lines = [
        f"name = {_toml_value(network.name)}",
        f"description = {_toml_value(network.description)}",
        f"default = {_toml_value(network.default)}",
    ]
    if network.metadata:
        lines += ["", "[metadata]"]
        lines += [f"{key} = {_toml_value(value)}" for key, value in network.metadata.items()]
    for variable in network.variables:
        binding = network.bindings.get(variable)
        if binding is None:
            continue
        lines += [
            "",
            f"[variables.{variable}]",
            f"field = {_toml_value(binding.field)}",
            f"kind = {_toml_value(binding.kind)}",
        ]
        if binding.nearest:
            lines.append("nearest = true")
        if binding.kind == "bins":
            lines.append(f"edges = {_toml_value(list(binding.edges))}")
            lines.append(f"values = {_toml_value(list(binding.numbers))}")
    return "\n".join(lines) + "\n"


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        if isinstance(value, float) and math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    if isinstance(value, str):
        escaped = value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
        return f'"{escaped}"'
    raise BindingError(f"cannot write {value!r} ({type(value).__name__}) to network.toml")
