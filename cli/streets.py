"""``nightlights streets``: street layers to streetlight layouts (Chuang 2011, Sec. 3).

``normalize`` maps a street layer's fields onto the canonical ones, ``sample`` fills the
missing street and lighting fields from a Bayesian network, ``fit`` estimates such a network
from streets whose lighting is known, ``learn`` estimates one from mapped street lamps, and
``place`` puts light systems along the streets.
"""

from __future__ import annotations

from collections import Counter
from typing import TYPE_CHECKING, Any, Literal, cast

import click

from . import plan_roads
from .kinds import FOLDER, LINES, POINTS
from .options import (
    BUILTIN_MAPPINGS,
    DEFAULT_ACROSS_JITTER,
    DEFAULT_ALONG_JITTER,
    DEFAULT_CANDIDATES,
    DEFAULT_MAX_DISTANCE,
    DEFAULT_MERGE_FRACTION,
    NETWORK_CATALOG,
    ON_CONFLICT,
    LibraryChoice,
    LibraryHelpOption,
    catalog_option,
    crs_option,
    files_argument,
    output_option,
    overwrite_option,
    prior_option,
    resolve_inout,
    seed_option,
    target_crs_option,
)
from .resources import max_memory_option

if TYPE_CHECKING:
    from nightlights.streets import NormalizeReport

_NETWORK_HELP = (
    "Catalogue network ({networks}) or a network folder. Default: the network for where the "
    "streets lie, as streets sample chooses it."
)
_SAMPLE_NETWORK_HELP = (
    "Catalogue network ({networks}) or a network folder. Default: chosen from where INPUT lies: "
    "north_america in North America, europe in Europe, east_asia in China, Japan, Korea and "
    "Taiwan, generic elsewhere (with a warning)."
)
#: The ``{networks}`` of the two helps above.
_NETWORKS = {"networks": NETWORK_CATALOG}


@click.group()
def streets() -> None:
    """Street layers to streetlight layouts (Chuang 2011, Sec. 3)."""


@streets.command("normalize")
@files_argument("INPUT OUTPUT", LINES, LINES)
@output_option
@overwrite_option
@click.option(
    "--mapping",
    cls=LibraryHelpOption,
    default="osm",
    show_default=True,
    help="Built-in mapping ({mappings}) or a TOML file.",
    help_values={"mappings": BUILTIN_MAPPINGS},
)
@click.option("--layer", default=None, help="Input layer (default: first; 'lines' for OSM).")
@crs_option
@target_crs_option
@max_memory_option
def normalize_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    mapping: str,
    layer: str | None,
    crs: str | None,
    target_crs: str | None,
) -> None:
    """Map INPUT's street fields onto the canonical fields; write OUTPUT (GeoPackage)."""
    import nightlights as nl

    (src,), dst = resolve_inout(
        files,
        output,
        inputs=1,
        usage="INPUT OUTPUT",
        overwrite=overwrite,
        existing_inputs=False,  # the stage names a missing file in its own error
    )
    result = nl.normalize(src, dst, mapping=mapping, layer=layer, crs=crs, target_crs=target_crs)
    print_normalize_report(result.report, dst)


def print_normalize_report(report: NormalizeReport, dst: str) -> None:
    """Print counts of kept, dropped and observed features, and of values outside their
    allowed range (treated as missing), on stderr."""
    from rich.console import Console
    from rich.table import Table

    from nightlights.streets.schema import STREET_FIELDS

    console = Console(stderr=True)
    console.print(
        f"[bold]{report.output_features}[/] street parts from {report.input_features} "
        f"features -> {dst} ({report.crs})"
    )
    for reason, count in report.dropped.items():
        if count:
            console.print(f"  dropped {count}: {reason}")
    table = Table("field", "observed", "missing", "out of range", title="canonical fields")
    for name in STREET_FIELDS:
        seen = report.observed.get(name, 0)
        rejected = sum(report.implausible_values.get(name, {}).values())
        table.add_row(name, str(seen), str(report.output_features - seen), str(rejected))
    console.print(table)


@streets.command("sample")
@files_argument("INPUT OUTPUT", LINES, LINES)
@output_option
@overwrite_option
@click.option(
    "--network",
    cls=LibraryHelpOption,
    default=None,
    metavar="NAME|DIR",
    help=_SAMPLE_NETWORK_HELP,
    help_values=_NETWORKS,
)
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
    type=LibraryChoice(ON_CONFLICT),
    default="error",
    show_default=True,
    help="Impossible evidence: stop, or drop the least likely observations with a warning.",
)
@max_memory_option
def sample_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    network: str | None,
    seed: int | None,
    candidates: int,
    on_conflict: str,
) -> None:
    """Fill missing street and lighting fields of INPUT by sampling a Bayesian network
    (Chuang 2011, Sec. 3.3); write OUTPUT."""
    import nightlights as nl

    (src,), dst = resolve_inout(files, output, inputs=1, usage="INPUT OUTPUT", overwrite=overwrite)
    result = nl.sample(
        src,
        dst,
        network=network,
        candidates=candidates,
        seed=seed,
        on_conflict=cast(Literal["error", "relax"], on_conflict),
        progress=True,
    )
    print_network_choice(result.network, result.location)
    print_lighting_summary(result.streets, dst)


def print_network_choice(network: str, location: tuple[float, float] | None) -> None:
    """Print the network used and, when chosen by location, where the layer lies (stderr)."""
    from rich.console import Console

    if location is None:
        line = f"network {network}"
    elif location[0] != location[0]:  # NaN: an empty layer has no location
        line = f"network {network} (empty layer, no location)"
    else:
        longitude, latitude = location
        line = (
            f"network {network}, chosen by location (layer centre {longitude:.2f}, "
            f"{latitude:.2f} deg lon, lat); give --network to choose another"
        )
    Console(stderr=True).print(line, highlight=False)


def print_lighting_summary(streets: Any, dst: str) -> None:
    """Print the lit segments per arrangement and light system (stderr)."""
    from rich.console import Console
    from rich.table import Table

    from nightlights.streets import lighting_summary

    summary = lighting_summary(streets)
    console = Console(stderr=True)
    console.print(f"[bold]{len(streets)}[/] street segments ({summary['lit']['lit']} lit) -> {dst}")
    for field, title in (("arrangement", "arrangement"), ("system_id", "light system")):
        table = Table(title, "lit segments")
        for value, count in summary[field].items():
            table.add_row(value, str(count))
        console.print(table)


@streets.command("fit")
@files_argument("INPUT OUTPUT", LINES, FOLDER)
@output_option
@click.option(
    "--network",
    cls=LibraryHelpOption,
    default=None,
    metavar="BASE",
    help="Base network: " + _NETWORK_HELP,
    help_values=_NETWORKS,
)
@prior_option
@max_memory_option
def fit_command(
    files: tuple[str, ...], output: str | None, network: str | None, prior: float
) -> None:
    """Estimate a network's tables from INPUT (lighting known); write it to the folder OUTPUT.

    OUTPUT must not exist or be an empty folder: a network folder is never replaced.
    """
    import nightlights as nl

    (src,), dst = resolve_inout(
        files,
        output,
        inputs=1,
        usage="INPUT OUTPUT",
        overwrite=True,  # the stage refuses a folder that is not empty
    )
    result = nl.fit(src, dst, network=network, prior=prior)
    from rich.console import Console

    Console(stderr=True).print(f"fitted network -> {result.path} (use --network {result.path})")


@streets.command("learn")
@files_argument("STREETS LAMPS OUT_DIR", LINES, POINTS, FOLDER)
@output_option
@overwrite_option
@click.option(
    "--network",
    cls=LibraryHelpOption,
    default=None,
    metavar="BASE",
    help="Base network: " + _NETWORK_HELP,
    help_values=_NETWORKS,
)
@click.option(
    "--max-distance",
    default=DEFAULT_MAX_DISTANCE,
    show_default=True,
    type=click.FloatRange(min=0, min_open=True),
    help="Largest lamp-to-street distance [m].",
)
@prior_option
@click.option(
    "--lamps-layer",
    default=None,
    help="Layer of the LAMPS file (default: 'points' for OSM files, else the first).",
)
@seed_option
@max_memory_option
def learn_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    network: str | None,
    max_distance: float,
    prior: float,
    lamps_layer: str | None,
    seed: int | None,
) -> None:
    """Learn a network from STREETS (normalised) and the mapped lamps in LAMPS; write it to
    the folder OUT_DIR.

    Each lamp goes to the nearest street within --max-distance (a street it runs along
    beats one that ends beside it); streets with two lamps on one side give arrangement and
    spacing, tagged heights give mounting height; streets without lamps stay unobserved
    (only lit=no says a street is unlit). The base network's tables are fitted to this
    evidence with the base as prior. OUT_DIR also gets learn_report.json and the evidence
    layers evidence_streets.gpkg and evidence_lamps.gpkg.
    """
    import nightlights.streets as nls

    (streets_path, lamps_path), dst = resolve_inout(
        files,
        output,
        inputs=2,
        usage="STREETS LAMPS OUT_DIR",
        overwrite=True,  # the stage checks the folder itself (--overwrite: network folders)
    )
    result = nls.learn(
        streets_path,
        lamps_path,
        dst,
        network=network,
        max_distance=max_distance,
        prior=prior,
        seed=seed,
        lamps_layer=lamps_layer,
        overwrite=overwrite,
    )
    print_learn_report(result.report, dst)


def print_learn_report(report: Any, dst: str) -> None:
    """Print the lamps assigned, the streets with evidence and its agreement (stderr)."""
    from rich.console import Console
    from rich.table import Table

    console = Console(stderr=True)
    console.print(
        f"{report.assigned} of {report.lamps} lamps on {report.streets_with_lamps} of "
        f"{report.streets} streets (within {report.max_distance:g} m; "
        f"{report.assigned - report.interior} beside a street end); "
        f"{report.unlit_tagged} streets tagged lit=no took none",
        highlight=False,
    )
    table = Table("field", "streets with evidence", "agreeing", "values", title="evidence")
    for name, evidence in report.fields.items():
        values = ", ".join(f"{key} {value:g}" for key, value in evidence.summary.items())
        share = "-" if not evidence.streets else f"{evidence.agreeing} ({evidence.agreement:.0%})"
        table.add_row(name, str(evidence.streets), share, values)
    console.print(table)
    console.print(f"learned network -> {dst} (use --network {dst})", highlight=False)


streets.add_command(plan_roads.plan)


@streets.command("place")
@files_argument("INPUT OUTPUT", LINES, POINTS)
@output_option
@overwrite_option
@catalog_option
@seed_option
@click.option(
    "--along-jitter",
    type=float,
    default=DEFAULT_ALONG_JITTER,
    show_default=True,
    help="Along-street jitter, fraction of the spacing [1].",
)
@click.option(
    "--across-jitter",
    type=float,
    default=DEFAULT_ACROSS_JITTER,
    show_default=True,
    help="Across-street jitter [m].",
)
@click.option(
    "--merge-fraction",
    type=float,
    default=DEFAULT_MERGE_FRACTION,
    show_default=True,
    help="Merge poles of different streets closer than this fraction of the spacing [1].",
)
@max_memory_option
def place_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    catalog: str | None,
    seed: int | None,
    along_jitter: float,
    across_jitter: float,
    merge_fraction: float,
) -> None:
    """Place light systems along the sampled streets in INPUT; write points to OUTPUT."""
    import nightlights as nl

    (src,), dst = resolve_inout(files, output, inputs=1, usage="INPUT OUTPUT", overwrite=overwrite)
    result = nl.place(
        src,
        dst,
        seed=seed,
        along_jitter=along_jitter,
        across_jitter=across_jitter,
        merge_fraction=merge_fraction,
        catalog=catalog,
    )
    from rich.console import Console

    lights = result.lights
    console = Console(stderr=True)
    console.print(
        f"[bold]{len(lights)}[/] luminaires on {lights['pole_id'].nunique()} poles -> {dst}"
    )
    for arrangement, count in sorted(Counter(lights["arrangement"]).items()):
        console.print(f"  {arrangement}: {count}")


commands = [streets]
