"""Tests of the panorama pictures: orientation of both projections, colour direction, errors."""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.sky.render import render_panorama

N_EL, N_AZ = 16, 64
ELEVATION = 90.0 - (np.arange(N_EL) + 0.5) * 90.0 / N_EL
AZIMUTH = (np.arange(N_AZ) + 0.5) * 360.0 / N_AZ


def _sky_bright_towards(azimuth: float) -> np.ndarray:
    """Sky of 22 mag arcsec-2 with a 15 mag arcsec-2 wedge of +-20 deg around ``azimuth``
    below 30 deg elevation."""
    m = np.full((N_EL, N_AZ), 22.0)
    off = np.abs((AZIMUTH - azimuth + 180.0) % 360.0 - 180.0)
    m[np.ix_(ELEVATION < 30.0, off < 20.0)] = 15.0
    return m


def _lighter_centroid(path_a, path_b) -> tuple[float, float]:
    """(x, y) centroid [px] of the pixels lighter in picture a than in picture b."""
    a = mpimg.imread(path_a)[..., :3].sum(axis=-1)
    b = mpimg.imread(path_b)[..., :3].sum(axis=-1)
    y, x = np.nonzero(a - b > 0.3)
    assert x.size > 50  # the wedge is visible at all
    return float(x.mean()), float(y.mean())


@pytest.mark.parametrize("projection", ["equirectangular", "fisheye"])
def test_bright_sky_is_drawn_lighter(tmp_path, projection: str) -> None:
    """Reversed colour map: a brighter sky (smaller magnitude) is a lighter colour."""
    dark = render_panorama(
        np.full((N_EL, N_AZ), 22.5), ELEVATION, AZIMUTH, tmp_path / "d.png", projection=projection
    )
    bright = render_panorama(
        np.full((N_EL, N_AZ), 15.0), ELEVATION, AZIMUTH, tmp_path / "b.png", projection=projection
    )
    assert mpimg.imread(bright)[..., :3].mean() > mpimg.imread(dark)[..., :3].mean()


def test_fisheye_has_north_up_and_east_right(tmp_path) -> None:
    """Fisheye: zenith in the centre, north at the top, azimuth clockwise (east on the right,
    as on a map seen from above)."""
    paths = {}
    for name, az in {"N": 0.0, "E": 90.0, "S": 180.0, "W": 270.0}.items():
        paths[name] = render_panorama(
            _sky_bright_towards(az),
            ELEVATION,
            AZIMUTH,
            tmp_path / f"{name}.png",
            projection="fisheye",
        )
    east_x, _ = _lighter_centroid(paths["E"], paths["W"])
    west_x, _ = _lighter_centroid(paths["W"], paths["E"])
    _, north_y = _lighter_centroid(paths["N"], paths["S"])
    _, south_y = _lighter_centroid(paths["S"], paths["N"])
    assert east_x > west_x + 100
    assert north_y < south_y - 100  # image rows grow downwards


def test_equirectangular_azimuth_grows_to_the_right(tmp_path) -> None:
    """Equirectangular: azimuth 0-360 deg from left to right, horizon at the bottom."""
    east = render_panorama(_sky_bright_towards(90.0), ELEVATION, AZIMUTH, tmp_path / "e.png")
    west = render_panorama(_sky_bright_towards(270.0), ELEVATION, AZIMUTH, tmp_path / "w.png")
    east_x, east_y = _lighter_centroid(east, west)
    west_x, _ = _lighter_centroid(west, east)
    height = mpimg.imread(east).shape[0]
    assert east_x < west_x - 200
    assert east_y > 0.5 * height  # low elevations at the bottom half


def test_values_outside_the_colour_range_are_clipped_not_rejected(tmp_path) -> None:
    m = np.full((N_EL, N_AZ), 22.0)
    m[0, 0], m[1, 1] = np.inf, 5.0  # unlit sky (+inf) and a blinding pixel
    out = render_panorama(m, ELEVATION, AZIMUTH, tmp_path / "c.png")
    assert out.stat().st_size > 5000


def test_unknown_projection_is_refused(tmp_path) -> None:
    with pytest.raises(InputError, match="mercator"):
        render_panorama(
            np.full((N_EL, N_AZ), 20.0),
            ELEVATION,
            AZIMUTH,
            tmp_path / "x.png",
            projection="mercator",
        )
    assert not (tmp_path / "x.png").exists()
