"""Options shared by several commands."""

from __future__ import annotations

import click

seed_option = click.option(
    "--seed", type=int, default=None, help="Random seed; the same seed gives the same output."
)
overwrite_option = click.option(
    "--overwrite/--no-overwrite", default=True, show_default=True, help="Replace existing outputs."
)
scheduler_option = click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="dask.distributed scheduler address; default: local threads.",
)
