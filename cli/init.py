"""``nightlights init``: write a commented project file to start from."""

from __future__ import annotations

from pathlib import Path

import click

from .options import OutputExistsError, overwrite_option

DEFAULT_PROJECT_FILE = "nightlights.toml"


@click.command("init")
@click.argument(
    "project",
    type=click.Path(dir_okay=False),
    default=DEFAULT_PROJECT_FILE,
    metavar="[PROJECT.toml]",
)
@overwrite_option
def init_command(project: str, overwrite: bool) -> None:
    """Write a commented project template to PROJECT.toml (default: nightlights.toml); edit
    it, then run it with nightlights run PROJECT.toml."""
    path = Path(project)
    if path.exists() and not overwrite:
        raise OutputExistsError(project)
    from nightlights.project import template

    template.write_template(path)
    click.echo(
        f"wrote {path}; edit its inputs and observers, then: nightlights run {path}", err=True
    )


commands = [init_command]
