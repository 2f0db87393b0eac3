"""``nightlights photometry``: inspect IES LM-63 and EULUMDAT files."""

from __future__ import annotations

import warnings

import click

from .options import check_outputs, overwrite_option


@click.group()
def photometry() -> None:
    """Photometric files: format, flux, ULOR, BUG rating (Chuang 2011, Sec. 4)."""


@photometry.command("info")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print a JSON object instead of a table.")
@click.option(
    "--plot",
    "plot_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write a polar candela plot (C0-C180, C90-C270) to this PNG.",
)
@click.option(
    "--street-azimuth",
    type=float,
    default=90.0,
    show_default=True,
    help="C-plane facing the street, for the BUG front/back split [deg].",
)
@overwrite_option
def info_command(
    file: str, as_json: bool, plot_path: str | None, street_azimuth: float, overwrite: bool
) -> None:
    """Summarise photometric FILE: grid, declared and integrated flux, ULOR, BUG, warnings."""
    from ies import read_photometry
    from ies.errors import PhotometryWarning
    from ies.plot import write_polar_plot
    from nightlights.io import OutputSet
    from nightlights.io.jsonfile import dumps_json

    check_outputs([plot_path], overwrite=overwrite)
    outputs = OutputSet(plot_path)  # the plot's folder is checked before the file is read
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)  # kept in .warnings, printed below
        photometry = read_photometry(file)
    summary = photometry.summary()
    if photometry.photometric_type == "C":
        rating = photometry.bug_rating(street_azimuth=street_azimuth)
        summary["bug_rating"] = str(rating)
        summary["bug_zone_lumens"] = dict(rating.zone_lumens)
        summary["street_azimuth"] = street_azimuth
    if plot_path:
        with outputs:
            write_polar_plot(photometry, outputs.temporary(plot_path))
        summary["plot"] = plot_path
    if as_json:
        click.echo(dumps_json(summary, indent=2))
        return
    print_summary(summary)


def _lumens(value: object) -> str:
    return "-" if value is None else f"{float(value):,.1f} lm"  # type: ignore[arg-type]


def print_summary(summary: dict[str, object]) -> None:
    """Print a photometry summary as a table (stdout)."""
    from rich.console import Console
    from rich.table import Table

    console = Console()
    grid = summary["grid"]
    assert isinstance(grid, dict)
    table = Table(show_header=False, title=str(summary["source"]))
    rows = [
        ("format", f"{summary['format']}  (type {summary['photometric_type']})"),
        ("symmetry", str(summary["symmetry"])),
        (
            "grid",
            f"{grid['n_horizontal']} horizontal x {grid['n_vertical']} vertical, "
            f"V {grid['vertical_range'][0]:g}-{grid['vertical_range'][1]:g} deg",
        ),
        ("declared lamp lumens", _lumens(summary["declared_lumens"])),
        ("declared luminaire flux", _lumens(summary["expected_flux"])),
        ("integrated flux", _lumens(summary["integrated_flux"])),
        (
            "downward / upward",
            f"{_lumens(summary['downward_flux'])} / {_lumens(summary['upward_flux'])}",
        ),
        ("ULOR", f"{float(summary['ulor']):.4f}"),  # type: ignore[arg-type]
        ("max intensity", f"{float(summary['max_candela']):,.1f} cd"),  # type: ignore[arg-type]
        ("BUG rating", str(summary["bug_rating"] or "-")),
    ]
    for key, value in rows:
        table.add_row(key, value)
    console.print(table)
    for message in summary["warnings"]:  # type: ignore[attr-defined]
        console.print(f"[yellow]warning:[/] {message}")
    if summary.get("plot"):
        console.print(f"polar plot -> {summary['plot']}")


commands = [photometry]
