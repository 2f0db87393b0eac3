"""``nightlights qgis-plugin``: the QGIS plugin that puts the stages in the Processing Toolbox."""

from __future__ import annotations

import click

from .kinds import file_kind
from .options import files_argument, output_option, overwrite_option, resolve_inout


@click.group("qgis-plugin")
def qgis_plugin() -> None:
    """The QGIS Processing provider, as a plugin zip for QGIS's Plugins > Install from ZIP."""


@qgis_plugin.command("build")
@files_argument("[OUTPUT]", file_kind("zip"))
@output_option
@overwrite_option
@click.option(
    "--command",
    "command",
    default=None,
    type=click.Path(exists=True, dir_okay=False),
    help="The nightlights executable the plugin runs (default: this environment's).",
)
def build_command(
    files: tuple[str, ...], output: str | None, overwrite: bool, command: str | None
) -> None:
    """Write the plugin zip OUTPUT (default: nightlights_processing.zip).

    The plugin runs this environment's nightlights command in a subprocess (its path is
    recorded in the zip), so QGIS's Python needs none of the toolkit's libraries; its
    Processing algorithms are made from the description of the stage commands' paths and
    options that the zip carries (stages.json). In QGIS:
    Plugins > Manage and Install Plugins > Install from ZIP; the algorithms appear under
    nightlights in the Processing Toolbox.
    """
    from rich.console import Console

    from nightlights.qgis import build_plugin, plugin_command

    from .describe import describe_stages

    if output is None and not files:
        output = plugin_zip()
    _, out = resolve_inout(files, output, inputs=0, usage="[OUTPUT]", overwrite=overwrite)
    root = click.get_current_context().find_root().command
    assert isinstance(root, click.Group)
    runs = plugin_command(command)  # absolute, executable: what the zip records
    path = build_plugin(out, describe_stages(root), command=runs, overwrite=overwrite)
    Console(stderr=True).print(
        f"QGIS plugin -> {path} (runs {runs}); install it in QGIS with Plugins > Manage and "
        "Install Plugins > Install from ZIP",
        soft_wrap=True,
        highlight=False,
    )


def plugin_zip() -> str:
    """The plugin zip's default name: the plugin's folder name with ``.zip``."""
    from nightlights.qgis import PLUGIN_FOLDER

    return f"{PLUGIN_FOLDER}.zip"


commands = [qgis_plugin]
