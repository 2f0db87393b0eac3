"""The shape of the code base: dependency direction, no import circles, modules of a readable size.

Imports are read statically (module level and inside functions alike), so a circle dodged by a
function-level import counts as a circle.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("nightlights", "bayesnets", "ies", "cli")
#: Folders installed under another import name (``pyproject.toml``'s package-dir).
IMPORT_NAMES = {"cli": "nightlights_cli"}
#: Longest module without a stated reason [lines].
MAX_LINES = 600
#: What a longer module must say at the top of its docstring to explain its length.
LENGTH_REASON = "Length:"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    parts[0] = IMPORT_NAMES.get(parts[0], parts[0])
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {
        _module_name(path): path
        for package in PACKAGES
        for path in sorted((ROOT / package).rglob("*.py"))
        if "data" not in path.relative_to(ROOT / package).parts
    }


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """Project modules imported by ``name`` (the deepest known module of each import)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    is_package = path.name == "__init__.py"
    targets: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            candidates = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                base = base[: len(base) - node.level + (1 if is_package else 0)]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            candidates = [f"{module}.{alias.name}" for alias in node.names] + [module]
        else:
            continue
        for candidate in candidates:
            parts = candidate.split(".")
            for end in range(len(parts), 0, -1):
                prefix = ".".join(parts[:end])
                if prefix in known:
                    if prefix != name:
                        targets.add(prefix)
                    break
    return targets


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    known = set(modules)
    graph = {name: _imports(name, path, known) for name, path in modules.items()}
    # a package's __init__ importing its own submodules is not a dependency of those on it
    return {
        name: {t for t in targets if not (t.startswith(name + ".") and name in known)}
        for name, targets in graph.items()
    }


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in graph.get(node, ()):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def _without_package_inits(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """Edges into a package's ``__init__`` re-exports go to the module that defines the name;
    approximate that by dropping edges from a subpackage's modules to its own ``__init__``."""
    return {
        name: {t for t in targets if not name.startswith(t + ".")}
        for name, targets in graph.items()
    }


def test_no_import_circles() -> None:
    cycles = _cycles(_without_package_inits(_graph()))
    assert cycles == [], f"import circles: {cycles}"


@pytest.mark.parametrize(
    ("package", "forbidden"),
    [
        ("ies", ("nightlights", "bayesnets", "nightlights_cli")),
        ("bayesnets", ("nightlights", "ies", "nightlights_cli")),
        ("nightlights", ("nightlights_cli",)),
    ],
)
def test_dependency_direction(package: str, forbidden: tuple[str, ...]) -> None:
    graph = _graph()
    wrong = sorted(
        f"{name} -> {target}"
        for name, targets in graph.items()
        if name.split(".")[0] == package
        for target in targets
        if target.split(".")[0] in forbidden
    )
    assert wrong == []


def test_modules_of_readable_size() -> None:
    long = []
    for name, path in _modules().items():
        text = path.read_text(encoding="utf-8")
        lines = text.count("\n")
        if lines <= MAX_LINES:
            continue
        docstring = ast.get_docstring(ast.parse(text)) or ""
        if LENGTH_REASON not in docstring:
            long.append(f"{name} ({lines} lines)")
    assert long == [], f"modules over {MAX_LINES} lines without a '{LENGTH_REASON}' reason"


def test_the_graph_sees_imports() -> None:
    graph = _graph()
    assert "nightlights.errors" in graph["nightlights.io.raster"]
    assert "ies.frames" in graph["nightlights.ground.frames"]


#: Where the code and its tests live (the docs pages have their own check).
CODE_FOLDERS = (*PACKAGES, "tests", "benchmarks", "examples")
#: A citation of an issue number, or of a capitalised project file other than the README.
#: (Built from pieces so that this line does not cite what it forbids.)
CITATION = re.compile(
    "|".join(
        (
            r"\b[Ii]" + r"ssue\s*#?\d+",
            r"\b(?!README\.md)[A-Z]{4,}" + r"\.md\b",
            r"\b" + "STYLE" + r" rule",
        )
    )
)


def test_code_cites_papers_not_issues_or_outside_files() -> None:
    hits = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for folder in CODE_FOLDERS
        for path in sorted((ROOT / folder).rglob("*.py"))
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1)
        if CITATION.search(line)
    ]
    assert hits == []


def test_cli_modules_import_each_other_relatively() -> None:
    """The folder ``cli/`` is installed as ``nightlights_cli``: an absolute ``cli.x`` import
    would fail once installed, and ``nightlights_cli.x`` would read another installed copy."""
    absolute = []
    for path in sorted((ROOT / "cli").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names: list[str] = []
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            absolute += [
                f"{path.name}: {name}"
                for name in names
                if name.split(".")[0] in ("cli", *IMPORT_NAMES.values())
            ]
    assert absolute == []
