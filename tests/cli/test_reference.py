"""docs/cli.md is the command reference generated from the click commands."""

from __future__ import annotations

from pathlib import Path

from nightlights_cli.reference import COMMAND, render

DOCS = Path(__file__).resolve().parents[2] / "docs" / "cli.md"


def test_docs_cli_md_is_current() -> None:
    assert DOCS.read_text(encoding="utf-8") == render(), f"docs/cli.md is stale; run {COMMAND}"


def test_reference_lists_every_command_option_and_deprecation() -> None:
    text = render()
    for heading in (
        "## `nightlights streets normalize`",
        "## `nightlights emission viirs`",
        "## `nightlights kernel build`",
    ):
        assert heading in text
    assert "| `--n-components` | INTEGER |" in text
    assert "| `nightlights skyglow` | `--out` |" in text
    assert "| `nightlights emission` | `--from-viirs INPUT OUTPUT` |" in text
    assert "`--help`" not in text  # click's own help option is not listed per command
