"""The naive reference and the RGB bands use the kernel's whole atmosphere, not only its
turbidity: a kernel built with a given aerosol optical depth or a flat Earth must give the
same sky in ``naive`` mode (direct integration) as in ``pca``/``exact`` mode."""

from __future__ import annotations

import numpy as np
import pytest
from affine import Affine

from nightlights.io import RasterBand, write_cog
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
from nightlights.sky.atmosphere import Atmosphere

CELL = 100.0


def _write_scene(path) -> None:
    scene = np.zeros((2, 40, 40), np.float32)
    scene[0, 5, 30] = 1.0
    scene[0, 20:23, 3:6] = 0.3
    scene[1] = 0.1 * scene[0]
    write_cog(
        path,
        [RasterBand(scene[b], ("reflected", "uplight")[b], "lm m-2") for b in range(2)],
        transform=Affine(CELL, 0, 500_000, 0, -CELL, 6_700_000),
        crs="EPSG:32635",
    )


@pytest.mark.parametrize(
    "atmosphere",
    [
        Atmosphere(aerosol_optical_depth=1.0),
        Atmosphere(turbidity=3.0, flat_earth=True, wavelength_nm=450.0),
    ],
    ids=["aerosol_optical_depth", "flat_earth_blue"],
)
def test_naive_mode_uses_the_kernels_atmosphere(tmp_path, atmosphere: Atmosphere) -> None:
    """Same scene, same kernel: naive vs exact within the binning error of the coarse kernel.

    Mean error over the bright pixels (after / before the fix): 0.156 / 0.335 (optical depth 1;
    the hazy forward peak makes binning coarser: 0.023 with 96 x 128 bins), 0.074 / 0.348 (flat
    Earth, 450 nm, T = 3); zenith exact / naive: 1.003 / 0.769 and 0.993 / 1.561. Before, the
    naive mode rebuilt ``Atmosphere(turbidity=...)`` and the default uplight exponent."""
    spec = KernelSpec(
        r_min=5.0,
        r_max=20_000.0,
        n_distance=24,
        n_elevation=8,
        n_azimuth=32,
        uplight=True,
        atmosphere=atmosphere,
        uplight_exponent=2.0,
    )
    kernel = build_kernel(spec, progress=False)
    src = tmp_path / "emission.tif"
    _write_scene(src)
    runs = {
        mode: skyglow(
            Scene(src, kernel=kernel),
            Observer(502_000.0, 6_698_000.0, height=0.0),
            tmp_path / f"{mode}.nc",
            mode=mode,
        )
        .panorama["luminance"]
        .values
        for mode in ("exact", "naive")
    }
    exact, naive = runs["exact"], runs["naive"]
    bright = naive > 0.01 * naive.max()
    assert np.mean(np.abs(exact[bright] - naive[bright]) / naive[bright]) < 0.2
    assert exact[0].mean() == pytest.approx(naive[0].mean(), rel=0.05)
