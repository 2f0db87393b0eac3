"""``nightlights streets``: normalise street layers, fill lighting properties, place poles."""

from __future__ import annotations

import click

from cli.streets_sample import commands as sample_commands


@click.group()
def streets() -> None:
    """Street layers to streetlight layouts (Chuang 2011, Sec. 3)."""


for _command in sample_commands:
    streets.add_command(_command)

commands = [streets]
