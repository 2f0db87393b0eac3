"""Strict JSON: what the toolkit writes parses with a strict parser (no NaN, no Infinity), each
null that stands for a non-finite number says why, and no module writes JSON another way."""

from __future__ import annotations

import ast
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from nightlights.io.jsonfile import dumps_json, json_ready

ROOT = Path(__file__).resolve().parents[3]


def strict_loads(text: str) -> Any:
    """JSON as strict parsers (RFC 8259) read it: NaN and Infinity are refused."""

    def refuse(constant: str) -> None:
        raise ValueError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


#: (value, what a strict parser reads back)
VALUES = [
    ({"a": 1.5, "b": "x", "c": None, "d": True}, {"a": 1.5, "b": "x", "c": None, "d": True}),
    (
        {"mag": math.inf},
        {"mag": None, "mag_null_reason": "mag was +inf, which strict JSON cannot hold"},
    ),
    (
        {"low": -math.inf, "nan": math.nan},
        {
            "low": None,
            "low_null_reason": "low was -inf, which strict JSON cannot hold",
            "nan": None,
            "nan_null_reason": "nan was NaN, which strict JSON cannot hold",
        },
    ),
    (
        {"zenith": [18.5, math.inf]},
        {
            "zenith": [18.5, None],
            "zenith_null_reason": "item 1: zenith was +inf, which strict JSON cannot hold",
        },
    ),
    (
        {"nested": [{"x": np.float32("nan"), "n": np.int64(3)}], "array": np.array([1.0, np.inf])},
        {
            "nested": [
                {"x": None, "x_null_reason": "x was NaN, which strict JSON cannot hold", "n": 3}
            ],
            "array": [1.0, None],
            "array_null_reason": "item 1: array was +inf, which strict JSON cannot hold",
        },
    ),
]


@pytest.mark.parametrize(("value", "expected"), VALUES)
def test_non_finite_numbers_are_null_with_the_reason(value: Any, expected: Any) -> None:
    assert strict_loads(dumps_json(value)) == expected
    assert json_ready(value) == expected


def test_a_path_given_to_default_is_text_and_the_reason_can_be_the_callers() -> None:
    text = dumps_json(
        {"file": Path("a/b.tif"), "after": math.inf}, default=str, reason=lambda k, v: f"{k}: dark"
    )
    assert strict_loads(text) == {
        "file": "a/b.tif",
        "after": None,
        "after_null_reason": "after: dark",
    }


#: ``json.dumps`` calls whose text is no JSON document the toolkit writes, by (module,
#: function): hash keys of finite, validated parameters and request values echoed in messages.
NOT_WRITTEN = {
    ("nightlights/emission_functions.py", "parse_tabulated_emission"),  # a canonical tag
    ("nightlights/sky/spec.py", "content_hash"),
    ("nightlights/sky/multiple.py", "_atmosphere_key"),
    ("nightlights/sky/multiple.py", "multiple_scattering_table"),
    ("nightlights/sky/multiple.py", "tables_digest"),
    ("nightlights/project/_cache.py", "stage_key"),
    ("nightlights/explore/_app.py", "number"),
    ("nightlights/explore/_app.py", "choice"),
    ("nightlights/explore/_app.py", "text"),
    ("nightlights/explore/_app.py", "flag"),
    ("nightlights/explore/_app.py", "pairs"),
    ("nightlights/explore/_app.py", "export_paths"),
    ("nightlights/io/jsonfile.py", "dumps_json"),  # the strict writer itself
}


def _json_calls(path: Path) -> list[tuple[str | None, ast.Call]]:
    """The ``json.dump``/``json.dumps`` calls of a module with their enclosing function."""
    found: list[tuple[str | None, ast.Call]] = []

    def visit(node: ast.AST, function: str | None) -> None:
        for child in ast.iter_child_nodes(node):
            name = child.name if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef) else None
            call = child.func if isinstance(child, ast.Call) else None
            if (
                isinstance(call, ast.Attribute)
                and call.attr in ("dump", "dumps")
                and isinstance(call.value, ast.Name)
                and call.value.id == "json"
            ):
                found.append((function, child))  # type: ignore[arg-type]
            visit(child, name or function)

    visit(ast.parse(path.read_text(encoding="utf-8")), None)
    return found


def test_every_json_the_toolkit_writes_is_strict() -> None:
    loose = []
    for folder in ("nightlights", "cli"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            module = path.relative_to(ROOT).as_posix()
            for function, call in _json_calls(path):
                strict = any(
                    k.arg == "allow_nan" and isinstance(k.value, ast.Constant) and not k.value.value
                    for k in call.keywords
                )
                if not strict and (module, function) not in NOT_WRITTEN:
                    loose.append(f"{module}:{call.lineno} ({function})")
    assert loose == [], "write JSON with nightlights.io.jsonfile.dumps_json"
