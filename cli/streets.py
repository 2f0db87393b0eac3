"""``nightlights streets``: normalise street layers, fill lighting properties, place poles."""

from __future__ import annotations

from collections import Counter

import click
from rich.console import Console
from rich.table import Table

from cli.options import catalog_option, seed_option
from cli.streets_sample import commands as sample_commands
from nightlights.streets.normalize import NormalizeReport, builtin_mappings, normalize
from nightlights.streets.place import PlacementOptions, place
from nightlights.streets.schema import STREET_FIELDS


@click.group()
def streets() -> None:
    """Street layers to streetlight layouts (Chuang 2011, Sec. 3)."""


@streets.command("normalize")
@click.argument("src", type=click.Path(dir_okay=False))
@click.argument("dst", type=click.Path(dir_okay=False))
@click.option(
    "--mapping",
    default="osm",
    show_default=True,
    help=f"Built-in mapping ({', '.join(builtin_mappings())}) or a TOML file.",
)
@click.option("--layer", default=None, help="Input layer (default: first; 'lines' for OSM).")
@click.option("--crs", "assume_crs", default=None, help="CRS of an input that has none.")
@click.option("--target-crs", default=None, help="Projected output CRS (default: local UTM).")
def normalize_command(
    src: str,
    dst: str,
    mapping: str,
    layer: str | None,
    assume_crs: str | None,
    target_crs: str | None,
) -> None:
    """Map SRC's street fields onto the canonical fields; write DST (GeoPackage)."""
    report = normalize(
        src, dst, mapping=mapping, layer=layer, assume_crs=assume_crs, target_crs=target_crs
    )
    print_normalize_report(report, dst)


def print_normalize_report(report: NormalizeReport, dst: str) -> None:
    """Print counts of kept, dropped and observed features."""
    console = Console(stderr=True)
    console.print(
        f"[bold]{report.output_features}[/] street parts from {report.input_features} "
        f"features -> {dst} ({report.crs})"
    )
    for reason, count in report.dropped.items():
        if count:
            console.print(f"  dropped {count}: {reason}")
    table = Table("field", "observed", "missing", title="canonical fields")
    for name in STREET_FIELDS:
        seen = report.observed.get(name, 0)
        table.add_row(name, str(seen), str(report.output_features - seen))
    console.print(table)


@streets.command("place")
@click.argument("src", type=click.Path(exists=True, dir_okay=False))
@click.argument("dst", type=click.Path(dir_okay=False))
@catalog_option
@seed_option
@click.option(
    "--along-jitter",
    default=PlacementOptions.along_jitter,
    show_default=True,
    help="Along-street jitter, fraction of the spacing [1].",
)
@click.option(
    "--across-jitter",
    default=PlacementOptions.across_jitter,
    show_default=True,
    help="Across-street jitter [m].",
)
@click.option(
    "--merge-fraction",
    default=PlacementOptions.merge_fraction,
    show_default=True,
    help="Merge poles of different streets closer than this fraction of the spacing.",
)
def place_command(
    src: str,
    dst: str,
    catalog: str | None,
    seed: int | None,
    along_jitter: float,
    across_jitter: float,
    merge_fraction: float,
) -> None:
    """Place light systems along the sampled streets in SRC; write points to DST."""
    options = PlacementOptions(
        along_jitter=along_jitter, across_jitter=across_jitter, merge_fraction=merge_fraction
    )
    lights = place(src, dst, seed=seed, options=options, catalog=catalog)
    console = Console(stderr=True)
    console.print(
        f"[bold]{len(lights)}[/] luminaires on {lights['pole_id'].nunique()} poles -> {dst}"
    )
    for arrangement, count in sorted(Counter(lights["arrangement"]).items()):
        console.print(f"  {arrangement}: {count}")


for _command in sample_commands:
    streets.add_command(_command)

commands = [streets]
