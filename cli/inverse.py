"""``nightlights inverse``: which lights cause the glow an observer sees, and how to dim them.

Four subcommands over :mod:`nightlights.inverse` (Dobashi et al. 2023, Sec. 4), one library
function each:

- ``inverse q EMISSION Q`` (``inverse_q``): each lit cell's light-pollution level Q_i
  (Eqs. 10-11), or its part of the zenith or hemisphere-mean sky luminance;
- ``inverse s EMISSION S --region REGION`` (``inverse_s``): each cell's part of the skyglow in
  a region of the sky (Eqs. 13-14);
- ``inverse dim EMISSION DIMMED --by Q --qa A --qb B`` (``inverse_reduce``): the emission
  dimmed by the rule of Eq. 12 over a Q or S raster;
- ``inverse plan EMISSION DIMMED --observer X,Y --target-zenith MAG`` (``least_dimming``):
  the least flux removed that meets sky-brightness targets (a linear program).

``inverse reduce`` (both jobs in one command) is kept, hidden, for one release: it dispatches
to ``dim`` (given ``--by``) or ``plan`` (given targets) with a deprecation note.

Like every command module this imports only click; the choices are the library's
(:class:`~nightlights_cli.options.FromLibrary`), read when first needed.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import click

from .kinds import JSON, PNG, RASTER, KindPath
from .options import (
    Q_METRICS,
    S_METHODS,
    S_WEIGHTS,
    DeprecatedCommand,
    LibraryChoice,
    check_outputs,
    clouds_of,
    clouds_options,
    components_option,
    dem_option,
    deprecated_option,
    files_argument,
    kernel_option,
    observer_crs_option,
    observer_height_option,
    observer_of,
    observers_option,
    one_of,
    options,
    output_option,
    overwrite_option,
    parse_pair,
    resolve_inout,
    scene_of,
    scene_options,
    warn_deprecated,
)
from .resources import max_memory_option

REGION_HELP = (
    "Region of the sky: 'az,el az,el ...' (closed: the first vertex repeated at the end), "
    "zenith:R, horizon:AZ1,AZ2,EL, or a GeoJSON/WKT polygon file (x azimuth, y elevation) [deg]."
)


@click.group("inverse")
def inverse() -> None:
    """Which lights cause an observer's skyglow (per-cell rasters), and how to dim them.

    \b
    nightlights inverse q EMISSION Q --observer X,Y [--metric pca-norm|zenith|hemisphere]
    nightlights inverse s EMISSION S --observer X,Y --region REGION
    nightlights inverse dim EMISSION DIMMED --by Q --qa A --qb B [--gamma G]
    nightlights inverse plan EMISSION DIMMED --observer X,Y --target-zenith MAG

    REGION is 'az,el az,el ...' (closed polygon), zenith:R, horizon:AZ1,AZ2,EL or a
    GeoJSON/WKT file, angles in degrees (azimuth clockwise from north).
    """


# --- q and s ------------------------------------------------------------------------------------


@inverse.command("q")
@files_argument("EMISSION OUTPUT", RASTER, RASTER)
@output_option
@overwrite_option
@scene_options
@clouds_options
@click.option(
    "--metric",
    type=LibraryChoice(Q_METRICS),
    default="pca-norm",
    show_default=True,
    help="pca-norm: Q_i, the norm of the cell's PCA coefficients (Dobashi Eq. 11); zenith: the "
    "cell's part of the zenith luminance [cd m-2]; hemisphere: its part of the mean luminance "
    "of the visible sky [cd m-2].",
)
@max_memory_option
def q_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    observer: str,
    observer_crs: str | None,
    observer_height: float,
    dem: str | None,
    kernel: str | None,
    turbidity: float | None,
    n_azimuth: int | None,
    n_elevation: int | None,
    n_distance: int | None,
    base_height: float | None,
    optical_depth: float,
    cover: float,
    metric: str,
) -> None:
    """Each lit cell's light-pollution level for an observer: write OUTPUT (one-band COG on
    EMISSION's grid, NaN where unlit)."""
    from nightlights import inverse as library

    parse_pair(observer)  # the syntax checked before any work
    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    scene = scene_of(
        emission,
        dem=dem,
        kernel=kernel,
        turbidity=turbidity,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        n_distance=n_distance,
        clouds=clouds_of(base_height, optical_depth, cover),
    )
    result = library.inverse_q(
        scene, observer_of(observer, observer_crs, observer_height), out, metric=metric
    )
    _report_influence(result, out)


@inverse.command("s")
@files_argument("EMISSION OUTPUT", RASTER, RASTER)
@output_option
@overwrite_option
@scene_options
@click.option("--region", required=True, metavar="REGION", help=REGION_HELP)
@click.option(
    "--weight",
    type=LibraryChoice(S_WEIGHTS),
    default="solid-angle",
    show_default=True,
    help="solid-angle: the cell's part of the region's solid-angle-weighted mean luminance; "
    "pixel: the sum over the region's panorama pixels (Dobashi Eq. 14).",
)
@click.option(
    "--method",
    type=LibraryChoice(S_METHODS),
    default="pca",
    show_default=True,
    help="pca: FFT cross-correlation with the PCA bases (fast); brute: each cell's raw kernel "
    "image summed over the region (the reference).",
)
@components_option
@max_memory_option
def s_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    observer: str,
    observer_crs: str | None,
    observer_height: float,
    dem: str | None,
    kernel: str | None,
    turbidity: float | None,
    n_azimuth: int | None,
    n_elevation: int | None,
    n_distance: int | None,
    region: str,
    weight: str,
    method: str,
    components: int | None,
) -> None:
    """Each lit cell's part of the skyglow in a REGION of the sky: write OUTPUT (one-band COG
    on EMISSION's grid [cd m-2], NaN where unlit)."""
    from nightlights import inverse as library

    parse_pair(observer)  # the syntax checked before any work
    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    scene = scene_of(
        emission,
        dem=dem,
        kernel=kernel,
        turbidity=turbidity,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        n_distance=n_distance,
    )
    result = library.inverse_s(
        scene,
        observer_of(observer, observer_crs, observer_height),
        out,
        region=region,
        weight=weight,
        method=method,
        components=components,
    )
    _report_influence(result, out)


# --- dim and plan -------------------------------------------------------------------------------

#: The options of both dimming commands: the products written besides OUTPUT.
dimming_products = options(
    click.option(
        "--dimming-output",
        default=None,
        type=KindPath(RASTER, dir_okay=False),
        help="Write the dimming fraction of each cell (COG, band 'dimming') [1].",
    ),
    deprecated_option(
        "--dimming-out",
        "old_dimming_out",
        default=None,
        type=click.Path(dir_okay=False),
        replacement="--dimming-output",
    ),
    click.option(
        "--summary-output",
        default=None,
        type=KindPath(JSON, dir_okay=False),
        help="Write the summary (flux removed, sky before and after) as JSON.",
    ),
    deprecated_option(
        "--summary",
        "old_summary",
        default=None,
        type=click.Path(dir_okay=False),
        replacement="--summary-output",
    ),
    click.option(
        "--png",
        default=None,
        type=KindPath(PNG, dir_okay=False),
        help="Before/after panoramas of the (first) observer side by side.",
    ),
)
rule_options = options(
    click.option(
        "--by",
        type=KindPath(RASTER, exists=True, dir_okay=False),
        required=True,
        help="The Q or S raster (inverse q / inverse s) to dim by.",
    ),
    click.option(
        "--qa", type=float, required=True, help="Q_a: no dimming below it [unit of --by]."
    ),
    click.option(
        "--qb", type=float, required=True, help="Q_b: full --gamma dimming above it [unit of --by]."
    ),
    click.option(
        "--gamma",
        type=float,
        default=1.0,
        show_default=True,
        help="gamma_usr in [0, 1]: the fraction of flux removed above Q_b [1].",
    ),
)
target_options = options(
    click.option(
        "--target-zenith",
        type=float,
        default=None,
        metavar="MAG",
        help="Zenith sky brightness every --observer must reach [mag arcsec-2].",
    ),
    click.option(
        "--target-region",
        "target_region",
        multiple=True,
        metavar="REGION:MAG",
        help="A region of the sky and the brightness its mean must reach for every --observer "
        "[mag arcsec-2]; split at the last colon (zenith:30:21.5); repeat for several.",
    ),
    click.option(
        "--max-dimming",
        default=None,
        metavar="FRACTION|RASTER",
        help="Largest fraction of any cell's flux the targets may remove: a number in [0, 1] or "
        "a raster on EMISSION's grid [1] (default 1).",
    ),
)


@inverse.command("dim")
@files_argument("EMISSION OUTPUT", RASTER, RASTER)
@output_option
@overwrite_option
@rule_options
@dem_option
@kernel_option
@dimming_products
@click.pass_context
@max_memory_option
def dim_command(
    ctx: click.Context,
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    by: str,
    qa: float,
    qb: float,
    gamma: float,
    dem: str | None,
    kernel: str | None,
    dimming_output: str | None,
    old_dimming_out: str | None,
    summary_output: str | None,
    old_summary: str | None,
    png: str | None,
) -> None:
    """Dim EMISSION by a Q or S raster (--by) with the rule of Dobashi Eq. 12: no dimming
    below Q_a, the fraction gamma above Q_b, linear between; write OUTPUT."""
    dimming_output, summary_output = _products(
        ctx, dimming_output, old_dimming_out, summary_output, old_summary
    )
    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    check_outputs([dimming_output, summary_output, png], overwrite=overwrite)
    from nightlights import inverse as library

    result = library.inverse_reduce(
        scene_of(emission, dem=dem, kernel=kernel),
        out,
        by=by,
        qa=qa,
        qb=qb,
        gamma=gamma,
        dimming_output=dimming_output,
        summary_output=summary_output,
        png=png,
    )
    _print(_summary_lines(result.summary, out))


@inverse.command("plan")
@files_argument("EMISSION OUTPUT", RASTER, RASTER)
@output_option
@overwrite_option
@observers_option
@target_options
@observer_crs_option
@observer_height_option
@dem_option
@kernel_option
@dimming_products
@click.pass_context
@max_memory_option
def plan_command(
    ctx: click.Context,
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    observers: tuple[str, ...],
    target_zenith: float | None,
    target_region: tuple[str, ...],
    max_dimming: str | None,
    observer_crs: str | None,
    observer_height: float,
    dem: str | None,
    kernel: str | None,
    dimming_output: str | None,
    old_dimming_out: str | None,
    summary_output: str | None,
    old_summary: str | None,
    png: str | None,
) -> None:
    """Dim EMISSION by the least flux that meets sky-brightness targets (--target-zenith,
    --target-region) for every --observer: a linear program; write OUTPUT."""
    if target_zenith is None and not target_region:
        raise click.UsageError("give --target-zenith and/or --target-region", ctx)
    if not observers:
        raise click.UsageError("give the targets' --observer X,Y (repeat for several)", ctx)
    targets = [_region_target(text) for text in target_region]
    for text in observers:  # the syntax checked before any work
        parse_pair(text)
    cap = _max_dimming(max_dimming)
    dimming_output, summary_output = _products(
        ctx, dimming_output, old_dimming_out, summary_output, old_summary
    )
    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    check_outputs([dimming_output, summary_output, png], overwrite=overwrite)
    from nightlights import inverse as library

    result = library.least_dimming(
        scene_of(emission, dem=dem, kernel=kernel),
        [observer_of(text, observer_crs, observer_height) for text in observers],
        out,
        target_zenith=target_zenith,
        target_region=targets,
        max_dimming=cap,
        dimming_output=dimming_output,
        summary_output=summary_output,
        png=png,
    )
    _print(_summary_lines(result.summary, out))


def _products(
    ctx: click.Context,
    dimming_output: str | None,
    old_dimming_out: str | None,
    summary_output: str | None,
    old_summary: str | None,
) -> tuple[str | None, str | None]:
    """``--dimming-output`` and ``--summary-output``, or their deprecated spellings."""
    return (
        one_of(ctx, **{"--dimming-output": dimming_output, "--dimming-out": old_dimming_out}),
        one_of(ctx, **{"--summary-output": summary_output, "--summary": old_summary}),
    )


# --- reduce: both, deprecated -------------------------------------------------------------------


@inverse.command(
    "reduce",
    cls=DeprecatedCommand,
    replacement="`inverse dim` (`--by`, `--qa`, `--qb`, `--gamma`) or `inverse plan` "
    "(`--target-zenith`, `--target-region`, `--max-dimming`)",
)
@files_argument("EMISSION OUTPUT", RASTER, RASTER)
@output_option
@overwrite_option
@click.option("--by", type=click.Path(exists=True, dir_okay=False), default=None)
@click.option("--qa", type=float, default=None)
@click.option("--qb", type=float, default=None)
@click.option("--gamma", type=float, default=1.0)
@target_options
@observers_option
@observer_crs_option
@observer_height_option
@dem_option
@kernel_option
@dimming_products
@click.pass_context
@max_memory_option
def reduce_command(ctx: click.Context, **params: Any) -> None:
    """Deprecated: inverse dim (--by) or inverse plan (--target-zenith, --target-region)."""
    by_mode = params["by"] is not None
    target_mode = params["target_zenith"] is not None or bool(params["target_region"])
    if by_mode == target_mode:
        raise click.UsageError(
            "give either --by Q/S raster with --qa and --qb (inverse dim), or --target-zenith "
            "and/or --target-region with --observer (inverse plan); "
            + ("not both" if by_mode else "neither was given"),
            ctx,
        )
    rule = ("by", "qa", "qb", "gamma")
    plan = (
        "observers",
        "target_zenith",
        "target_region",
        "max_dimming",
        "observer_crs",
        "observer_height",
    )
    command, own, other = (dim_command, rule, plan) if by_mode else (plan_command, plan, rule)
    flags = {param.name: param.opts[0] for param in ctx.command.params}
    given = [
        flags[name]
        for name in other
        if ctx.get_parameter_source(name) is click.core.ParameterSource.COMMANDLINE
    ]
    if given:
        raise click.UsageError(f"{', '.join(given)}: not an option of inverse {command.name}", ctx)
    if by_mode and (params["qa"] is None or params["qb"] is None):
        raise click.UsageError("--by needs --qa and --qb", ctx)
    group = ctx.parent.command_path if ctx.parent is not None else "nightlights inverse"
    warn_deprecated(ctx, f"{ctx.command_path} is deprecated; use {group} {command.name}.")
    shared = (
        "files",
        "output",
        "overwrite",
        "dem",
        "kernel",
        "dimming_output",
        "old_dimming_out",
        "summary_output",
        "old_summary",
        "png",
    )
    ctx.invoke(command, **{name: params[name] for name in (*shared, *own)})


# --- helpers ------------------------------------------------------------------------------------


def _region_target(text: str) -> tuple[str, float]:
    """``REGION:MAG`` -> (region, magnitude [mag arcsec-2]); split at the last colon."""
    region, colon, magnitude = text.rpartition(":")
    try:
        if not (colon and region.strip()):
            raise ValueError(text)
        value = float(magnitude)
    except ValueError:
        raise click.BadParameter(
            f"{text!r}; expected REGION:MAG, e.g. zenith:30:21.5", param_hint="--target-region"
        ) from None
    return region, value


def _max_dimming(text: str | None) -> float | str:
    """A number [1] or an existing raster path; the library checks the range."""
    if text is None:
        return 1.0
    try:
        return float(text)
    except ValueError:
        if Path(text).is_file():
            return text
    raise click.BadParameter(
        f"{text!r}; expected a number in [0, 1] or an existing raster", param_hint="--max-dimming"
    )


def _magnitude(values: Mapping[str, Any], when: str) -> str:
    value = values.get(f"{when}_mag_arcsec2")
    return "?" if value is None else f"{float(value):.2f}"


def _summary_lines(summary: Mapping[str, Any], out: str) -> list[str]:
    """A short human summary of a dimming: flux removed and the sky before -> after."""
    removed = float(summary.get("flux_removed_lm", float("nan")))
    percent = float(summary.get("flux_removed_percent", float("nan")))
    total = float(summary.get("flux_before_lm", float("nan")))
    line = f"flux removed: {removed:.4g} lm = {percent:.2f} % of {total:.4g} lm"
    if "dimmed_cells" in summary and "lit_cells" in summary:
        line += f" ({summary['dimmed_cells']} of {summary['lit_cells']} lit cells dimmed)"
    lines = [f"{line} -> {out}"]
    for index, observer in enumerate(summary.get("observers", ()), start=1):
        parts = []
        zenith = observer.get("zenith")
        if zenith:
            parts.append(f"zenith {_magnitude(zenith, 'before')} -> {_magnitude(zenith, 'after')}")
        for region in observer.get("regions", ()):
            parts.append(
                f"region {region.get('region', '?')} {_magnitude(region, 'before')} -> "
                f"{_magnitude(region, 'after')}"
            )
        where = f"({float(observer.get('x', float('nan'))):.1f}, "
        where += f"{float(observer.get('y', float('nan'))):.1f})"
        lines.append(f"observer {index} {where}: {'; '.join(parts)} mag arcsec-2")
    method = (
        summary.get("plan", {}).get("method") if isinstance(summary.get("plan"), dict) else None
    )
    if method:
        lines.append(f"least-flux plan solved by {method}")
    return lines


def _report_influence(result: Any, out: str) -> None:
    """One line: what the raster holds, its total and the forward panorama's value."""
    total, panorama = float(result.total), float(result.panorama_value)
    if result.metric == "pca-norm":
        line = f"Q_i (pca-norm): sum over cells {total:.4g} cd m-2"
    else:
        line = (
            f"{result.metric}: sum over cells {total:.4g} cd m-2, forward panorama "
            f"{panorama:.4g} cd m-2"
        )
        if result.metric == "zenith":
            from nightlights.brightness import luminance_to_magnitude

            line += f" = {float(luminance_to_magnitude(panorama)):.2f} mag arcsec-2"
    _print([f"{line}; {1000 * float(result.seconds):.1f} ms -> {out}"])


def _print(lines: list[str]) -> None:
    from rich.console import Console

    console = Console(stderr=True)
    for line in lines:
        console.print(line, soft_wrap=True, markup=False, highlight=False)


commands = [inverse]
