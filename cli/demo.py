"""``nightlights demo``: the whole pipeline on the bundled Helsinki example."""

from __future__ import annotations

from pathlib import Path

import click

from .kinds import FOLDER
from .options import (
    SEED_HELP,
    OutputExistsError,
    deprecated_option,
    files_argument,
    one_of,
    output_option,
    overwrite_option,
    resolve_inout,
)
from .resources import max_memory_option

DEFAULT_DEMO_FOLDER = "nightlights-demo"


@click.command("demo")
@files_argument("[OUTPUT]", FOLDER)
@output_option
@deprecated_option(
    "--out",
    "old_out",
    type=click.Path(file_okay=False),
    replacement="OUTPUT or -o/--output",
)
@overwrite_option
@click.option("--seed", type=int, default=2011, show_default=True, help=SEED_HELP)
@click.pass_context
@max_memory_option
def demo(
    ctx: click.Context,
    files: tuple[str, ...],
    output: str | None,
    old_out: str | None,
    overwrite: bool,
    seed: int,
) -> None:
    """Run every stage on the bundled Helsinki extract (OpenStreetMap, ODbL); write the
    products to the folder OUTPUT (default: nightlights-demo).

    The demo is the bundled project file helsinki.toml run as nightlights run runs it. A
    folder that is not empty is refused unless --overwrite is given; then the demo's files
    in it are replaced (stages already up to date there are skipped) and other files are
    left alone.
    """
    output = one_of(ctx, **{"-o/--output": output, "--out": old_out})
    if output is None and not files:
        output = DEFAULT_DEMO_FOLDER
    _, out_dir = resolve_inout(files, output, inputs=0, usage="[OUTPUT]", overwrite=True)
    folder = Path(out_dir)
    if not overwrite and folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise OutputExistsError(out_dir)

    from rich.console import Console

    from nightlights.demo import run_demo

    from .run import print_outputs

    console = Console(stderr=True, emoji=False, highlight=False, soft_wrap=True)
    with console.status("running the Helsinki demo (the bundled project helsinki.toml) ..."):
        result = run_demo(out_dir, seed=seed)
    console.print("[bold]Helsinki demo[/] (data (c) OpenStreetMap contributors, ODbL)")
    print_outputs(console, result)
    ran, cached = getattr(result, "ran", None), getattr(result, "cached", None)
    if ran is not None and cached is not None:
        from nightlights.demo import DEMO_PROJECT, example_path

        console.print(
            f"ran {len(ran)} stages, {len(cached)} up to date, in {result.seconds:.1f} s "
            f"(the project file: {example_path(DEMO_PROJECT)})",
            soft_wrap=True,
        )


commands = [demo]
