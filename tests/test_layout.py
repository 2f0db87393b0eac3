"""The shape of the code base: dependency direction, floors, no import circles, readable modules.

Imports are read statically (module level and inside functions alike), so a circle dodged by a
function-level import counts as a circle, and an import that runs up the floors counts wherever
it stands.

The floors of ``nightlights``, lowest first (:data:`FLOORS`). A module may import modules of
its own floor and of the floors below it, never of a floor above; rooms (packages or modules)
that share a floor stand side by side and import each other not at all:

1. base: ``errors`` (the exception root) and ``_typing`` (array and path types).
2. leaves: ``_validate`` (checks of user input), ``_resources`` (memory bounds), ``_parallel``
   (Dask helpers), ``_progress`` (the progress bars' columns), ``_signals`` (Ctrl-C held
   during compiled work), ``brightness`` (sky-brightness units, Bortle, the zenith summary) and
   ``emission_functions`` (the angular emission shapes and the band tag naming them, the
   vocabulary the ground writes and the sky reads).
3. io: files in and out (rasters, vectors, styles, terrain).
4. ground: ``streets`` (street layers to light points) and ``ground`` (light on the ground
   and what goes up).
5. sky and roads: skyglow kernels, panoramas, many observers (``observers``, ``darkness``) and
   the per-cell splits of panorama sums (``influence``); beside them ``roads`` (road lighting to
   EN 13201, reading the ground's luminaire frames).
6. inverse and night sky: ``inverse`` (which lights cause the glow, how to dim them) and
   ``nightsky`` (stars, Moon, natural sky, the eye), both reading the sky.
7. explore: the interactive investigation.
8. maps: quick-look map figures.
9. project: one TOML file that runs every stage.
10. front: ``qgis`` (the QGIS provider) and ``demo`` (the bundled example).

The package face ``nightlights/__init__.py`` stands on no floor: it hands every stage on lazily
(its ``_LAZY`` table). An import of it is read as an import of the module each name taken from
it comes from (``nl.darkness`` or ``from nightlights import darkness``: ``nightlights.sky``); a
name the face holds itself (the errors, ``__version__``) counts as ``nightlights.errors``, the
only module the face imports when it loads. The lazy tables of the subpackages' faces count as
imports too. ``ies`` and ``bayesnets`` stand below every floor (:func:`test_dependency_direction`).
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

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


def _import_nodes(tree: ast.Module) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement of a module and whether it stands inside a function."""

    def visit(node: ast.AST, deferred: bool) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import | ast.ImportFrom):
                yield child, deferred
            inside = deferred or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef)
            yield from visit(child, inside)

    yield from visit(tree, False)


def _candidates(node: ast.Import | ast.ImportFrom, name: str, is_package: bool) -> list[str]:
    """Dotted names an import statement may load: one per alias (``module.alias`` for a
    from-import), then, for a from-import, the module it names."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if node.level:
        base = name.split(".")
        base = base[: len(base) - node.level + (1 if is_package else 0)]
        module = ".".join([*base, node.module] if node.module else base)
    else:
        module = node.module or ""
    return [f"{module}.{alias.name}" for alias in node.names] + [module]


def _deepest_known(candidate: str, known: set[str]) -> str | None:
    parts = candidate.split(".")
    for end in range(len(parts), 0, -1):
        prefix = ".".join(parts[:end])
        if prefix in known:
            return prefix
    return None


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """Project modules imported by ``name`` (the deepest known module of each import)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    is_package = path.name == "__init__.py"
    targets: set[str] = set()
    for node, _ in _import_nodes(tree):
        for candidate in _candidates(node, name, is_package):
            target = _deepest_known(candidate, known)
            if target is not None and target != name:
                targets.add(target)
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


#: The floors of ``nightlights``, lowest first: (name, rooms). A room is a package or a module;
#: a module stands on the floor of its longest room prefix. See the module docstring.
FLOORS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("base", ("nightlights.errors", "nightlights._typing")),
    (
        "leaves",
        (
            "nightlights._validate",
            "nightlights._resources",
            "nightlights._parallel",
            "nightlights._progress",
            "nightlights._signals",
            "nightlights.brightness",
            "nightlights.emission_functions",
        ),
    ),
    ("io", ("nightlights.io",)),
    ("ground", ("nightlights.streets", "nightlights.ground")),
    ("sky and roads", ("nightlights.sky", "nightlights.roads")),
    ("inverse and night sky", ("nightlights.inverse", "nightlights.nightsky")),
    ("explore and meters", ("nightlights.explore", "nightlights.meter")),
    ("maps", ("nightlights.maps",)),
    ("project", ("nightlights.project",)),
    ("front", ("nightlights.qgis", "nightlights.demo")),
)
#: The package face: on no floor; imports of it are read through its lazy table.
FACE = "nightlights"
#: Where a name the face holds itself comes from (the face loads this module alone).
FACE_OWN = "nightlights.errors"
#: The name of a package face's table of lazily imported names (public name -> module).
LAZY_TABLE = "_LAZY"


class ImportSite(NamedTuple):
    """One project module that one statement of a module loads."""

    module: str
    line: int
    #: ``at module level``, ``inside a function`` or ``in the lazy table``.
    where: str
    target: str

    def __str__(self) -> str:
        return f"{self.module}:{self.line} ({self.where}) imports {self.target}"


def _lazy_table(tree: ast.Module) -> dict[str, tuple[str, int]]:
    """A face's lazy table: public name -> (module, line of the entry)."""
    for node in tree.body:
        target: ast.expr
        if isinstance(node, ast.AnnAssign):
            target = node.target
        elif isinstance(node, ast.Assign) and len(node.targets) == 1:
            target = node.targets[0]
        else:
            continue
        if isinstance(target, ast.Name) and target.id == LAZY_TABLE:
            assert isinstance(node.value, ast.Dict), f"{LAZY_TABLE} is not a dict literal"
            return {
                ast.literal_eval(key): (ast.literal_eval(value), value.lineno)
                for key, value in zip(node.value.keys, node.value.values, strict=True)
                if key is not None
            }
    return {}


def _face_names() -> dict[str, str]:
    """The face's lazy table: public name -> the module that defines it."""
    tree = ast.parse((ROOT / FACE / "__init__.py").read_text(encoding="utf-8"))
    return {key: module for key, (module, _) in _lazy_table(tree).items()}


def _through_face(attribute: str, face: dict[str, str], known: set[str]) -> str:
    """The module a name taken from the face comes from."""
    if f"{FACE}.{attribute}" in known:
        return f"{FACE}.{attribute}"
    return face.get(attribute, FACE_OWN)


def _attributes_of(tree: ast.Module, bound: str) -> set[str]:
    """Attributes read from the name ``bound`` anywhere in a module (``nl.skyglow``)."""
    return {
        node.attr
        for node in ast.walk(tree)
        if isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Name)
        and node.value.id == bound
    }


def _import_sites(
    name: str, source: str, *, is_package: bool, known: set[str], face: dict[str, str]
) -> list[ImportSite]:
    """Every project module that the source of module ``name`` loads, statement by statement."""
    tree = ast.parse(source)
    sites: list[ImportSite] = []

    def add(line: int, where: str, target: str | None) -> None:
        site = ImportSite(name, line, where, target or "")
        if target is not None and target != name and site not in sites:
            sites.append(site)

    for node, deferred in _import_nodes(tree):
        where = "inside a function" if deferred else "at module level"
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == FACE:  # import nightlights as nl: what nl.NAME reads
                    for attribute in sorted(_attributes_of(tree, alias.asname or FACE)):
                        add(node.lineno, where, _through_face(attribute, face, known))
                else:
                    add(node.lineno, where, _deepest_known(alias.name, known))
            continue
        candidates = _candidates(node, name, is_package)
        for alias, candidate in zip(node.names, candidates, strict=False):
            target = _deepest_known(candidate, known)
            if target == FACE:  # from nightlights import NAME
                target = _through_face(alias.name, face, known)
            add(node.lineno, where, target)
    for module, line in _lazy_table(tree).values():
        add(line, "in the lazy table", _deepest_known(module, known))
    return sites


def _room(module: str) -> str | None:
    """The room (longest prefix in :data:`FLOORS`) a module belongs to; None: none."""
    matches = [
        room
        for _, rooms in FLOORS
        for room in rooms
        if module == room or module.startswith(room + ".")
    ]
    return max(matches, key=len, default=None)


def _floor(module: str) -> int | None:
    """Index in :data:`FLOORS` of the floor a module stands on; None: on no floor."""
    room = _room(module)
    return next((i for i, (_, rooms) in enumerate(FLOORS) if room in rooms), None)


def _floor_name(index: int) -> str:
    return f"floor {index + 1} ({FLOORS[index][0]})"


def _upward(sites: list[ImportSite]) -> list[str]:
    """The imports that run from a lower floor to a higher one."""
    wrong = []
    for site in sites:
        low, high = _floor(site.module), _floor(site.target)
        if low is not None and high is not None and high > low:
            wrong.append(f"{site}: {_floor_name(low)} up to {_floor_name(high)}")
    return wrong


def _sideways(sites: list[ImportSite]) -> list[str]:
    """The imports between two rooms that share a floor."""
    wrong = []
    for site in sites:
        floor = _floor(site.module)
        if floor is not None and floor == _floor(site.target):
            if _room(site.module) != _room(site.target):
                wrong.append(f"{site}: sideways on {_floor_name(floor)}")
    return wrong


def _floored_modules() -> dict[str, Path]:
    """The modules of ``nightlights`` but its face."""
    return {
        name: path
        for name, path in _modules().items()
        if name.split(".")[0] == FACE and name != FACE
    }


def _nightlights_sites() -> list[ImportSite]:
    known, face = set(_modules()), _face_names()
    return [
        site
        for name, path in _floored_modules().items()
        for site in _import_sites(
            name,
            path.read_text(encoding="utf-8"),
            is_package=path.name == "__init__.py",
            known=known,
            face=face,
        )
    ]


def test_every_module_stands_on_a_floor() -> None:
    homeless = sorted(name for name in _floored_modules() if _floor(name) is None)
    assert homeless == [], f"modules on no floor of FLOORS: {homeless}"
    rooms = [room for _, floor in FLOORS for room in floor]
    assert len(rooms) == len(set(rooms)), "a room on two floors"
    missing = sorted(room for room in rooms if room not in _modules())
    assert missing == [], f"rooms of FLOORS that are no module: {missing}"


def test_no_import_runs_up_the_floors() -> None:
    wrong = _upward(_nightlights_sites())
    assert wrong == [], "imports that run up the floors:\n" + "\n".join(wrong)


def test_rooms_on_one_floor_stand_apart() -> None:
    wrong = _sideways(_nightlights_sites())
    assert wrong == [], "imports between rooms of one floor:\n" + "\n".join(wrong)


def _sites_of(module: str, source: str) -> list[ImportSite]:
    """The import sites of a module that would have ``source`` (the checks' own tests)."""
    is_package = (ROOT / module.replace(".", "/") / "__init__.py").exists()
    return _import_sites(
        module, source, is_package=is_package, known=set(_modules()), face=_face_names()
    )


@pytest.mark.parametrize(
    ("module", "source", "expected"),
    [
        (
            "nightlights.io.styles",
            "def qml():\n    from nightlights.sky.spec import KernelSpec\n",
            "nightlights.io.styles:2 (inside a function) imports nightlights.sky.spec: "
            "floor 3 (io) up to floor 5 (sky and roads)",
        ),
        (
            "nightlights.sky.stage",
            "import nightlights as nl\n\ndef run():\n    return nl.inverse_q\n",
            "nightlights.sky.stage:1 (at module level) imports nightlights.inverse: "
            "floor 5 (sky and roads) up to floor 6 (inverse and night sky)",
        ),
        (
            "nightlights.ground.upward",
            "from nightlights import skyglow\n",
            "nightlights.ground.upward:1 (at module level) imports nightlights.sky: "
            "floor 4 (ground) up to floor 5 (sky and roads)",
        ),
        (
            "nightlights.sky",
            "_LAZY: dict[str, str] = {\n    'zenith_summary': 'nightlights.nightsky.render',\n}\n",
            "nightlights.sky:2 (in the lazy table) imports nightlights.nightsky.render: "
            "floor 5 (sky and roads) up to floor 6 (inverse and night sky)",
        ),
        (
            "nightlights.brightness",
            "from .io import styles\n",
            "nightlights.brightness:1 (at module level) imports nightlights.io.styles: "
            "floor 2 (leaves) up to floor 3 (io)",
        ),
    ],
)
def test_the_floor_check_sees_every_kind_of_import(module: str, source: str, expected: str) -> None:
    assert _upward(_sites_of(module, source)) == [expected]


def test_the_floor_check_sees_sideways_imports() -> None:
    sites = _sites_of("nightlights.inverse.stage", "from ..nightsky import render\n")
    assert _upward(sites) == []
    assert _sideways(sites) == [
        "nightlights.inverse.stage:1 (at module level) imports nightlights.nightsky.render: "
        "sideways on floor 6 (inverse and night sky)"
    ]


def test_the_floor_check_lets_imports_go_down() -> None:
    source = (
        "import nightlights as nl\n"
        "from nightlights import __version__, brightness\n"
        "from nightlights.sky.influence import cell_values\n"
        "def run():\n"
        "    from nightlights.io import Raster\n"
        "    return nl.darkness, nl.NightlightsError\n"
    )
    sites = _sites_of("nightlights.inverse.stage", source)
    assert {site.target for site in sites} == {
        "nightlights.brightness",
        "nightlights.errors",
        "nightlights.io",
        "nightlights.sky",
        "nightlights.sky.influence",
    }
    assert _upward(sites) == [] and _sideways(sites) == []


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
