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
catalog_option = click.option(
    "--catalog",
    default=None,
    type=click.Path(exists=True, file_okay=False),
    help="Luminaire database folder (default: the bundled one).",
)
skip_unknown_option = click.option(
    "--skip-unknown", is_flag=True, help="Drop lights with unknown system ids (with a warning)."
)
