"""``nightlights obstacles``: building footprints -> obstacle height, spacing and filling factor.

``obstacles FOOTPRINTS OUTPUT (--reference RASTER | --resolution M)`` writes one three-band COG
(``height`` [m], ``spacing`` [m], ``filling`` [1]) that a scene takes as its obstacles
(``--obstacles`` of the sky commands, ``obstacles=`` of ``nightlights.Scene``).
"""

from __future__ import annotations

import click

from .kinds import POLYGONS, RASTER, KindPath
from .options import files_argument, output_option, overwrite_option, resolve_inout


@click.command("obstacles")
@files_argument("FOOTPRINTS OUTPUT", POLYGONS, RASTER)
@output_option
@overwrite_option
@click.option(
    "--reference",
    type=KindPath(RASTER, exists=True, dir_okay=False),
    default=None,
    help="Raster whose grid the output takes (the emission raster); or --resolution.",
)
@click.option(
    "--resolution",
    type=float,
    default=None,
    help="Cell size [m] of a grid over the footprints (projected CRS); or --reference.",
)
@click.option("--layer", default=None, help="Layer of FOOTPRINTS (default: the first).")
@click.option(
    "--height-field",
    default=None,
    help="Field of the building height [m] (default: the first of height, building:height).",
)
@click.option(
    "--levels-field",
    default=None,
    help="Field of the number of levels, used where there is no height (default: the first "
    "of building:levels, levels).",
)
@click.option(
    "--storey-height",
    type=float,
    default=3.0,
    show_default=True,
    help="Height of one level [m].",
)
@click.option(
    "--default-height",
    type=float,
    default=None,
    help="Height [m] of footprints without height or levels (default: they are skipped; "
    "warned either way).",
)
def obstacles(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    reference: str | None,
    resolution: float | None,
    layer: str | None,
    height_field: str | None,
    levels_field: str | None,
    storey_height: float,
    default_height: float | None,
) -> None:
    """Obstacle height, spacing and filling factor of building FOOTPRINTS on a grid; write
    OUTPUT (COG, bands height [m], spacing [m], filling [1]) for a scene's obstacles.

    Per cell: the area-weighted mean building height, the built fraction and the gap between
    the buildings of a square lattice of the same count and built area."""
    from nightlights.ground.footprints import obstacle_rasters

    inputs, out = resolve_inout(
        files, output, inputs=1, usage="FOOTPRINTS OUTPUT", overwrite=overwrite
    )
    raster = obstacle_rasters(
        inputs[0],
        reference=reference,
        resolution=resolution,
        height_field=height_field,
        levels_field=levels_field,
        storey_height=storey_height,
        default_height=default_height,
        layer=layer,
        output=out,
    )
    from rich.console import Console

    rows, cols = raster.shape
    Console(stderr=True).print(
        f"{raster.tags['footprints']} footprints on a {rows} x {cols} grid -> {out}"
    )


commands = [obstacles]
