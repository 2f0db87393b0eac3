"""``nightlights demo``: the whole pipeline on the bundled Helsinki example."""

from __future__ import annotations

import click
from rich.console import Console

from nightlights.demo import run_demo


@click.command("demo")
@click.option(
    "--out",
    "out_dir",
    default="nightlights-demo",
    show_default=True,
    type=click.Path(file_okay=False),
    help="Output folder.",
)
@click.option("--seed", default=2011, show_default=True, help="Random seed.")
def demo(out_dir: str, seed: int) -> None:
    """Run every stage on the bundled Helsinki extract (OpenStreetMap, ODbL)."""
    console = Console(stderr=True)
    with console.status("running the Helsinki demo ..."):
        result = run_demo(out_dir, seed=seed)
    console.print("[bold]Helsinki demo[/] (data (c) OpenStreetMap contributors, ODbL)")
    for stage, path in result.outputs.items():
        console.print(f"  {stage:>22}: {path}")
    for name, (magnitude, bortle) in result.zenith.items():
        console.print(
            f"  zenith sky at {name}: {magnitude:.2f} mag arcsec-2 from the extract's "
            f"streetlights alone (Bortle {bortle})",
            soft_wrap=True,
        )


commands = [demo]
