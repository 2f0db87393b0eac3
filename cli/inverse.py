"""``nightlights inverse``: which lights cause the glow an observer sees, and how to dim them.

Three subcommands over :mod:`nightlights.inverse` (Dobashi et al. 2023, Sec. 4):

- ``inverse q EMISSION Q``: each lit cell's light-pollution level Q_i (Eqs. 10-11), or its
  part of the zenith or hemisphere-mean sky luminance;
- ``inverse s EMISSION S --region REGION``: each cell's part of the skyglow in a region of the
  sky (Eqs. 13-14);
- ``inverse reduce EMISSION REDUCED``: dim the emission, either by a Q or S raster (Eq. 12,
  ``--by``) or by the least flux that meets sky-brightness targets (``--target-zenith``,
  ``--target-region``).

Like every command module this imports only click; the choices below mirror constants of the
library (``tests/cli/test_inverse.py`` checks that they are equal).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, TypeVar

import click

from cli.options import (
    check_outputs,
    files_argument,
    output_option,
    overwrite_option,
    resolve_inout,
)
from cli.skyglow import parse_pair

F = TypeVar("F", bound=Callable[..., Any])

# --- mirrors of library constants (checked by tests/cli/test_inverse.py) ----------------------
#: nightlights.sky.influence.METRICS
Q_METRICS = ("pca-norm", "zenith", "hemisphere")
#: nightlights.sky.influence.WEIGHTS
S_WEIGHTS = ("solid-angle", "pixel")
#: nightlights.inverse.stage.S_METHODS
S_METHODS = ("pca", "brute")

REGION_HELP = (
    "Region of the sky: 'az,el az,el ...' (closed: the first vertex repeated at the end), "
    "zenith:R, horizon:AZ1,AZ2,EL, or a GeoJSON/WKT polygon file (x azimuth, y elevation) [deg]."
)


# --- options shared by the subcommands ----------------------------------------------------------

observer_crs_option = click.option(
    "--observer-crs", default=None, metavar="CRS", help="CRS of --observer (default: the raster's)."
)
observer_height_option = click.option(
    "--observer-height", default=1.7, show_default=True, help="Above ground [m]."
)
dem_option = click.option(
    "--dem",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Terrain heights above sea level [m] (raster): observer altitude, each lit cell's own "
    "source altitude, horizon mask.",
)
kernel_option = click.option(
    "--kernel",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Precomputed kernel (nightlights kernel build); default: cached scene kernel.",
)


def scene_options(function: F) -> F:
    """The observer and scene options of ``inverse q`` and ``inverse s`` (as ``skyglow``)."""
    decorators = [
        click.option(
            "--observer", required=True, metavar="X,Y", help="Observer X,Y (in --observer-crs)."
        ),
        observer_crs_option,
        observer_height_option,
        dem_option,
        kernel_option,
        click.option("--turbidity", type=float, default=None, help="Turbidity T (default 2)."),
        click.option(
            "--n-azimuth",
            type=int,
            default=None,
            help="Panorama columns (default 256; a given --kernel fixes it).",
        ),
        click.option(
            "--n-elevation",
            type=int,
            default=None,
            help="Panorama rows (default 64; a given --kernel fixes it).",
        ),
        click.option(
            "--n-distance",
            type=int,
            default=None,
            help="Distance bins of the scene kernel built when --kernel is not given (default "
            "64; a given --kernel fixes it).",
        ),
    ]
    for decorator in reversed(decorators):
        function = decorator(function)
    return function


@click.group("inverse")
def inverse() -> None:
    """Which lights cause an observer's skyglow (per-cell rasters), and how to dim them.

    \b
    nightlights inverse q EMISSION Q --observer X,Y [--metric pca-norm|zenith|hemisphere]
    nightlights inverse s EMISSION S --observer X,Y --region REGION
    nightlights inverse reduce EMISSION REDUCED --by Q --qa A --qb B [--gamma G]
    nightlights inverse reduce EMISSION REDUCED --observer X,Y --target-zenith MAG

    REGION is 'az,el az,el ...' (closed polygon), zenith:R, horizon:AZ1,AZ2,EL or a
    GeoJSON/WKT file, angles in degrees (azimuth clockwise from north).
    """


# --- q and s ------------------------------------------------------------------------------------


@inverse.command("q")
@files_argument("EMISSION OUTPUT")
@output_option
@overwrite_option
@scene_options
@click.option(
    "--metric",
    type=click.Choice(Q_METRICS),
    default="pca-norm",
    show_default=True,
    help="pca-norm: Q_i, the norm of the cell's PCA coefficients (Dobashi Eq. 11); zenith: the "
    "cell's part of the zenith luminance [cd m-2]; hemisphere: its part of the mean luminance "
    "of the visible sky [cd m-2].",
)
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
    metric: str,
) -> None:
    """Each lit cell's light-pollution level for an observer: write OUTPUT (one-band COG on
    EMISSION's grid, NaN where unlit)."""
    from nightlights import inverse as library

    observer_xy = parse_pair(observer)
    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    result = library.inverse_q(
        emission,
        out,
        observer=observer_xy,
        observer_crs=observer_crs,
        observer_height=observer_height,
        dem=dem,
        kernel=kernel,
        metric=metric,
        turbidity=turbidity,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        n_distance=n_distance,
    )
    _report_influence(result, out)


@inverse.command("s")
@files_argument("EMISSION OUTPUT")
@output_option
@overwrite_option
@scene_options
@click.option("--region", required=True, metavar="REGION", help=REGION_HELP)
@click.option(
    "--weight",
    type=click.Choice(S_WEIGHTS),
    default="solid-angle",
    show_default=True,
    help="solid-angle: the cell's part of the region's solid-angle-weighted mean luminance; "
    "pixel: the sum over the region's panorama pixels (Dobashi Eq. 14).",
)
@click.option(
    "--method",
    type=click.Choice(S_METHODS),
    default="pca",
    show_default=True,
    help="pca: FFT cross-correlation with the PCA bases (fast); brute: each cell's raw kernel "
    "image summed over the region (the reference).",
)
@click.option(
    "--components",
    type=int,
    default=None,
    help="PCA bases to use at run time, the first of those the kernel stores (default: all).",
)
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

    observer_xy = parse_pair(observer)
    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    result = library.inverse_s(
        emission,
        out,
        observer=observer_xy,
        region=region,
        weight=weight,
        method=method,
        components=components,
        observer_crs=observer_crs,
        observer_height=observer_height,
        dem=dem,
        kernel=kernel,
        turbidity=turbidity,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        n_distance=n_distance,
    )
    _report_influence(result, out)


# --- reduce -------------------------------------------------------------------------------------


@inverse.command("reduce")
@files_argument("EMISSION OUTPUT")
@output_option
@overwrite_option
@click.option(
    "--by",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Dim by this Q or S raster (inverse q / inverse s) by Dobashi Eq. 12; needs --qa, --qb.",
)
@click.option("--qa", type=float, default=None, help="Q_a: no dimming below it [unit of --by].")
@click.option(
    "--qb", type=float, default=None, help="Q_b: full --gamma dimming above it [unit of --by]."
)
@click.option(
    "--gamma",
    type=float,
    default=1.0,
    show_default=True,
    help="gamma_usr in [0, 1]: the fraction of flux removed above Q_b [1].",
)
@click.option(
    "--target-zenith",
    type=float,
    default=None,
    metavar="MAG",
    help="Zenith sky brightness every --observer must reach [mag arcsec-2]; the least flux is "
    "removed.",
)
@click.option(
    "--target-region",
    "target_regions",
    multiple=True,
    metavar="REGION:MAG",
    help="A region of the sky and the brightness its mean must reach for every --observer "
    "[mag arcsec-2]; split at the last colon (zenith:30:21.5); repeat for several.",
)
@click.option(
    "--observer",
    "observers",
    multiple=True,
    metavar="X,Y",
    help="Observer X,Y (in --observer-crs) of the targets; repeat for several.",
)
@observer_crs_option
@observer_height_option
@dem_option
@kernel_option
@click.option(
    "--max-dimming",
    default=None,
    metavar="FRACTION|RASTER",
    help="Largest fraction of any cell's flux the targets may remove: a number in [0, 1] or a "
    "raster on EMISSION's grid [1] (default 1).",
)
@click.option(
    "--dimming-out",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write the dimming fraction of each cell (COG, band 'dimming') [1].",
)
@click.option(
    "--summary",
    "summary_out",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write the summary (flux removed, sky before and after) as JSON.",
)
@click.option(
    "--png",
    default=None,
    type=click.Path(dir_okay=False),
    help="Before/after panoramas of the first observer side by side.",
)
@click.pass_context
def reduce_command(
    ctx: click.Context,
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    by: str | None,
    qa: float | None,
    qb: float | None,
    gamma: float,
    target_zenith: float | None,
    target_regions: tuple[str, ...],
    observers: tuple[str, ...],
    observer_crs: str | None,
    observer_height: float,
    dem: str | None,
    kernel: str | None,
    max_dimming: str | None,
    dimming_out: str | None,
    summary_out: str | None,
    png: str | None,
) -> None:
    """Dim EMISSION and write OUTPUT: by a Q/S raster (--by, Dobashi Eq. 12), or by the least
    flux that meets sky-brightness targets (--target-zenith, --target-region)."""
    by_mode = by is not None
    target_mode = target_zenith is not None or bool(target_regions)
    if by_mode == target_mode:
        raise click.UsageError(
            "give either --by Q/S raster with --qa and --qb, or --target-zenith and/or "
            "--target-region with --observer; " + ("not both" if by_mode else "neither was given"),
            ctx,
        )
    targets = [_region_target(text) for text in target_regions]
    if by_mode:
        _refuse(
            ctx,
            "apply only to --target-zenith/--target-region (--by names its observer)",
            **{
                "--observer": observers or None,
                "--observer-crs": observer_crs,
                "--max-dimming": max_dimming,
                "--observer-height": _changed(ctx, "observer_height"),
            },
        )
        if qa is None or qb is None:
            raise click.UsageError("--by needs --qa and --qb", ctx)
    else:
        _refuse(
            ctx,
            "apply only to --by",
            **{"--qa": qa, "--qb": qb, "--gamma": _changed(ctx, "gamma")},
        )
        if not observers:
            raise click.UsageError("--target-zenith/--target-region need --observer X,Y", ctx)
    observer_xys = [parse_pair(text) for text in observers]
    cap = _max_dimming(max_dimming)
    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    check_outputs([dimming_out, summary_out, png], overwrite=overwrite)

    from nightlights import inverse as library

    if by_mode:
        assert by is not None and qa is not None and qb is not None
        result = library.inverse_reduce(
            emission,
            out,
            by=by,
            qa=qa,
            qb=qb,
            gamma=gamma,
            dem=dem,
            kernel=kernel,
            dimming_output=dimming_out,
            summary_output=summary_out,
            png=png,
        )
    else:
        result = library.least_dimming(
            emission,
            out,
            observers=observer_xys,
            target_zenith=target_zenith,
            target_region=targets,
            max_dimming=cap,
            observer_crs=observer_crs,
            observer_height=observer_height,
            dem=dem,
            kernel=kernel,
            dimming_output=dimming_out,
            summary_output=summary_out,
            png=png,
        )
    _print(_summary_lines(result.summary, out))


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


def _changed(ctx: click.Context, name: str) -> Any:
    """The value of option ``name`` when given on the command line, else None."""
    source = ctx.get_parameter_source(name)
    return ctx.params[name] if source is click.core.ParameterSource.COMMANDLINE else None


def _refuse(ctx: click.Context, why: str, **given: Any) -> None:
    """Usage error naming the options among ``given`` that were set."""
    named = [name for name, value in given.items() if value is not None]
    if named:
        raise click.UsageError(f"{', '.join(named)}: {why}", ctx)


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
