"""``nightlights streets``: street layers to streetlight layouts (Chuang 2011, Sec. 3).

``normalize`` maps a street layer's fields onto the canonical ones, ``sample`` fills the
missing street and lighting fields from a Bayesian network, ``fit`` estimates such a network
from streets whose lighting is known, ``learn`` estimates one from mapped street lamps, and
``place`` puts light systems along the streets, and ``audit`` rates each street segment's
lighting against its lighting class (EN 13201) and, given ``--year``, its energy (EN 13201-5).
"""

from __future__ import annotations

from collections import Counter
from typing import TYPE_CHECKING, Any, Literal, cast

import click

from . import plan_roads
from .kinds import FOLDER, JSON, LINES, POINTS, KindPath, file_kind
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
    check_outputs,
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


@streets.command("audit")
@files_argument("LIGHTS STREETS OUTPUT", POINTS, LINES, LINES)
@output_option
@overwrite_option
@catalog_option
@click.option(
    "--rtable",
    default=None,
    type=click.Path(exists=True, dir_okay=False),
    help="r-table of the road surface (CIE 144 layout); default: an analytic stand-in.",
)
@click.option(
    "--requirements",
    default=None,
    type=KindPath(file_kind("toml"), exists=True, dir_okay=False),
    help="Requirements by class (TOML); default: EN 13201-2:2015 Tables 1-3.",
)
@click.option(
    "--dimming", default=None, metavar="FIELD", help="Field of LIGHTS with each light's level [1]."
)
@click.option(
    "--age",
    type=click.FloatRange(min=0, min_open=True),
    default=23.0,
    show_default=True,
    help="Observer's age for the threshold increment [year].",
)
@click.option(
    "--json",
    "summary_json",
    default=None,
    type=KindPath(JSON, dir_okay=False),
    help="Write the summary to this JSON file.",
)
@click.option(
    "--year",
    type=click.IntRange(1900, 2100),
    default=None,
    help="Compute energy (EN 13201-5) over this UTC year.",
)
@click.option(
    "--schedule",
    default=None,
    metavar="STEPS",
    help="Dimming schedule, e.g. '22:00=0.5,05:00=1' (needs --year).",
)
@click.option(
    "--zone",
    default="UTC",
    show_default=True,
    help="IANA zone or UTC offset of the schedule's clock times.",
)
@click.option(
    "--grid-factor",
    type=click.FloatRange(min=0),
    default=None,
    help="Grid emission factor [kg CO2/kWh] (needs --year).",
)
@click.option(
    "--power-field",
    default="power",
    show_default=True,
    help="Field of LIGHTS with each light's input power [W]; else the photometry's watts.",
)
@max_memory_option
def audit_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    catalog: str | None,
    rtable: str | None,
    requirements: str | None,
    dimming: str | None,
    age: float,
    summary_json: str | None,
    year: int | None,
    schedule: str | None,
    zone: str,
    grid_factor: float | None,
    power_field: str,
) -> None:
    """Rate the lighting of every segment of STREETS lit by LIGHTS against its lighting class
    (EN 13201-2/-3); write the styled segments to OUTPUT (GeoPackage).

    With --year, each segment also gets its lights' power, annual energy, D_P, D_E and (with
    --grid-factor) CO2 (EN 13201-5).
    """
    import nightlights as nl
    from nightlights.roads import EnergyOptions

    (lights_path, streets_path), dst = resolve_inout(
        files, output, inputs=2, usage="LIGHTS STREETS OUTPUT", overwrite=overwrite
    )
    check_outputs([summary_json], overwrite=overwrite)
    if year is None and (schedule is not None or grid_factor is not None):
        raise click.UsageError("--schedule and --grid-factor need --year")
    energy = None
    if year is not None:
        energy = EnergyOptions(
            year, schedule=schedule, zone=zone, grid_factor=grid_factor, power_field=power_field
        )
    result = nl.audit(
        lights_path,
        streets_path,
        dst,
        catalog=catalog,
        rtable=rtable,
        requirements=requirements,
        dimming=dimming,
        age=age,
        energy=energy,
        summary_json=summary_json,
    )
    print_audit_summary(result.summary.to_dict(), dst)


def print_audit_summary(summary: dict[str, Any], dst: str) -> None:
    """Print the segments, length and compliant share per class, overall, and the energy
    totals (stderr)."""
    from rich.console import Console
    from rich.table import Table

    def share(value: float | None) -> str:
        return "-" if value is None else f"{value:.1%}"

    console = Console(stderr=True)
    console.print(
        f"[bold]{summary['segments']}[/] segments, {summary['rated']} rated, "
        f"{summary['passed']} keep their class -> {dst}",
        highlight=False,
    )
    table = Table("class", "segments", "length km", "compliant", title="lighting classes")
    for name, row in summary["by_class"].items():
        table.add_row(
            name, str(row["segments"]), f"{row['length_m'] / 1000:.3f}", share(row["share"])
        )
    console.print(table)
    console.print(
        f"compliant: {share(summary['share_compliant'])} of "
        f"{summary['rated_length_m'] / 1000:.3f} km rated street",
        highlight=False,
    )
    energy = summary.get("energy")
    if energy:
        line = (
            f"energy {energy['year']}: {energy['energy_kwh']:.1f} kWh "
            f"({energy['power_w']:.0f} W, {energy['burning_hours']:.0f} full-power h)"
        )
        if energy["energy_density"] is not None:
            line += f", D_E {energy['energy_density']:.2f} Wh/m2"
        if energy["co2_kg"] is not None:
            line += f", CO2 {energy['co2_kg']:.1f} kg"
        console.print(line, highlight=False)


commands = [streets]
