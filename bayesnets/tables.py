"""CSV tables of a Bayesian network, one per variable (Chuang 2011, Sec. 3.3, Fig. 10).

A table's header names the variable, then its parents, then the weight column::

    ARRANGEMENT,HAS_MEDIAN,WIDTH_RATIO,weight
    single_sided,F,le1,80
    staggered,F,le1,15
    ...

Each row gives a state of the variable, a state of every parent and a non-negative weight
proportional to the likelihood of that state given those parent states. As in Chuang's
Figure 10 the last header cell may also hold the total of the weights instead of the word
``weight``. Rows are normalised per parent combination when the network is built.
"""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path

from bayesnets.errors import InvalidWeightError, TableFormatError


@dataclass(frozen=True)
class TableRow:
    """One row of a variable's table.

    Attributes
    ----------
    state
        State of the table's variable.
    parent_states
        State of each parent, in header order.
    weight
        Non-negative weight, proportional to the conditional likelihood [1].
    line
        Line number in the CSV file (the header is line 1).
    """

    state: str
    parent_states: tuple[str, ...]
    weight: float
    line: int


@dataclass(frozen=True)
class VariableTable:
    """A parsed (not yet validated against other tables) CSV table.

    Attributes
    ----------
    variable
        Name of the variable the table estimates (first header cell).
    parents
        Names of its parents (middle header cells).
    rows
        Rows in file order.
    source
        File the table came from, used in error messages.
    """

    variable: str
    parents: tuple[str, ...]
    rows: tuple[TableRow, ...]
    source: str

    def states(self) -> tuple[str, ...]:
        """States of the variable, in order of first appearance."""
        return tuple(dict.fromkeys(row.state for row in self.rows))


def parse_table(text: str, *, source: str = "<table>") -> VariableTable:
    """Parse the text of one CSV table.

    Parameters
    ----------
    text
        CSV text: a header ``VAR,PARENT1,...,PARENTn,weight`` and one row per state and
        parent combination. Blank lines and lines starting with ``#`` are skipped. Cells
        may be separated by commas or (as in Chuang's Figure 10) tabs.
    source
        Name of the file, used in error messages.

    Returns
    -------
    VariableTable
        The parsed table.

    Raises
    ------
    TableFormatError
        Missing or malformed header, wrong number of cells in a row, empty state, a row
        repeated for the same state and parent states.
    InvalidWeightError
        A weight that is not a number, negative or not finite.

    References
    ----------
    Chuang 2011, Sec. 3.3 and Fig. 10 (table layout).

    Examples
    --------
    >>> table = parse_table("LIT,weight\\nT,3\\nF,1\\n", source="LIT.csv")
    >>> table.variable, table.states()
    ('LIT', ('T', 'F'))
    """
    lines = [
        (number, line)
        for number, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not lines:
        raise TableFormatError(f"{source}: empty table; expected a header VAR,...,weight")
    delimiter = "\t" if "," not in lines[0][1] and "\t" in lines[0][1] else ","
    header = [cell.strip() for cell in _split(lines[0][1], delimiter)]
    header_line = lines[0][0]
    if len(header) < 2 or any(not cell for cell in header):
        raise TableFormatError(
            f"{source}, line {header_line}: header {lines[0][1]!r}; expected "
            "VAR,PARENT1,...,PARENTn,weight with non-empty names"
        )
    if header[-1].lower() != "weight" and not _is_number(header[-1]):
        raise TableFormatError(
            f"{source}, line {header_line}: last header cell {header[-1]!r}; expected "
            "'weight' (or the total of the weights, as in Chuang 2011 Fig. 10)"
        )
    names = header[:-1]
    if len(set(names)) != len(names):
        raise TableFormatError(
            f"{source}, line {header_line}: a variable is named twice in the header {names}"
        )
    variable, parents = names[0], tuple(names[1:])
    rows: list[TableRow] = []
    seen: dict[tuple[str, ...], int] = {}
    for number, line in lines[1:]:
        cells = [cell.strip() for cell in _split(line, delimiter)]
        if len(cells) != len(header):
            raise TableFormatError(
                f"{source}, line {number}: {len(cells)} cells in {line!r}; expected "
                f"{len(header)} ({','.join(header)})"
            )
        if any(not cell for cell in cells[:-1]):
            raise TableFormatError(f"{source}, line {number}: empty state in {line!r}")
        weight = _parse_weight(cells[-1], source=source, line=number)
        key = tuple(cells[:-1])
        if key in seen:
            raise TableFormatError(
                f"{source}, line {number}: duplicate row {','.join(key)} "
                f"(first given on line {seen[key]})"
            )
        seen[key] = number
        rows.append(TableRow(cells[0], tuple(cells[1:-1]), weight, number))
    if not rows:
        raise TableFormatError(f"{source}: table for {variable} has a header but no rows")
    return VariableTable(variable, parents, tuple(rows), source)


def read_table(path: str | os.PathLike[str]) -> VariableTable:
    """Read one CSV table from ``path`` (see :func:`parse_table`)."""
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise TableFormatError(f"{file}: cannot read table: {exc}") from exc
    return parse_table(text, source=str(file))


def format_table(table: VariableTable) -> str:
    """CSV text of ``table`` with a ``weight`` header (inverse of :func:`parse_table`)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow([table.variable, *table.parents, "weight"])
    for row in table.rows:
        writer.writerow([row.state, *row.parent_states, f"{row.weight:.6g}"])
    return buffer.getvalue()


def _split(line: str, delimiter: str) -> list[str]:
    return next(csv.reader([line], delimiter=delimiter))


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _parse_weight(text: str, *, source: str, line: int) -> float:
    try:
        weight = float(text)
    except ValueError:
        raise InvalidWeightError(
            f"{source}, line {line}: weight {text!r} is not a number; expected a "
            "non-negative finite number"
        ) from None
    if not math.isfinite(weight) or weight < 0:
        raise InvalidWeightError(
            f"{source}, line {line}: weight {text!r}; expected a non-negative finite number"
        )
    return weight
