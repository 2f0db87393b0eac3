"""Polar candela plots (goniometric diagrams, Chuang 2011, Sec. 4.1, Fig. 11)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ies.photometry import Photometry


def polar_candela_figure(photometry: Photometry, *, title: str | None = None) -> Any:
    """Matplotlib figure with the C0-C180 and C90-C270 planes of a type C distribution.

    Nadir points down; each plane is drawn with its first half (C0, C90) on the right and
    its opposite half (C180, C270) on the left.

    Parameters
    ----------
    photometry : Photometry
        Type C table.
    title : str or None
        Figure title; default the file name.

    Returns
    -------
    matplotlib.figure.Figure
        The figure (not yet saved).
    """
    from matplotlib.figure import Figure

    v = np.linspace(0.0, 180.0, 361)
    figure = Figure(figsize=(6, 6))
    axes: Any = figure.add_subplot(projection="polar")  # matplotlib PolarAxes
    axes.set_theta_zero_location("S")
    for (right, left), colour in (((0.0, 180.0), "tab:red"), ((90.0, 270.0), "tab:blue")):
        cd_right = photometry.intensity(v, right)
        cd_left = photometry.intensity(v, left)
        theta = np.radians(np.concatenate([-v[::-1], v]))
        radius = np.concatenate([cd_left[::-1], cd_right])
        axes.plot(theta, radius, color=colour, label=f"C{left:g} | C{right:g}")
    axes.set_thetagrids(
        range(0, 360, 30), labels=[f"{(a if a <= 180 else 360 - a)}°" for a in range(0, 360, 30)]
    )
    axes.set_rlabel_position(45)
    axes.legend(loc="lower left", bbox_to_anchor=(-0.1, -0.1))
    name = Path(photometry.source).name
    axes.set_title(title or f"{name}\nluminous intensity [cd]", fontsize=10)
    figure.tight_layout()
    return figure


def write_polar_plot(photometry: Photometry, path: str | os.PathLike[str]) -> Path:
    """Write :func:`polar_candela_figure` as a PNG, atomically (temp file + rename).

    Parameters
    ----------
    photometry : Photometry
        Type C table.
    path : str or os.PathLike
        Output PNG.

    Returns
    -------
    Path
        The written file.
    """
    target = Path(path)
    figure = polar_candela_figure(photometry)
    handle, temporary = tempfile.mkstemp(suffix=".png", dir=target.parent or Path("."))
    os.close(handle)
    try:
        figure.savefig(temporary, dpi=120)
        os.replace(temporary, target)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return target
