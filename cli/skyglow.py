"""``nightlights skyglow``: the night sky an observer sees over an emission raster."""

from __future__ import annotations

import click

from cli.options import (
    PROJECTIONS,
    SKYGLOW_MODES,
    check_outputs,
    deprecated_option,
    files_argument,
    one_of,
    output_option,
    overwrite_option,
    resolve_inout,
)


def parse_pair(text: str) -> tuple[float, float]:
    """``X,Y`` -> two floats."""
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise click.BadParameter(f"{text!r}; expected X,Y", param_hint="--observer") from None
    return x, y


@click.command("skyglow")
@files_argument("EMISSION OUTPUT")
@output_option
@deprecated_option(
    "--out", "old_out", type=click.Path(dir_okay=False), replacement="OUTPUT or -o/--output"
)
@overwrite_option
@click.option("--observer", required=True, metavar="X,Y", help="Observer X,Y (in --observer-crs).")
@click.option(
    "--observer-crs", default=None, metavar="CRS", help="CRS of --observer (default: the raster's)."
)
@click.option("--observer-height", default=1.7, show_default=True, help="Above ground [m].")
@click.option("--turbidity", type=float, default=None, help="Turbidity T (default 2).")
@click.option(
    "--kernel",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Precomputed kernel (nightlights kernel build); default: cached scene kernel.",
)
@click.option(
    "--mode",
    type=click.Choice(SKYGLOW_MODES),
    default="pca",
    show_default=True,
    help="pca: fast; exact: the raw tables, no PCA (a kernel built with --tables); naive: "
    "direct integration, the slow reference.",
)
@click.option(
    "--components",
    type=int,
    default=None,
    help="PCA bases to use at run time, the first of those the kernel stores (default: all).",
)
@click.option("--png", default=None, type=click.Path(dir_okay=False), help="False-colour PNG.")
@click.option(
    "--projection",
    type=click.Choice(PROJECTIONS),
    default="equirectangular",
    show_default=True,
    help="Projection of the --png picture.",
)
@click.option(
    "--polar-output",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write the observer's polar flux map (NetCDF, or a GeoTIFF in the emission's CRS "
    "when it ends in .tif).",
)
@deprecated_option(
    "--polar-out", "old_polar_out", type=click.Path(dir_okay=False), replacement="--polar-output"
)
@click.option(
    "--dem",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Terrain heights above sea level [m] (raster): observer altitude, each lit cell's own "
    "source altitude, horizon mask.",
)
@click.option(
    "--bands",
    type=click.Choice(["V", "RGB"]),
    default="V",
    show_default=True,
    help="V: luminance; RGB: CIE XYZ with wavelength-dependent scattering.",
)
@click.option(
    "--spectrum",
    default="LED_4000K",
    show_default=True,
    help="Luminaire spectrum for --bands RGB (HPS, LED_3000K, LED_4000K, ...).",
)
@click.option(
    "--n-azimuth",
    type=int,
    default=None,
    help="Panorama columns (default 256; a given --kernel fixes it).",
)
@click.option(
    "--n-elevation",
    type=int,
    default=None,
    help="Panorama rows (default 64; a given --kernel fixes it).",
)
@click.option(
    "--n-distance",
    type=int,
    default=None,
    help="Distance bins of the scene kernel built when --kernel is not given (default 64; a "
    "given --kernel fixes it).",
)
@click.pass_context
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
    bands: str,
    spectrum: str,
    n_azimuth: int | None,
    n_elevation: int | None,
    n_distance: int | None,
) -> None:
    """Skyglow panorama (luminance, mag arcsec-2) of EMISSION [lm m-2] for an observer;
    write OUTPUT: a NetCDF, or a styled GeoTIFF (azimuth/elevation grid in degrees) when it
    ends in .tif."""
    import nightlights as nl

    observer_xy = parse_pair(observer)
    output = one_of(ctx, **{"-o/--output": output, "--out": old_out})
    polar_output = one_of(ctx, **{"--polar-output": polar_output, "--polar-out": old_polar_out})
    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    check_outputs([png, polar_output], overwrite=overwrite)
    result = nl.skyglow(
        emission,
        out,
        observer=observer_xy,
        observer_crs=observer_crs,
        observer_height=observer_height,
        turbidity=turbidity,
        kernel=kernel,
        mode=mode,
        components=components,
        png=png,
        projection=projection,
        polar_output=polar_output,
        dem=dem,
        bands=bands,
        spectrum=spectrum,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        n_distance=n_distance,
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


commands = [skyglow]
