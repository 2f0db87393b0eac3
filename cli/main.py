"""Entry point of the ``nightlights`` command.

One module per command, named after it, each exposing ``commands`` (click commands or groups);
this module only builds the group, sets up logging, and turns domain errors into one-line
messages with exit status 1. The command modules import only click at import time, so that
``nightlights --help`` does not load the library.
"""

from __future__ import annotations

import importlib
import logging
import sys
import warnings
from typing import Any

import click

from nightlights import __version__

#: Modules that each expose ``commands``: a list of click commands or groups.
COMMAND_MODULES = (
    "cli.streets",
    "cli.irradiance",
    "cli.emission",
    "cli.kernel",
    "cli.skyglow",
    "cli.inverse",
    "cli.darkness",
    "cli.photometry",
    "cli.demo",
)


def domain_errors() -> tuple[type[Exception], ...]:
    """The exception roots of the project's packages (reported in one line)."""
    from bayesnets.errors import BayesNetError
    from ies.errors import PhotometryError
    from nightlights.errors import NightlightsError

    return (NightlightsError, BayesNetError, PhotometryError)


class NightlightsGroup(click.Group):
    """A click group that reports domain errors in one line instead of a traceback."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except Exception as exc:
            if isinstance(exc, domain_errors()):
                raise click.ClickException(f"{type(exc).__name__}: {exc}") from exc
            raise


@click.group(cls=NightlightsGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="nightlights")
@click.option("-v", "--verbose", count=True, help="More detail (repeat for debug).")
@click.option("-q", "--quiet", is_flag=True, help="Only errors.")
def cli(verbose: int, quiet: bool) -> None:
    """Night-time lighting: streetlights, irradiance, emission and skyglow.

    Commands that write a product take INPUT... OUTPUT (or -o/--output OUTPUT) and refuse to
    replace an existing output unless --overwrite is given.
    """
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
