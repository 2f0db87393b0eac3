"""``nightlights streets plan``: a per-light dimming that keeps every road lit under sky targets.

The lights are rated against their street segments' classes
(:func:`nightlights.roads.road_model`); the sky targets, if any, are built per light
(:func:`nightlights.inverse.sky_matrix`) on an emission grid of ``--cell-size`` that holds
every light (:func:`nightlights.inverse.road_sky.lights_emission`); the plan is
:func:`nightlights.roads.road_plan`. OUTPUT is the light layer with a ``dimming`` field.
"""

from __future__ import annotations

import warnings
from typing import Any

import click

from .kinds import JSON, LINES, POINTS, KindPath
from .options import (
    PLAN_OBJECTIVES,
    LibraryChoice,
    catalog_option,
    check_outputs,
    files_argument,
    kernel_option,
    observer_crs_option,
    observer_of,
    observers_option,
    output_option,
    overwrite_option,
    parse_pair,
    resolve_inout,
)

#: Cell of the emission grid the sky targets are computed on [m] (the inverse commands'
#: rasters are 100 m; the per-light approximation assumes a light's reflected flux stays
#: in its cell, see nightlights.inverse.road_sky).
CELL_SIZE = 100.0


@click.command("plan")
@files_argument("LIGHTS STREETS OUTPUT", POINTS, LINES, POINTS)
@output_option
@overwrite_option
@observers_option
@observer_crs_option
@kernel_option
@click.option(
    "--target-zenith",
    type=float,
    default=None,
    metavar="MAG",
    help="Zenith sky brightness every --observer must reach [mag arcsec-2].",
)
@click.option(
    "--zenith-reduction",
    type=float,
    default=None,
    metavar="FRACTION",
    help="Fraction by which the zenith luminance at every --observer must fall [1].",
)
@click.option(
    "--cell-size",
    type=float,
    default=CELL_SIZE,
    show_default=True,
    help="Cell of the emission grid of the sky targets [m].",
)
@click.option(
    "--objective",
    type=LibraryChoice(PLAN_OBJECTIVES),
    default="energy",
    show_default=True,
    help="Minimise the lights' power or their luminous flux.",
)
@click.option(
    "--min-dimming",
    type=float,
    default=0.0,
    show_default=True,
    help="Lowest level any light may take [1].",
)
@click.option(
    "--rtable",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="The road surface's r-table (default: the analytic stand-in, with a warning).",
)
@click.option(
    "--requirements",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Requirements by class (TOML; default: EN 13201-2:2015 Tables 1-3).",
)
@catalog_option
@click.option(
    "--json",
    "summary_json",
    type=KindPath(JSON, dir_okay=False),
    default=None,
    help="Write the summary as JSON.",
)
@click.pass_context
def plan(
    ctx: click.Context,
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    observers: tuple[str, ...],
    observer_crs: str | None,
    kernel: str | None,
    target_zenith: float | None,
    zenith_reduction: float | None,
    cell_size: float,
    objective: str,
    min_dimming: float,
    rtable: str | None,
    requirements: str | None,
    catalog: str | None,
    summary_json: str | None,
) -> None:
    """Dim LIGHTS by the least energy (or flux) that keeps every segment of STREETS at its
    lighting class and meets the sky targets (--target-zenith, --zenith-reduction) for every
    --observer; write OUTPUT (the lights with a 'dimming' field)."""
    skied = target_zenith is not None or zenith_reduction is not None
    if skied and not observers:
        raise click.UsageError("give the sky targets' --observer X,Y (repeat for several)", ctx)
    if observers and not skied:
        raise click.UsageError("give --target-zenith and/or --zenith-reduction", ctx)
    for text in observers:
        parse_pair(text)
    (lights_path, streets_path), out = resolve_inout(
        files, output, inputs=2, usage="LIGHTS STREETS OUTPUT", overwrite=overwrite
    )
    check_outputs([summary_json], overwrite=overwrite)
    summary = run_plan(
        lights_path,
        streets_path,
        out,
        observers=[observer_of(text, observer_crs, 0.0) for text in observers],
        kernel=kernel,
        target_zenith=target_zenith,
        zenith_reduction=zenith_reduction,
        cell_size=cell_size,
        objective=objective,
        min_dimming=min_dimming,
        rtable=rtable,
        requirements=requirements,
        catalog=catalog,
    )
    if summary_json is not None:
        from nightlights.io.atomic import atomic_output
        from nightlights.io.jsonfile import dumps_json

        with atomic_output(summary_json) as tmp:
            tmp.write_text(dumps_json(summary, indent=2) + "\n", encoding="utf-8")
    for line in summary_lines(summary, out):
        click.echo(line)


def run_plan(
    lights_path: str,
    streets_path: str,
    out: str,
    *,
    observers: list[Any],
    kernel: str | None,
    target_zenith: float | None,
    zenith_reduction: float | None,
    cell_size: float,
    objective: str,
    min_dimming: float,
    rtable: str | None,
    requirements: str | None,
    catalog: str | None,
) -> dict[str, Any]:
    """Build the model and the sky, solve the plan, write OUTPUT; the summary."""
    import numpy as np
    from affine import Affine

    from nightlights import roads
    from nightlights.errors import DataQualityWarning, InputError
    from nightlights.inverse.road_sky import lights_emission, sky_matrix
    from nightlights.io import Raster, as_vector, write_gpkg
    from nightlights.io.outputs import OutputSet
    from nightlights.sky import Scene

    if not cell_size > 0:
        raise InputError(f"--cell-size={cell_size!r}: expected a cell size above 0 [m]")
    frame, _ = as_vector(lights_path, name="lights")
    with OutputSet(out, inputs={"lights": lights_path, "streets": streets_path}) as outputs:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", DataQualityWarning)
            model = roads.road_model(
                lights_path, streets_path, catalog=catalog, rtable=rtable, requirements=requirements
            )
        for warning in caught:
            click.echo(f"Warning: {warning.message}", err=True)
        sky = None
        if observers:
            points = model.luminaires.light_point
            x0, y0 = points[:, 0].min() - cell_size, points[:, 1].max() + cell_size
            cols = int(np.ceil((points[:, 0].max() + cell_size - x0) / cell_size)) + 1
            rows = int(np.ceil((y0 - points[:, 1].min() + cell_size) / cell_size)) + 1
            grid = Raster(
                np.zeros((1, rows, cols)),
                Affine(cell_size, 0, x0, 0, -cell_size, y0),
                model.segments.crs.to_wkt(),
            )
            scene = Scene(lights_emission(model.luminaires, grid), kernel=kernel)
            sky = sky_matrix(
                model.luminaires,
                scene,
                observers,
                target_zenith=target_zenith,
                zenith_reduction=zenith_reduction,
            )
        result = roads.road_plan(model, sky, objective=objective, min_dimming=min_dimming)
        if len(model.luminaires) != len(frame):
            raise InputError(f"{lights_path}: lights were dropped; expected one luminaire per row")
        layer = frame.reset_index(drop=True).copy()
        layer["dimming"] = result.dimming
        write_gpkg(layer, outputs.temporary(out), layer="lights")
    return summary_of(result, out)


def summary_of(result: Any, out: str) -> dict[str, Any]:
    """The plan's figures as JSON-ready numbers."""
    import numpy as np

    def passed(frame: Any) -> int:
        return int(frame["passed"].fillna(False).astype(bool).sum())

    rated = int(result.before["passed"].notna().sum())
    unit = "W" if result.objective == "energy" else "lm"
    return {
        "output": out,
        "feasible": bool(result.feasible),
        "objective": result.objective,
        "unit": unit,
        "lights": len(result.dimming),
        "lights_dimmed": int(np.sum(result.dimming < 1.0 - 1e-9)),
        "cost_full": result.cost_full,
        "cost": result.cost,
        "saved": result.saved,
        "saved_share": result.saved / result.cost_full if result.cost_full > 0 else None,
        "cost_sky_only": result.cost_sky_only,
        "cost_of_safety": result.cost_of_safety,
        "segments_rated": rated,
        "segments_passing_before": passed(result.before),
        "segments_passing_after": passed(result.after),
        "sky": result.sky.to_dict(orient="records"),
        "binding": result.binding.to_dict(orient="records"),
    }


def summary_lines(summary: dict[str, Any], out: str) -> list[str]:
    """The summary as the command prints it."""
    unit = summary["unit"]
    lines = [
        f"{'Plan' if summary['feasible'] else 'No plan meets both'}: {out} "
        f"({summary['lights_dimmed']} of {summary['lights']} lights dimmed)",
        f"  {summary['objective']}: {summary['cost']:.6g} {unit} of {summary['cost_full']:.6g} "
        f"(saved {summary['saved']:.6g} {unit})",
        f"  cost of safety: {summary['cost_of_safety']:.6g} {unit} over the sky-only plan "
        f"({summary['cost_sky_only']:.6g} {unit})",
        f"  segments keeping their class: {summary['segments_passing_before']} before, "
        f"{summary['segments_passing_after']} after, of {summary['segments_rated']} rated",
    ]
    for target in summary["sky"]:
        lines.append(
            f"  sky {target['target']}: {target['before_cd_m2']:.4g} -> "
            f"{target['after_cd_m2']:.4g} cd m-2 (goal {target['goal_cd_m2']:.4g})"
        )
    for row in summary["binding"]:
        lines.append(
            f"  binding segment {row['segment']} ({row['lighting_class']}): short by "
            f"{row['slack']:.3g} of its requirement ({row['criteria']})"
        )
    return lines
