"""The tasks of the sky stages: per observer (skyglow, inverse q and s) or once."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from nightlights.project._schema import Observer, Project
from nightlights.project._tasks import Builder, Context, Task, dem_needs, kernel_spec, one
from nightlights.sky.observer import OBSERVER_HEIGHT

if TYPE_CHECKING:
    import geopandas as gpd

    from nightlights.sky.scene import Scene

#: The highest share of lit cells a finding about an inverse map counts [1].
FINDING_CELLS = 10


def _sky_options(project: Project, options: dict[str, Any]) -> dict[str, Any]:
    """A sky task's key parts: its options, the atmosphere and the kernel's content hash."""
    spec = kernel_spec(project)
    return options | {
        "turbidity": project.file.atmosphere.turbidity,
        "kernel": None if spec is None else spec.content_hash,
    }


def _scene(ctx: Context, stage: str, src: dict[str, Path]) -> Scene:
    """The project's scene for a sky stage: its emission and DEM, the project's kernel (or the
    stage's grid of a scene kernel) and its atmosphere."""
    from nightlights.sky.scene import Scene

    kernel = ctx.kernel()
    o = ctx.project.options(stage)
    grid = (
        {}
        if kernel is not None
        else {"n_azimuth": o.n_azimuth, "n_elevation": o.n_elevation, "n_distance": o.n_distance}
    )
    return Scene(
        src["emission"],
        dem=src.get("inputs.dem"),
        kernel=kernel,
        turbidity=None if kernel is not None else ctx.project.file.atmosphere.turbidity,
        **grid,
    )


def _per_observer(
    project: Project,
    stage: str,
    options: dict[str, Any],
    outputs: Callable[[str], dict[str, str]],
    compute: Callable[[Context, dict[str, Path], dict[str, Path], Observer], dict[str, Any]],
) -> list[Task]:
    """A task per observer of ``stage``: ``outputs(name)`` names its files."""
    tasks = []
    for observer in project.observers_of(stage):

        def bound(
            ctx: Context, out: dict[str, Path], src: dict[str, Path], observer: Observer = observer
        ) -> dict[str, Any]:
            return compute(ctx, out, src, observer)

        tasks.append(
            Task(
                f"{stage}:{observer.name}",
                stage,
                outputs(observer.name),
                ("emission", *dem_needs(project)),
                _sky_options(project, options) | {"observer": observer.key()},
                bound,
                observer,
            )
        )
    return tasks


def _skyglow(project: Project, options: dict[str, Any]) -> list[Task]:
    o = project.options("skyglow")

    def compute(
        ctx: Context, out: dict[str, Path], src: dict[str, Path], observer: Observer
    ) -> dict[str, Any]:
        import nightlights as nl

        key = f"skyglow_{observer.name}"
        sky = nl.skyglow(
            _scene(ctx, "skyglow", src),
            observer.sky(),
            out[key],
            mode=o.mode,
            components=o.components,
            png=out.get(f"{key}_png"),
            projection=(
                o.projection
                if isinstance(o.projection, str)
                else o.projection.get(observer.name, "equirectangular")
            ),
            polar_output=out.get(f"{key}_polar"),
            bands=o.bands,
            spectrum=o.spectrum,
            progress=ctx.progress,
        )
        return {"zenith": [sky.zenith_magnitude, sky.bortle]}

    def outputs(name: str) -> dict[str, str]:
        files = {f"skyglow_{name}": f"skyglow_{name}.nc"}
        if o.png:
            files[f"skyglow_{name}_png"] = f"skyglow_{name}.png"
        if o.polar_output:
            files[f"skyglow_{name}_polar"] = f"polar_{name}.nc"
        return files

    return _per_observer(project, "skyglow", options, outputs, compute)


def _observers(project: Project, options: dict[str, Any]) -> list[Task]:
    o = project.options("observers")

    def compute(ctx: Context, out: dict[str, Path], src: dict[str, Path]) -> dict[str, Any]:
        from nightlights.sky.observers import observers
        from nightlights.sky.scene import Scene

        points = ctx.project.observers
        panoramas = out.get("observers_panoramas")
        if panoramas is not None:
            panoramas.mkdir()
        kernel = ctx.kernel()
        scene = Scene(
            src["emission"],
            dem=src.get("inputs.dem"),
            kernel=kernel,
            turbidity=None if kernel is not None else ctx.project.file.atmosphere.turbidity,
        )
        result = observers(
            scene,
            [p.sky() for p in points],
            out["observers"],
            panoramas=panoramas,
            top_cells=o.top_cells,
            scheduler=o.scheduler,
            overwrite=True,
            progress=ctx.progress,
        )
        return {"seconds_observers": result.seconds}

    outputs = {"observers": "observers.gpkg"}
    if o.panoramas:
        outputs["observers_panoramas"] = "observers_panoramas"
    keys = [p.key() for p in project.observers]
    return one(
        "observers",
        outputs,
        ("emission", *dem_needs(project)),
        _sky_options(project, options) | {"observers": keys},
        compute,
    )


def _marker(observer: Observer, crs: Any) -> gpd.GeoDataFrame:
    import geopandas as gpd
    from shapely.geometry import Point

    points = gpd.GeoDataFrame(geometry=[Point(observer.x, observer.y)], crs=observer.crs or crs)
    return points.to_crs(crs)


def _share_map(ctx: Context, raster: Any, path: Path, title: str, observer: Observer) -> None:
    from nightlights.maps import plot_raster_map

    top = float(np.nanmax(raster.data))
    plot_raster_map(
        raster,
        path,
        points=_marker(observer, raster.crs),
        points_label="observer",
        points_size=40.0,
        floor=top * 1e-3,
        title=title,
        credit=ctx.project.file.project.credit,
    )


def _top_share(data: Any) -> tuple[float, int]:
    """The share of the sum that the brightest :data:`FINDING_CELLS` cells hold, and the count."""
    values = np.sort(np.asarray(data, dtype=float)[np.isfinite(data)])[::-1]
    total = values.sum()
    return (float(values[:FINDING_CELLS].sum() / total) if total > 0 else 0.0), int(values.size)


def _inverse_q(project: Project, options: dict[str, Any]) -> list[Task]:
    o = project.options("inverse-q")

    def compute(
        ctx: Context, out: dict[str, Path], src: dict[str, Path], observer: Observer
    ) -> dict[str, Any]:
        import nightlights as nl

        key = f"inverse_q_{observer.name}"
        q = nl.inverse_q(
            _scene(ctx, "inverse-q", src),
            observer.sky(),
            out[key],
            metric=o.metric,
            progress=ctx.progress,
        )
        title = f"Q ({o.metric}): each cell's part at {observer.name}"
        what = {"zenith": "the zenith", "hemisphere": "the sky's mean luminance"}.get(
            o.metric, "the sum of Q"
        )
        return _influence_facts(ctx, q.raster, out.get(f"{key}_map"), title, observer, what)

    return _per_observer(
        project, "inverse-q", options, lambda name: _influence_outputs("q", name, o.map), compute
    )


def _inverse_s(project: Project, options: dict[str, Any]) -> list[Task]:
    o = project.options("inverse-s")

    def compute(
        ctx: Context, out: dict[str, Path], src: dict[str, Path], observer: Observer
    ) -> dict[str, Any]:
        import nightlights as nl

        key = f"inverse_s_{observer.name}"
        s = nl.inverse_s(
            _scene(ctx, "inverse-s", src),
            observer.sky(),
            out[key],
            region=o.region,
            weight=o.weight,
            method=o.method,
            components=o.components,
            progress=ctx.progress,
        )
        title = f"S: each cell's part of the sky {o.region} from {observer.name}"
        what = f"the sky {o.region}"
        return _influence_facts(ctx, s.raster, out.get(f"{key}_map"), title, observer, what)

    return _per_observer(
        project, "inverse-s", options, lambda name: _influence_outputs("s", name, o.map), compute
    )


def _influence_outputs(kind: str, name: str, with_map: bool) -> dict[str, str]:
    files = {f"inverse_{kind}_{name}": f"inverse_{kind}_{name}.tif"}
    if with_map:
        files[f"inverse_{kind}_{name}_map"] = f"inverse_{kind}_{name}.png"
    return files


def _influence_facts(
    ctx: Context, raster: Any, png: Path | None, title: str, observer: Observer, what: str
) -> dict[str, Any]:
    """Draw an inverse map (when asked) and say how much its brightest cells hold."""
    if png is not None:
        _share_map(ctx, raster, png, title, observer)
    share, count = _top_share(raster.data)
    return {
        "findings": [
            f"{what} at {observer.name}: the brightest {FINDING_CELLS} of {count} lit cells "
            f"give {100 * share:.0f} % of it"
        ]
    }


def _threshold(value: float | str, lit: Any) -> float:
    """A Q/S threshold: the value, or the percentile of the lit cells (``"50%"``)."""
    if isinstance(value, str):
        return float(np.percentile(lit, float(value[:-1])))
    return float(value)


def _inverse_reduce(project: Project, options: dict[str, Any]) -> list[Task]:
    o = project.options("inverse-reduce")
    by_stage = o.by
    if o.observer is not None:
        name = o.observer
    else:
        name = project.observers_of(by_stage)[0].name
    by = f"{by_stage.replace('-', '_')}_{name}"

    def compute(ctx: Context, out: dict[str, Path], src: dict[str, Path]) -> dict[str, Any]:
        import rasterio

        import nightlights as nl

        with rasterio.open(src[by]) as raster:
            data = raster.read(1)
        lit = data[np.isfinite(data)]
        qa, qb = _threshold(o.qa, lit), _threshold(o.qb, lit)
        # the scene the Q or S map recorded (its turbidity and grid) completes this one
        scene = nl.Scene(src["emission"], dem=src.get("inputs.dem"), kernel=ctx.kernel())
        reduced = nl.inverse_reduce(
            scene,
            out[f"emission_dimmed_{name}"],
            by=src[by],
            qa=qa,
            qb=qb,
            gamma=o.gamma,
            dimming_output=out[f"dimming_{name}"],
            summary_output=out[f"dimming_{name}_summary"],
            png=out.get(f"dimming_{name}_png"),
            progress=ctx.progress,
        )
        summary = reduced.summary
        finding = (
            f"dimming the cells by {by_stage} of {name} (Q_a = {qa:.3g}, Q_b = {qb:.3g}) removes "
            f"{summary['flux_removed_percent']:.1f} % of the flux"
        )
        regions = summary.get("observers", [{}])[0].get("regions", [])
        if regions:
            band = regions[0]
            finding += (
                f" and darkens that sky from {band['before_mag_arcsec2']:.2f} to "
                f"{band['after_mag_arcsec2']:.2f} mag arcsec-2"
            )
        return {"findings": [finding]}

    outputs = {
        f"emission_dimmed_{name}": f"emission_dimmed_{name}.tif",
        f"dimming_{name}": f"dimming_{name}.tif",
        f"dimming_{name}_summary": f"dimming_{name}.json",
    }
    if o.png:
        outputs[f"dimming_{name}_png"] = f"dimming_{name}.png"
    return one(
        "inverse-reduce",
        outputs,
        ("emission", by, *dem_needs(project)),
        _sky_options(project, options),
        compute,
    )


def _darkness(project: Project, options: dict[str, Any]) -> list[Task]:
    o = project.options("darkness")

    def compute(ctx: Context, out: dict[str, Path], src: dict[str, Path]) -> dict[str, Any]:
        import nightlights as nl

        heights = sorted({p.height for p in ctx.project.observers}) or [OBSERVER_HEIGHT]
        nl.darkness(
            _scene(ctx, "darkness", src),
            out["darkness"],
            height=heights[0],
            chunk_size=o.chunk_size,
            progress=ctx.progress,
        )
        return {}

    options = _sky_options(project, options)
    options["height"] = sorted({p.height for p in project.observers}) or [OBSERVER_HEIGHT]
    return one(
        "darkness",
        {"darkness": "darkness.tif"},
        ("emission", *dem_needs(project)),
        options,
        compute,
    )


#: The builder of each sky stage.
SKY_BUILDERS: dict[str, Builder] = {
    "skyglow": _skyglow,
    "observers": _observers,
    "inverse-q": _inverse_q,
    "inverse-s": _inverse_s,
    "inverse-reduce": _inverse_reduce,
    "darkness": _darkness,
}
