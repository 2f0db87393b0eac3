"""MkDocs hook: charts and figures from outside ``docs/``, and tables from their JSON.

The benchmark charts (``benchmarks/results/*.png``) and the example figures
(``examples/figures/*.png``) stay where the scripts write them; this hook adds them to the
site's files under the same relative paths, so a page links them as
``benchmarks/results/NAME.png`` (relative to the docs root) without copying binaries.

It also expands table markers, so that the figures quoted next to a chart are the ones in the
JSON the benchmark wrote, never a stale copy::

    <!-- json-table benchmarks/results/NAME.json | rows | column; column=Header; a/b=Header -->
    <!-- json-values benchmarks/results/NAME.json | key/sub=Label; other=Label -->

``json-table`` renders the list of records found at the path (``/`` separates keys) with one
column per named field (nested fields as ``a/b``); ``json-values`` renders a two-column table of
single values. A record without one of the fields shows ``-`` (not measured); a missing file,
key, or a field that no record has stops the build with an error naming it.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parent.parent
#: Files outside docs/ that the site shows, as glob patterns relative to the repository root.
EXTERNAL_FILES = ("benchmarks/results/*.png", "examples/figures/*.png")

MARKER = re.compile(r"^<!--[ \t]*json-(table|values)[ \t]+(.+?)[ \t]*-->[ \t]*$", re.MULTILINE)


#: A cross-reference placeholder left by Markdown in a docstring.
AUTOREF = re.compile(
    r'<autoref (?P<attrs>[^>]*?)identifier="(?P<identifier>[^"]*)"(?P<rest>[^>]*)>'
    r"(?P<title>.*?)</autoref>",
    re.DOTALL,
)
#: A unit as docstrings write it after a quantity: ``[deg]``, ``[1]``, ``[cd m-2]``.
UNIT = re.compile(
    r"^(?:1|%|(?:deg|rad|sr|km|m|mm|nm|um|µm|s|ms|us|h|lx|lm|cd|W|K|mag|arcsec|px|Pa|hPa)"
    r"(?:-?\d)?)(?:\s(?:deg|rad|sr|km|m|nm|um|µm|s|ms|us|lx|lm|cd|W|K|mag|arcsec)(?:-?\d)?)*$"
)


def on_files(files: Files, config: Any) -> Files:
    """Add the charts and figures to the site under their repository paths."""
    for pattern in EXTERNAL_FILES:
        for path in sorted(ROOT.glob(pattern)):
            uri = path.relative_to(ROOT).as_posix()
            if files.get_file_from_path(uri) is None:
                files.append(File.generated(config, uri, abs_src_path=str(path)))
    return files


def on_serve(server: Any, config: Any, builder: Any) -> Any:
    """Rebuild on changes to the charts, figures and JSON while serving."""
    for folder in ("benchmarks/results", "examples/figures", "examples"):
        server.watch(str(ROOT / folder))
    return server


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    """Replace the JSON table markers of a page with Markdown tables."""

    def expand(match: re.Match[str]) -> str:
        kind, arguments = match.group(1), match.group(2)
        where = f"{page.file.src_uri}: json-{kind}"
        try:
            if kind == "table":
                return _records_table(arguments)
            return _values_table(arguments)
        except (OSError, KeyError, IndexError, TypeError, ValueError) as error:
            raise PluginError(f"{where} {arguments!r}: {error}") from error

    return MARKER.sub(expand, markdown)


def on_page_content(html: str, page: Any, config: Any, files: Files) -> str:
    """Give back the text of units that Markdown read as cross-references.

    A docstring that writes a range before a unit, ``angle in [0, 180] [deg]``, reads to
    Markdown as a reference link ``[0, 180][deg]`` that nothing resolves; put the text back.
    """

    def restore(match: re.Match[str]) -> str:
        identifier = match.group("identifier")
        if not UNIT.match(identifier):
            return match.group(0)
        return f"[{match.group('title')}] [{identifier}]"

    return AUTOREF.sub(restore, html)


def _records_table(arguments: str) -> str:
    parts = [part.strip() for part in arguments.split("|")]
    if len(parts) != 3:
        raise ValueError("expected 'FILE | PATH | COLUMNS'")
    data = _load(parts[0])
    records = _lookup(data, parts[1]) if parts[1] not in ("", ".") else data
    if not isinstance(records, list) or not records:
        raise ValueError(f"{parts[1]!r} is not a non-empty list of records")
    columns = _columns(parts[2])
    lines = [
        "| " + " | ".join(header for _, header in columns) + " |",
        "|" + "---|" * len(columns),
    ]
    rows = []
    found = {key: False for key, _ in columns}
    for record in records:
        cells = []
        for key, _ in columns:
            try:
                cells.append(_format(_lookup(record, key)))
                found[key] = True
            except KeyError:
                cells.append("-")  # not measured for this record
        rows.append("| " + " | ".join(cells) + " |")
    missing = [key for key, seen in found.items() if not seen]
    if missing:
        raise KeyError(f"no record of {parts[1]!r} has the field(s) {missing}")
    return "\n".join(lines + rows)


def _values_table(arguments: str) -> str:
    parts = [part.strip() for part in arguments.split("|")]
    if len(parts) != 2:
        raise ValueError("expected 'FILE | KEYS'")
    data = _load(parts[0])
    lines = ["| quantity | value |", "|---|---|"]
    for key, label in _columns(parts[1]):
        lines.append(f"| {label} | {_format(_lookup(data, key))} |")
    return "\n".join(lines)


def _load(relative: str) -> Any:
    path = ROOT / relative
    if not path.is_file():
        raise ValueError(f"no file {relative} in the repository")
    with path.open(encoding="utf-8") as stream:
        return json.load(stream)


def _columns(text: str) -> list[tuple[str, str]]:
    columns = []
    for item in text.split(";"):
        key, _, header = item.strip().partition("=")
        if not key:
            raise ValueError(f"empty column in {text!r}")
        columns.append((key.strip(), header.strip() or key.strip()))
    return columns


def _lookup(data: Any, path: str) -> Any:
    value = data
    for key in path.split("/"):
        if isinstance(value, list):
            value = value[int(key)]
        elif isinstance(value, dict):
            if key not in value:
                raise KeyError(f"no key {key!r} (of {path!r}); keys: {sorted(value)}")
            value = value[key]
        else:
            raise TypeError(f"{path!r}: cannot look up {key!r} in a {type(value).__name__}")
    return value


def _format(value: Any) -> str:
    """Three significant digits for reals, integers and text as they are."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, float):
        if not math.isfinite(value):
            return str(value)
        if value == 0.0:
            return "0"
        magnitude = abs(value)
        if 1e-3 <= magnitude < 1e10:
            digits = max(0, 2 - math.floor(math.log10(magnitude)))
            return f"{value:,.{digits}f}"
        return f"{value:.2e}"
    if isinstance(value, list):
        return " x ".join(_format(item) for item in value)
    return str(value).replace("|", "\\|")
