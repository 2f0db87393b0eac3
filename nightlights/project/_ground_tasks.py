"""The tasks of the stages from the streets to the emission raster."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from nightlights.project._schema import Project
from nightlights.project._tasks import (
    Builder,
    Context,
    Task,
    catalog_needs,
    dem_needs,
    is_path,
    one,
)


def _normalize(project: Project, options: dict[str, Any]) -> list[Task]:
    def compute(ctx: Context, out: dict[str, Path], src: dict[str, Path]) -> dict[str, Any]:
        import nightlights as nl

        o = ctx.project.options("normalize")
        nl.normalize(
            src["inputs.streets"],
            out["streets_norm"],
            mapping=ctx.project.file.inputs.mapping,
            layer=o.layer,
            crs=o.crs,
            target_crs=o.target_crs,
        )
        return {}

    needs = ["inputs.streets"]
    if project.file.inputs.mapping not in ("osm", "municipal"):
        needs.append("inputs.mapping")
    options["mapping"] = project.file.inputs.mapping
    return one("normalize", {"streets_norm": "streets_norm.gpkg"}, tuple(needs), options, compute)


def _sample(project: Project, options: dict[str, Any]) -> list[Task]:
    def compute(ctx: Context, out: dict[str, Path], src: dict[str, Path]) -> dict[str, Any]:
        import nightlights as nl

        o = ctx.project.options("sample")
        nl.sample(
            src["streets_norm"],
            out["streets_lit"],
            network=ctx.project.file.inputs.network,
            candidates=o.candidates,
            seed=ctx.project.file.project.seed,
            on_conflict=o.on_conflict,
            progress=ctx.progress,
        )
        return {}

    options |= {"network": project.file.inputs.network, "seed": project.file.project.seed}
    needs = ["streets_norm"] + (["inputs.network"] if is_path(project.file.inputs.network) else [])
    return one("sample", {"streets_lit": "streets_lit.gpkg"}, tuple(needs), options, compute)


def _place(project: Project, options: dict[str, Any]) -> list[Task]:
    def compute(ctx: Context, out: dict[str, Path], src: dict[str, Path]) -> dict[str, Any]:
        import nightlights as nl

        o = ctx.project.options("place")
        nl.place(
            src["streets_lit"],
            out["lights"],
            seed=ctx.project.file.project.seed,
            along_jitter=o.along_jitter,
            across_jitter=o.across_jitter,
            merge_fraction=o.merge_fraction,
            catalog=ctx.project.file.inputs.catalog,
        )
        return {}

    options["seed"] = project.file.project.seed
    return one(
        "place",
        {"lights": "lights.gpkg"},
        ("streets_lit", *catalog_needs(project)),
        options,
        compute,
    )


def _irradiance(project: Project, options: dict[str, Any]) -> list[Task]:
    o = project.options("irradiance")

    def compute(ctx: Context, out: dict[str, Path], src: dict[str, Path]) -> dict[str, Any]:
        import nightlights as nl
        from nightlights.ground import InfluenceThreshold
        from nightlights.io import read_vector

        lights = read_vector(src["lights"], layer="lights")
        nl.irradiance(
            lights,
            out["irradiance"],
            resolution=o.resolution,
            sensors=tuple(o.sensor),
            bounds=o.bounds,
            margin=o.margin,
            catalog=ctx.project.file.inputs.catalog,
            dem=src.get("inputs.dem"),
            threshold=InfluenceThreshold.parse(o.threshold, max_radius=o.max_radius),
            skip_unknown=o.skip_unknown,
            tile_size=o.tile_size,
            progress=ctx.progress,
        )
        if "irradiance_map" in out:
            from nightlights.maps import plot_raster_map

            plot_raster_map(
                out["irradiance"],
                out["irradiance_map"],
                points=lights.drop_duplicates("pole_id") if "pole_id" in lights else lights,
                title=f"{ctx.project.file.project.name}: predicted poles and ground illuminance",
                credit=ctx.project.file.project.credit,
                zoom=o.map_window,
            )
        return {}

    outputs = {"irradiance": "irradiance.tif"}
    if o.map:
        outputs["irradiance_map"] = "irradiance.png"
    needs = ("lights", *dem_needs(project), *catalog_needs(project))
    return one("irradiance", outputs, needs, options, compute)


def _emission(project: Project, options: dict[str, Any]) -> list[Task]:
    o = project.options("emission")

    def compute(ctx: Context, out: dict[str, Path], src: dict[str, Path]) -> dict[str, Any]:
        import nightlights as nl

        nl.emission(
            src["irradiance"],
            out["emission"],
            lights=src["lights"],
            resolution=o.resolution,
            albedo=o.albedo,
            catalog=ctx.project.file.inputs.catalog,
            skip_unknown=o.skip_unknown,
        )
        return {}

    needs = ["irradiance", "lights", *catalog_needs(project)]
    if isinstance(o.albedo, str):
        needs.append("stages.emission.albedo")
    return one("emission", {"emission": "emission.tif"}, tuple(needs), options, compute)


def _emission_viirs(project: Project, options: dict[str, Any]) -> list[Task]:
    o = project.options("emission-viirs")

    def compute(ctx: Context, out: dict[str, Path], src: dict[str, Path]) -> dict[str, Any]:
        import nightlights as nl

        nl.emission_from_viirs(
            src["inputs.viirs"],
            out["emission"],
            spectrum=o.spectrum,
            resolution=o.resolution,
            target_crs=o.target_crs,
            emission_function=o.emission_function,
        )
        return {}

    return one("emission-viirs", {"emission": "emission.tif"}, ("inputs.viirs",), options, compute)


#: The builder of each stage from the streets to the emission raster.
GROUND_BUILDERS: dict[str, Builder] = {
    "normalize": _normalize,
    "sample": _sample,
    "place": _place,
    "irradiance": _irradiance,
    "emission": _emission,
    "emission-viirs": _emission_viirs,
}
