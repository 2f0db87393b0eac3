"""Entry point of the ``nightlights`` command.

Each command group lives in its own module and is listed in :data:`COMMAND_MODULES`; this
module only builds the group, sets up logging, and turns domain errors into one-line
messages with a non-zero exit status.
"""

from __future__ import annotations

import importlib
import logging
import sys
import warnings
from typing import Any

import click

from bayesnets.errors import BayesNetError
from ies.errors import PhotometryError
from nightlights import __version__
from nightlights.errors import NightlightsError

#: Modules that each expose ``commands``: a list of click commands or groups.
COMMAND_MODULES = (
    "cli.streets",
    "cli.demo",
    "cli.photometry",
    "cli.rasters",
    "cli.sky_kernel",
    "cli.skyglow",
)

DOMAIN_ERRORS = (NightlightsError, BayesNetError, PhotometryError)


class NightlightsGroup(click.Group):
    """A click group that reports domain errors in one line instead of a traceback."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except DOMAIN_ERRORS as exc:
            raise click.ClickException(f"{type(exc).__name__}: {exc}") from exc


@click.group(cls=NightlightsGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="nightlights")
@click.option("-v", "--verbose", count=True, help="More detail (repeat for debug).")
@click.option("-q", "--quiet", is_flag=True, help="Only errors.")
def cli(verbose: int, quiet: bool) -> None:
    """Night-time lighting: streetlights, irradiance, emission and skyglow."""
    level = (
        logging.ERROR if quiet else (logging.WARNING, logging.INFO, logging.DEBUG)[min(verbose, 2)]
    )
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    logging.captureWarnings(True)
    if quiet:
        warnings.simplefilter("ignore")


for _module_name in COMMAND_MODULES:
    for _command in importlib.import_module(_module_name).commands:
        cli.add_command(_command)


def main() -> None:
    """Console-script entry point."""
    sys.exit(cli.main(standalone_mode=True))
