"""``nightlights skyglow``: the night sky an observer sees over an emission raster."""

from __future__ import annotations

import click

from .kinds import PNG, RASTER, KindPath, file_kind
from .options import (
    PROJECTIONS,
    SKYGLOW_MODES,
    LibraryChoice,
    check_outputs,
    clouds_of,
    clouds_options,
    components_option,
    deprecated_option,
    files_argument,
    instrument_option,
    natural_of,
    night_option,
    observer_of,
    obstacles_option,
    one_of,
    output_option,
    overwrite_option,
    parse_pair,
    resolve_inout,
    scene_of,
    scene_options,
    spectrum_option,
)
from .resources import max_memory_option

#: The panorama and the polar map: a NetCDF, or a GeoTIFF when the name ends in .tif.
PANORAMA = file_kind("nc", "tif")


@click.command("skyglow")
@files_argument("EMISSION OUTPUT", RASTER, PANORAMA)
@output_option
@deprecated_option(
    "--out", "old_out", type=click.Path(dir_okay=False), replacement="OUTPUT or -o/--output"
)
@overwrite_option
@scene_options
@obstacles_option
@clouds_options
@click.option(
    "--mode",
    type=LibraryChoice(SKYGLOW_MODES),
    default="pca",
    show_default=True,
    help="pca: fast; exact: the raw tables, no PCA (a kernel built with --store-tables); naive: "
    "direct integration, the slow reference.",
)
@components_option
@click.option("--png", default=None, type=KindPath(PNG, dir_okay=False), help="False-colour PNG.")
@click.option(
    "--projection",
    type=LibraryChoice(PROJECTIONS),
    default="equirectangular",
    show_default=True,
    help="Projection of the --png picture.",
)
@click.option(
    "--polar-output",
    default=None,
    type=KindPath(PANORAMA, dir_okay=False),
    help="Write the observer's polar flux map (NetCDF, or a GeoTIFF in the emission's CRS "
    "when it ends in .tif).",
)
@deprecated_option(
    "--polar-out", "old_polar_out", type=click.Path(dir_okay=False), replacement="--polar-output"
)
@click.option(
    "--bands",
    type=click.Choice(["V", "RGB"]),
    default="V",
    show_default=True,
    help="V: luminance; RGB: CIE XYZ with wavelength-dependent scattering.",
)
@spectrum_option
@instrument_option
@night_option
@click.pass_context
@max_memory_option
def skyglow(
    ctx: click.Context,
    files: tuple[str, ...],
    output: str | None,
    old_out: str | None,
    overwrite: bool,
    observer: str,
    observer_crs: str | None,
    observer_height: float,
    turbidity: float | None,
    kernel: str | None,
    mode: str,
    components: int | None,
    png: str | None,
    projection: str,
    polar_output: str | None,
    old_polar_out: str | None,
    dem: str | None,
    obstacles: str | None,
    base_height: float | None,
    optical_depth: float,
    cover: float,
    bands: str,
    spectrum: str | None,
    instrument: str | None,
    night: str | None,
    n_azimuth: int | None,
    n_elevation: int | None,
    n_distance: int | None,
) -> None:
    """Skyglow panorama (luminance, mag arcsec-2) of EMISSION [lm m-2] for an observer;
    write OUTPUT: a NetCDF, or a styled GeoTIFF (azimuth/elevation grid in degrees) when it
    ends in .tif."""
    import nightlights as nl

    parse_pair(observer)  # the syntax checked before any work
    output = one_of(ctx, **{"-o/--output": output, "--out": old_out})
    polar_output = one_of(ctx, **{"--polar-output": polar_output, "--polar-out": old_polar_out})
    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    check_outputs([png, polar_output], overwrite=overwrite)
    scene = scene_of(
        emission,
        obstacles=obstacles,
        clouds=clouds_of(base_height, optical_depth, cover),
        dem=dem,
        kernel=kernel,
        turbidity=turbidity,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        n_distance=n_distance,
    )
    site = observer_of(observer, observer_crs, observer_height)
    natural = None
    if night is not None:
        import rasterio

        with rasterio.open(emission) as source:
            natural = natural_of(instrument, night, (site.x, site.y), site.crs or source.crs)
    result = nl.skyglow(
        scene,
        site,
        out,
        mode=mode,
        components=components,
        png=png,
        projection=projection,
        polar_output=polar_output,
        bands=bands,
        spectrum=spectrum,
        instrument=instrument,
        natural_luminance=natural,
    )
    from rich.console import Console

    Console(stderr=True).print(
        f"zenith: {result.zenith_luminance:.3g} cd m-2 = "
        f"{result.zenith_magnitude:.2f} mag arcsec-2 (artificial skyglow only), "
        f"Bortle class {result.bortle}; panorama {1000 * result.seconds:.1f} ms ({mode}) -> "
        f"{out}",
        soft_wrap=True,
    )
    from nightlights.brightness import zenith_summary

    total = zenith_summary(result.zenith_luminance)
    Console(stderr=True).print(
        f"with a moonless natural sky ({total['zenith_natural_cd_m2']:.3g} cd m-2): zenith "
        f"{total['zenith_sky_brightness']:.2f} mag arcsec-2 natural + artificial, Bortle class "
        f"{total['bortle_class_zenith']} (a given night: nightlights sky render)",
        soft_wrap=True,
    )
    if instrument is not None:
        spectrum_used = result.panorama.attrs["instrument_spectrum"]
        Console(stderr=True).print(
            f"{instrument} pointing at the zenith: {result.instrument_magnitude:.2f} mag "
            f"arcsec-2 in its band with the natural sky (artificial part "
            f"{result.instrument_luminance:.3g} cd m-2 V-equivalent, {spectrum_used} light)",
            soft_wrap=True,
        )


commands = [skyglow]
