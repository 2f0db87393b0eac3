"""``nightlights streets sample`` and ``nightlights streets fit`` (Chuang 2011, Sec. 3.3)."""

from __future__ import annotations

import click
from rich.console import Console
from rich.table import Table

from bayesnets import catalog_names, default_network_name
from cli.options import seed_option
from nightlights.io import read_vector
from nightlights.streets.fit import fit_streets
from nightlights.streets.sample import DEFAULT_CANDIDATES, lighting_summary, sample_streets

_NETWORK_HELP = (
    f"Catalogue network ({', '.join(catalog_names())}; default {default_network_name()}) "
    "or a network folder."
)


@click.command("sample")
@click.argument("src", type=click.Path(exists=True, dir_okay=False))
@click.argument("dst", type=click.Path(dir_okay=False))
@click.option("--network", default=None, metavar="NAME|DIR", help=_NETWORK_HELP)
@seed_option
@click.option(
    "--candidates",
    default=DEFAULT_CANDIDATES,
    show_default=True,
    type=click.IntRange(min=1),
    help="Likelihood-weighting candidates per segment.",
)
@click.option(
    "--on-conflict",
    type=click.Choice(["error", "relax"]),
    default="error",
    show_default=True,
    help="Impossible evidence: stop, or drop the least likely observations with a warning.",
)
def sample(
    src: str,
    dst: str,
    network: str | None,
    seed: int | None,
    candidates: int,
    on_conflict: str,
) -> None:
    """Fill missing street and lighting fields of SRC by sampling a Bayesian network."""
    path = sample_streets(
        src,
        dst,
        network=network,
        candidates=candidates,
        seed=seed,
        on_conflict=on_conflict,  # type: ignore[arg-type]
        progress=True,
    )
    streets = read_vector(path)
    summary = lighting_summary(streets)
    console = Console(stderr=True)
    console.print(f"[bold]{len(streets)}[/] street segments ({summary['lit']['lit']} lit) -> {dst}")
    for field, title in (("arrangement", "arrangement"), ("system_id", "light system")):
        table = Table(title, "lit segments")
        for value, count in summary[field].items():
            table.add_row(value, str(count))
        console.print(table)


@click.command("fit")
@click.argument("src", type=click.Path(exists=True, dir_okay=False))
@click.argument("out_dir", type=click.Path(file_okay=False))
@click.option("--network", default=None, metavar="BASE", help="Base network: " + _NETWORK_HELP)
@click.option(
    "--prior",
    default=1.0,
    show_default=True,
    type=click.FloatRange(min=0),
    help="Pseudo-observations per parent combination from the base network (0: maximum "
    "likelihood).",
)
def fit(src: str, out_dir: str, network: str | None, prior: float) -> None:
    """Estimate a network's tables from SRC (lighting known); write it to OUT_DIR."""
    path = fit_streets(src, out_dir, network=network, prior=prior)
    Console(stderr=True).print(f"fitted network -> {path} (use --network {path})")


commands = [sample, fit]
