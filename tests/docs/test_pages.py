"""The documentation pages: every chart shown, tables from the benchmarks' JSON, README in step."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.rglob("*.md"))


def _text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def _hooks():
    pytest.importorskip("mkdocs")
    spec = importlib.util.spec_from_file_location("docs_hooks", DOCS / "hooks.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_benchmarks_page_shows_every_chart() -> None:
    page = _text(DOCS / "benchmarks.md")
    charts = sorted(path.name for path in (ROOT / "benchmarks" / "results").glob("*.png"))
    assert charts
    missing = [name for name in charts if f"](benchmarks/results/{name})" not in page]
    assert not missing


def test_every_example_figure_is_shown() -> None:
    docs = "".join(_text(page) for page in PAGES)
    readme = _text(ROOT / "README.md")
    for figure in sorted((ROOT / "examples" / "figures").glob("*.png")):
        assert f"examples/figures/{figure.name})" in docs, figure.name
        assert f"](examples/figures/{figure.name})" in readme, figure.name


def test_json_tables_render_from_the_benchmark_files() -> None:
    hooks = _hooks()
    markers = 0
    for page in PAGES:
        markdown = _text(page)
        markers += len(hooks.MARKER.findall(markdown))
        fake_page = SimpleNamespace(file=SimpleNamespace(src_uri=page.relative_to(DOCS).as_posix()))
        rendered = hooks.on_page_markdown(markdown, fake_page, None, None)
        assert "json-table" not in rendered and "json-values" not in rendered, page.name
    assert markers >= len(list((ROOT / "benchmarks" / "results").glob("*.json")))


def test_json_table_values() -> None:
    hooks = _hooks()
    # sky_runtime_cells.json: the naive reference was measured at 2,048 cells only in part of
    # the rows; unmeasured cells show "-".
    table = hooks._records_table(
        "benchmarks/results/sky_runtime_cells.json | rows | lit_cells=cells; naive_s=naive [s]"
    )
    lines = table.splitlines()
    assert lines[0] == "| cells | naive [s] |"
    assert "| 512 | - |" in lines
    assert hooks._format(0.00012345) == "1.23e-04"
    assert hooks._format(722.1154732690002) == "722"
    assert hooks._format(0.0068) == "0.00680"
    assert hooks._format(2410391096) == "2,410,391,096"
    with pytest.raises(KeyError, match="no_such_field"):
        hooks._records_table("benchmarks/results/sky_runtime_cells.json | rows | no_such_field")


def test_unit_after_a_range_is_not_a_cross_reference() -> None:
    hooks = _hooks()
    html = '<p>Vertical angle in <autoref identifier="deg">0, 180</autoref>.</p>'
    restored = hooks.on_page_content(html, None, None, None)
    assert restored == "<p>Vertical angle in [0, 180] [deg].</p>"
    link = '<autoref identifier="nightlights.io.Raster">Raster</autoref>'
    assert hooks.on_page_content(link, None, None, None) == link


def test_readme_quick_start_is_what_ci_runs() -> None:
    readme = _text(ROOT / "README.md")
    block = re.search(r"## Quick start\s+```bash\n(.*?)```", readme, re.DOTALL)
    assert block
    commands = [line.strip() for line in block.group(1).splitlines() if line.strip()]
    assert commands == ["pip install . && nightlights demo", 'pip install ".[test]" && pytest']
    # CI runs the same two commands in a fresh environment (the demo in an empty folder).
    ci = _text(ROOT / ".ci" / "run")
    assert "(pip install . && cd" in ci and "nightlights demo" in ci
    assert '\npip install ".[test]" && pytest\n' in ci


def test_readme_links_to_the_docs_pages_that_exist() -> None:
    readme = _text(ROOT / "README.md")
    links = re.findall(r"\]\((docs/[^)#]+)", readme)
    assert {"docs/index.md", "docs/tutorial.md", "docs/benchmarks.md", "docs/cli.md"} <= set(links)
    for link in links:
        assert (ROOT / link).is_file(), link
    for page in ("streets", "photometry", "irradiance", "skyglow"):
        assert f"docs/physics/{page}.md" in links


def test_readme_keeps_the_data_credits() -> None:
    readme = _text(ROOT / "README.md")
    assert "© OpenStreetMap contributors" in readme
    assert "ODbL" in readme


@pytest.mark.parametrize("page", PAGES, ids=lambda path: path.relative_to(DOCS).as_posix())
def test_pages_cite_papers_not_project_files(page: Path) -> None:
    text = _text(page)
    # project files outside the repository are named in capitals (like the README, which is in it)
    outside = [name for name in re.findall(r"\b[A-Z]{4,}\.md\b", text) if name != "README.md"]
    assert outside == []
    assert not re.search(r"(?<![\w.])/work/", text)
    assert not re.search(r"\b[Ii]ssue\s*#?\d+", text)
    assert "[-]" not in text


def _griffe_rst():
    pytest.importorskip("griffe")
    spec = importlib.util.spec_from_file_location("docs_griffe_rst", DOCS / "griffe_rst.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_numpydoc_math_and_roles_become_markdown() -> None:
    rst = _griffe_rst()
    text = (
        "Ground illuminance :math:`E` of :class:`~nightlights.io.Raster` lights.\n"
        "\n"
        "    .. math::\n"
        "        E = \\frac{I \\cos i}{d^2}\n"
        "\n"
        "    Next paragraph, see :func:`other`."
    )
    markdown = rst.docstring_to_markdown(text)
    assert "$E$" in markdown
    assert (
        '<autoref optional identifier="nightlights.io.Raster"><code>Raster</code></autoref>'
        in markdown
    )
    assert "    $$\n    E = \\frac{I \\cos i}{d^2}\n    $$\n" in markdown
    assert "Next paragraph, see <code>other()</code>." in markdown
    assert ".. math::" not in markdown


def test_site_loads_nothing_from_the_network() -> None:
    config = _text(ROOT / "mkdocs.yml")
    scripts = re.findall(r"^extra_(?:javascript|css):\n((?:\s+- .+\n)+)", config, re.M)
    entries = [line.strip()[2:] for block in scripts for line in block.splitlines()]
    assert entries
    for entry in entries:
        assert not entry.startswith(("http://", "https://", "//")), entry
        assert (DOCS / entry).is_file(), entry
    assert re.search(r"^\s+font: false", config, re.M), "web fonts would load from a CDN"


def test_meters_page_colour_terms_are_the_librarys() -> None:
    """The instrument table of the validation page holds the colour terms the models compute."""
    from nightlights.sky.instruments import INSTRUMENTS, colour_term

    page = _text(DOCS / "meters.md")
    header = next(line for line in page.splitlines() if line.startswith("| instrument | FWHM"))
    spectra = {
        "natural sky": "natural_sky",
        "HPS": "HPS",
        "LPS": "LPS",
        "LED 2700 K": "LED_2700K",
        "LED 4000 K": "LED_4000K",
        "metal halide 4000 K": "metal_halide_4000K",
        "mercury": "mercury",
        "incandescent": "incandescent",
    }
    columns = [cell.strip() for cell in header.strip("|").split("|")][3:]
    assert [spectra[c] for c in columns]
    for name, instrument in INSTRUMENTS.items():
        row = next(line for line in page.splitlines() if line.startswith(f"| `{name}` |"))
        cells = [cell.strip() for cell in row.strip("|").split("|")]
        assert float(cells[1]) == instrument.fwhm
        shown = [float(cell) for cell in cells[3:]]
        expected = [round(colour_term(instrument, spectra[c]), 2) for c in columns]
        assert shown == pytest.approx(expected, abs=0.006), name
