"""The compiled polar scatter and the cached kernel levels against their numpy references."""

from __future__ import annotations

import numpy as np
import pytest
from affine import Affine

from nightlights.errors import InputError
from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky._polar_numba import polar_flux_levels
from nightlights.sky.panorama import KernelLevels, kernel_levels
from nightlights.sky.polar import level_maps, lit_polar_cells, source_level_weights

TRANSFORM = Affine(10.0, 0.0, 500_000.0, 0.0, -10.0, 6_700_000.0)


def _cells(n: int = 30_000, seed: int = 3) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    index = rng.choice(400 * 400, n, replace=False)
    rows, cols = np.divmod(index, 400)
    density = rng.lognormal(0.0, 1.0, (2, n))
    density[1, ::7] = np.nan  # a band with no value counts as no flux
    heights = rng.uniform(0.0, 70.0, n)
    return rows, cols, density, heights


@pytest.mark.filterwarnings("ignore:.*beyond the kernel's range")
@pytest.mark.parametrize(
    "observer",
    [
        (502_000.0, 6_698_000.0),  # on a cell corner: the cells around it take 16 x 16 points
        (502_003.7, 6_698_001.2),
        (499_000.0, 6_701_000.0),  # outside the raster
        (500_005.0, 6_699_995.0),  # at a cell centre
    ],
)
def test_scatter_equals_the_numpy_polar_map(observer: tuple[float, float]) -> None:
    rows, cols, density, heights = _cells()
    edges = np.concatenate([[0.0], np.geomspace(10.0, 2500.0, 40)])  # the far cells drop out
    weights = source_level_weights(heights, [0.0, 30.0, 60.0])
    scale = np.random.default_rng(1).uniform(0.0, 1.0, rows.size)
    cells = lit_polar_cells(rows, cols, density, TRANSFORM, observer, distance_edges=edges, n_az=64)
    for factor in (None, scale):
        reference = level_maps(cells, weights if factor is None else weights * factor)
        maps, dropped = polar_flux_levels(
            rows, cols, cells.flux, weights, TRANSFORM, observer,
            distance_edges=edges, n_az=64, scale=factor,
        )  # fmt: skip
        expected = np.stack([m.flux for m in reference])
        np.testing.assert_allclose(maps, expected, rtol=1e-12, atol=1e-9 * expected.max())
        lost = np.sum([m.dropped_flux for m in reference], axis=0)
        np.testing.assert_allclose(dropped, lost, rtol=1e-9, atol=1e-6)
        assert dropped[0] > 0  # the test reaches beyond the last edge


def test_scatter_refuses_mismatched_inputs() -> None:
    with pytest.raises(InputError, match="expected"):
        polar_flux_levels(
            [0, 1], [0, 1], [[1.0]], [[1.0, 1.0]], TRANSFORM, (0.0, 0.0),
            distance_edges=np.array([0.0, 10.0]), n_az=4,
        )  # fmt: skip
    with pytest.raises(InputError, match="north-up"):
        polar_flux_levels(
            [0], [0], [[1.0]], [[1.0]], Affine(10, 1, 0, 0, -10, 0), (0.0, 0.0),
            distance_edges=np.array([0.0, 10.0]), n_az=4,
        )  # fmt: skip


def test_kernel_levels_between_observer_levels_equal_the_dataset_reading() -> None:
    spec = KernelSpec(
        r_max=2000.0, n_distance=6, n_elevation=6, n_azimuth=16,
        source_altitudes=(0.0, 50.0), observer_altitudes=(0.0, 100.0),
    )  # fmt: skip
    table = build_kernel(spec, progress=False).kernel
    cached = KernelLevels(table)
    for altitude in (0.0, 37.5, 100.0, 37.5):
        for fast, slow in zip(
            cached.at(altitude), kernel_levels(table, observer_altitude=altitude), strict=True
        ):
            np.testing.assert_array_equal(fast.coefficient, slow.coefficient)
            np.testing.assert_array_equal(fast.basis_fft, slow.basis_fft)
            np.testing.assert_array_equal(fast.kernel, slow.kernel)
            assert fast.observer_weights == slow.observer_weights
    assert KernelLevels(table, tables=False).at(37.5)[0].kernel.shape[-1] == 0
