"""``nightlights kernel build``: precompute a skyglow kernel table (PCA + FFT) to NetCDF.

The defaults are the library's (:class:`~nightlights.sky.KernelSpec`: the measured-best
build); ``--exact`` restores the reference build (:meth:`~nightlights.sky.KernelSpec.exact`)
for the options not given.
"""

from __future__ import annotations

import time
from typing import Any

import click

from .kinds import NETCDF
from .options import (
    KERNEL_BACKENDS,
    KERNEL_PRECISIONS,
    MULTIPLE_SCATTERING_MODELS,
    LibraryChoice,
    atmosphere_default,
    deprecated_option,
    files_argument,
    given,
    kernel_default,
    one_of,
    output_option,
    overwrite_option,
    resolve_inout,
)
from .resources import max_memory_option


@click.group("kernel")
def kernel() -> None:
    """Skyglow kernels: sky luminance per lumen of a ground source, tabulated."""


@kernel.command("build")
@files_argument("OUTPUT", NETCDF)
@output_option
@overwrite_option
@click.option(
    "--turbidity",
    type=float,
    default=atmosphere_default("turbidity"),
    show_default=True,
    help="Turbidity T >= 1.",
)
@click.option(
    "--aerosol-optical-depth",
    type=float,
    default=None,
    help="Vertical aerosol optical depth (overrides --turbidity).",
)
@click.option(
    "--wavelength-nm",
    type=float,
    default=atmosphere_default("wavelength_nm"),
    show_default=True,
    help="Wavelength of the single band [nm].",
)
@deprecated_option(
    "--wavelength", "old_wavelength", type=float, default=None, replacement="--wavelength-nm"
)
@click.option(
    "--r-min",
    type=float,
    default=kernel_default("r_min"),
    show_default=True,
    help="Inner distance [m].",
)
@click.option(
    "--r-max",
    type=float,
    default=kernel_default("r_max"),
    show_default=True,
    help="Outer distance [m].",
)
@click.option(
    "--n-distance",
    type=int,
    default=kernel_default("n_distance"),
    show_default=True,
    help="Log-spaced distance bins.",
)
@click.option(
    "--n-elevation",
    type=int,
    default=kernel_default("n_elevation"),
    show_default=True,
    help="Elevation rows (0-90 deg).",
)
@click.option(
    "--n-azimuth",
    type=int,
    default=kernel_default("n_azimuth"),
    show_default=True,
    help="Azimuth columns (even).",
)
@click.option(
    "--source-altitude",
    "source_altitudes",
    type=float,
    multiple=True,
    help="Source altitude above sea level [m]; repeat for several levels (default 0).",
)
@click.option(
    "--observer-altitude",
    "observer_altitudes",
    type=float,
    multiple=True,
    help="Observer altitude above sea level [m]; repeat for several levels (default 0).",
)
@click.option(
    "--nodes",
    type=int,
    default=kernel_default("nodes"),
    show_default=True,
    help="Gauss nodes per line-of-sight panel.",
)
@click.option(
    "--pca-energy",
    type=float,
    default=kernel_default("pca_energy"),
    show_default=True,
    help="PCA explained energy.",
)
@deprecated_option("--energy", "old_energy", type=float, default=None, replacement="--pca-energy")
@click.option(
    "--n-components",
    type=int,
    default=None,
    help="PCA bases to store, at most the tables' rank (overrides --pca-energy). Not the same as "
    "skyglow --components, which uses fewer of the stored bases at run time.",
)
@deprecated_option(
    "--components", "old_components", type=int, default=None, replacement="--n-components"
)
@click.option(
    "--pca-error",
    type=float,
    default=kernel_default("pca_error"),
    show_default=True,
    help="PCA error target: the fewest bases whose reconstruction's mean relative error over "
    "pixels above 1 % of their image's maximum is at most this (a given --pca-energy "
    "replaces it).",
)
@deprecated_option("--error", "old_error", type=float, default=None, replacement="--pca-error")
@click.option(
    "--shared-bases/--per-level-bases",
    default=kernel_default("shared_bases"),
    show_default=True,
    help="One PCA basis for every observer altitude (a smaller file) or one per altitude.",
)
@click.option(
    "--precision",
    type=LibraryChoice(KERNEL_PRECISIONS),
    default=kernel_default("precision"),
    show_default=True,
    help="Storage precision of the PCA bases and coefficients.",
)
@click.option(
    "--altitude-step",
    type=int,
    default=kernel_default("altitude_step"),
    show_default=True,
    help="Compute every n-th altitude pair along each line of equal h_c - h_o and "
    "interpolate the others (log-linear in the observer altitude, never across more than "
    "937.5 m); 1 computes all.",
)
@click.option(
    "--sub-distances",
    type=int,
    default=kernel_default("sub_distances"),
    show_default=True,
    help="Distances averaged per bin.",
)
@click.option(
    "--uplight/--no-uplight", default=False, show_default=True, help="Also tabulate direct uplight."
)
@click.option(
    "--garstang-lobe/--no-garstang-lobe",
    default=False,
    show_default=True,
    help="Also tabulate Garstang's (1986) low-angle lobe (serves every garstang:F,G band).",
)
@click.option(
    "--tabulated-emission",
    default=None,
    metavar="TEXT",
    help='Also tabulate this emission function: tabulated:{"angles": [deg, 0 to 90], '
    '"intensities": [relative]}.',
)
@click.option("--flat-earth", is_flag=True, help="Flat Earth instead of a sphere.")
@click.option(
    "--multiple-scattering",
    type=LibraryChoice(MULTIPLE_SCATTERING_MODELS),
    default=kernel_default("multiple_scattering"),
    show_default=True,
    help="monte-carlo: single scattering times the Monte Carlo factor of all scattering "
    "orders (shipped for turbidity 2 and Garstang's K = 1; measured on the first build "
    "otherwise); single: single scattering only (Dobashi et al. 2023).",
)
@click.option(
    "--store-tables/--no-store-tables",
    default=False,
    show_default=True,
    help="Keep the raw images next to the PCA bases (needed only by skyglow --mode exact; "
    "most of the file).",
)
@deprecated_option(
    "--tables/--no-tables",
    "old_tables",
    default=None,
    replacement="--store-tables/--no-store-tables",
)
@click.option(
    "--exact",
    is_flag=True,
    help="The reference build: every altitude pair integrated at 12 nodes, one PCA per "
    "observer altitude by --pca-energy, float64 (for --nodes, --pca-error, --shared-bases, "
    "--precision and --altitude-step not given).",
)
@click.option(
    "--backend",
    type=LibraryChoice(KERNEL_BACKENDS),
    default="auto",
    show_default=True,
    help="Line-of-sight integrator: numba (compiled) or numpy (reference).",
)
@click.pass_context
@max_memory_option
def build(
    ctx: click.Context,
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    turbidity: float,
    aerosol_optical_depth: float | None,
    wavelength_nm: float,
    old_wavelength: float | None,
    r_min: float,
    r_max: float,
    n_distance: int,
    n_elevation: int,
    n_azimuth: int,
    source_altitudes: tuple[float, ...],
    observer_altitudes: tuple[float, ...],
    nodes: int,
    pca_energy: float,
    old_energy: float | None,
    n_components: int | None,
    old_components: int | None,
    pca_error: float | None,
    old_error: float | None,
    shared_bases: bool,
    precision: str,
    altitude_step: int,
    sub_distances: int,
    uplight: bool,
    garstang_lobe: bool,
    tabulated_emission: str | None,
    flat_earth: bool,
    multiple_scattering: str,
    store_tables: bool,
    old_tables: bool | None,
    exact: bool,
    backend: str,
) -> None:
    """Build a kernel table and write it to OUTPUT (NetCDF).

    The defaults are the measured-best build (benchmark bench_sky_kernel_defaults: Dobashi's
    configuration into 16 MB, 0.3 % from the reference); --exact gives the reference build.
    """
    import nightlights as nl
    from nightlights.sky.atmosphere import Atmosphere
    from nightlights.sky.spec import EXACT_SETTINGS

    _, out = resolve_inout(files, output, inputs=0, usage="OUTPUT", overwrite=overwrite)
    components = one_of(ctx, **{"--n-components": n_components, "--components": old_components})
    wavelength_nm = _renamed(
        ctx, "wavelength_nm", "--wavelength-nm", "--wavelength", old_wavelength
    )
    pca_energy = _renamed(ctx, "pca_energy", "--pca-energy", "--energy", old_energy)
    pca_error = _renamed(ctx, "pca_error", "--pca-error", "--error", old_error)
    store_tables = _renamed(ctx, "store_tables", "--store-tables", "--tables", old_tables)
    if given(ctx, "pca_energy") is not None or old_energy is not None:
        pca_error = pca_error if given(ctx, "pca_error") or old_error else None
    settings: dict[str, Any] = {
        "nodes": nodes,
        "pca_error": pca_error,
        "shared_bases": shared_bases,
        "precision": precision,
        "altitude_step": altitude_step,
    }
    if exact:  # the reference for every setting not given
        for name, value in EXACT_SETTINGS.items():
            explicit = ctx.get_parameter_source(name) is click.core.ParameterSource.COMMANDLINE
            if not explicit and not (name == "pca_error" and old_error is not None):
                settings[name] = value
    spec = nl.KernelSpec(
        r_min=r_min,
        r_max=r_max,
        n_distance=n_distance,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        source_altitudes=source_altitudes or (0.0,),
        observer_altitudes=observer_altitudes or (0.0,),
        atmosphere=Atmosphere(
            turbidity=turbidity,
            aerosol_optical_depth=aerosol_optical_depth,
            wavelength_nm=wavelength_nm,
            flat_earth=flat_earth,
        ),
        pca_energy=pca_energy,
        n_components=components,
        sub_distances=sub_distances,
        uplight=uplight,
        garstang_lobe=garstang_lobe,
        tabulated_emission=tabulated_emission,
        store_tables=store_tables,
        multiple_scattering=multiple_scattering,
        **settings,
    )
    start = time.perf_counter()
    result = nl.build_kernel(spec, out, backend=backend, progress=True)
    from rich.console import Console

    ds = result.kernel
    Console(stderr=True).print(
        f"kernel {ds.sizes['distance']} r x {ds.sizes['elevation']} el x "
        f"{ds.sizes['azimuth']} az, {ds.sizes['component']} bases "
        f"(energy {float(ds.explained_energy.min()):.6f}"
        + (
            f", mean error {float(ds.attrs['pca_mean_error']):.4f}"
            if "pca_mean_error" in ds.attrs
            else ""
        )
        + f") in {time.perf_counter() - start:.1f} s "
        f"-> {out} [{ds.attrs['content_hash'][:12]}]"
    )


def _renamed(ctx: click.Context, name: str, new: str, old: str, old_value: Any) -> Any:
    """The value of option ``name``, or of its deprecated spelling ``old`` when that was given
    (both given: a usage error)."""
    if old_value is None:
        return ctx.params[name]
    return one_of(ctx, **{new: given(ctx, name), old: old_value})


commands = [kernel]
