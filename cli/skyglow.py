"""``nightlights skyglow``: the night sky an observer sees over an emission raster."""

from __future__ import annotations

import click
from rich.console import Console

from nightlights.sky.panorama import MODES
from nightlights.sky.render import PROJECTIONS
from nightlights.sky.stage import skyglow as skyglow_stage


def _pair(text: str) -> tuple[float, float]:
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise click.BadParameter(f"{text!r}; expected X,Y") from None
    return x, y


@click.command("skyglow")
@click.argument("emission", type=click.Path(exists=True, dir_okay=False))
@click.option("--observer", required=True, help="Observer X,Y (in --observer-crs).")
@click.option("--observer-crs", default=None, help="CRS of --observer (default: the raster's).")
@click.option("--observer-height", default=1.7, show_default=True, help="Above ground [m].")
@click.option("--turbidity", type=float, default=None, help="Turbidity T (default 2).")
@click.option(
    "--kernel",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Precomputed kernel (nightlights kernel build); default: cached scene kernel.",
)
@click.option("--mode", type=click.Choice(MODES), default="pca", show_default=True)
@click.option("--components", type=int, default=None, help="PCA bases to use (default: all).")
@click.option(
    "--out",
    "out_nc",
    required=True,
    type=click.Path(dir_okay=False),
    help="Output panorama NetCDF.",
)
@click.option("--png", default=None, type=click.Path(dir_okay=False), help="False-colour PNG.")
@click.option(
    "--projection", type=click.Choice(PROJECTIONS), default="equirectangular", show_default=True
)
@click.option(
    "--polar-out",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write the observer's polar flux map (NetCDF).",
)
@click.option(
    "--dem",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Terrain heights above sea level [m]: observer altitude, each lit cell's own source "
    "altitude, horizon mask.",
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
@click.option("--n-azimuth", default=256, show_default=True, help="Panorama columns.")
@click.option("--n-elevation", default=64, show_default=True, help="Panorama rows.")
def skyglow(
    emission: str,
    observer: str,
    observer_crs: str | None,
    observer_height: float,
    turbidity: float | None,
    kernel: str | None,
    mode: str,
    components: int | None,
    out_nc: str,
    png: str | None,
    projection: str,
    polar_out: str | None,
    dem: str | None,
    bands: str,
    spectrum: str,
    n_azimuth: int,
    n_elevation: int,
) -> None:
    """Skyglow panorama (luminance, mag arcsec-2) of EMISSION [lm m-2] for an observer."""
    result = skyglow_stage(
        emission,
        out_nc,
        observer=_pair(observer),
        observer_crs=observer_crs,
        observer_height=observer_height,
        turbidity=turbidity,
        kernel=kernel,
        mode=mode,
        components=components,
        png=png,
        projection=projection,
        polar_out=polar_out,
        n_el=n_elevation,
        n_az=n_azimuth,
        dem=dem,
        bands=bands,
        spectrum=spectrum,
    )
    console = Console(stderr=True)
    console.print(
        f"zenith: {result.zenith_luminance:.3g} cd m-2 = "
        f"{result.zenith_magnitude:.2f} mag arcsec-2 (artificial skyglow only), "
        f"Bortle class {result.bortle}; panorama {1000 * result.seconds:.1f} ms ({mode}) -> "
        f"{out_nc}",
        soft_wrap=True,
    )


commands = [skyglow]
