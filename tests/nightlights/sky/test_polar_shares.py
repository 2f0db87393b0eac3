"""A sub-point's flux shared between its two neighbouring distance bins, linear in ln r: the
weights, flux conservation, the compiled scatter and the smooth sky of a lone moving source."""

from __future__ import annotations

import numpy as np
import pytest
from affine import Affine

from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky._polar_numba import polar_flux_levels
from nightlights.sky.darkness import zenith_per_lumen
from nightlights.sky.panorama import kernel_slice
from nightlights.sky.polar import (
    _lit_polar_cells,
    _nearest_bin,
    distance_centres,
    distance_shares,
    lit_polar_cells,
    polar_map,
)

EDGES = np.geomspace(10.0, 10_000.0, 13)  # 12 bins, 0.58 in ln r each
CENTRES = np.sqrt(EDGES[:-1] * EDGES[1:])


def test_centres_are_the_kernels_distance_coordinate() -> None:
    spec = KernelSpec(r_min=10.0, r_max=3000.0, n_distance=6, n_elevation=4, n_azimuth=8)
    np.testing.assert_array_equal(distance_centres(spec.edges), spec.distances)
    table = build_kernel(spec, progress=False).kernel
    np.testing.assert_allclose(
        distance_centres(table["distance_edges"].values), table["distance"].values, rtol=1e-12
    )


def test_a_bin_centre_gives_all_to_that_bin() -> None:
    lower, weight = distance_shares(CENTRES, EDGES)
    np.testing.assert_array_equal(lower, np.arange(CENTRES.size))
    np.testing.assert_array_equal(weight, 1.0)


def test_halfway_in_ln_r_gives_half_to_each_bin() -> None:
    halfway = np.sqrt(CENTRES[:-1] * CENTRES[1:])  # the inner edges, halfway in ln r
    lower, weight = distance_shares(halfway, EDGES)
    np.testing.assert_array_equal(lower, np.arange(CENTRES.size - 1))
    np.testing.assert_allclose(weight, 0.5, rtol=1e-12)


def test_weights_are_linear_in_ln_r_between_centres() -> None:
    t = np.linspace(0.0, 0.999, 7)
    r = np.exp(np.log(CENTRES[4]) + t * (np.log(CENTRES[5]) - np.log(CENTRES[4])))
    lower, weight = distance_shares(r, EDGES)
    np.testing.assert_array_equal(lower, 4)
    np.testing.assert_allclose(weight, 1.0 - t, atol=1e-12)


def test_the_ends_give_all_to_one_bin_and_beyond_is_left_out() -> None:
    r = np.array([0.0, 5.0, 10.0, CENTRES[0] * 0.99, CENTRES[-1] * 1.01, EDGES[-1] * 0.999])
    lower, weight = distance_shares(r, EDGES)
    np.testing.assert_array_equal(lower, [0, 0, 0, 0, 11, 11])
    np.testing.assert_array_equal(weight, 1.0)
    lower, weight = distance_shares([EDGES[-1], 2 * EDGES[-1]], EDGES)
    np.testing.assert_array_equal(lower, [12, 12])  # n_r: beyond the last edge


def test_a_first_edge_at_zero_takes_the_arithmetic_centre() -> None:
    edges = np.array([0.0, 50.0, 200.0])
    np.testing.assert_array_equal(distance_centres(edges), [25.0, 100.0])
    lower, weight = distance_shares([10.0, 50.0], edges)
    assert lower.tolist() == [0, 0]
    assert weight[0] == 1.0
    assert weight[1] == pytest.approx(np.log(100 / 50) / np.log(100 / 25), rel=1e-12)


def test_each_sub_point_shares_between_two_adjacent_bins_and_keeps_its_flux() -> None:
    """Per cell the entries' shares add up to 1 (all sub-points within range), every cell has
    at most two distance bins per sub-point and they are neighbours."""
    rng = np.random.default_rng(4)
    rows, cols = rng.integers(0, 60, 200), rng.integers(0, 60, 200)
    rows, cols = np.unique(np.stack([rows, cols]), axis=1)
    density = rng.uniform(0.1, 2.0, (1, rows.size))
    transform = Affine(50.0, 0, 0, 0, -50.0, 3000.0)
    cells = lit_polar_cells(
        rows, cols, density, transform, (1510.0, 1490.0), distance_edges=EDGES, n_az=32
    )
    per_cell = np.bincount(cells.cell, weights=cells.share, minlength=cells.n_cells)
    np.testing.assert_allclose(per_cell, 1.0, rtol=1e-12)
    assert np.all(cells.share > 0)
    one = _lit_polar_cells(
        rows, cols, density, transform, (1510.0, 1490.0),
        distance_edges=EDGES, n_az=32, max_samples=16, bins=_nearest_bin,
    )  # fmt: skip
    assert cells.cell.size > one.cell.size  # sub-points that share have two entries
    flux = cells.binned()
    assert flux.sum() == pytest.approx(cells.total_flux[0], rel=1e-12)
    np.testing.assert_allclose(flux.sum(axis=(0, 1)), one.binned().sum(axis=(0, 1)), rtol=1e-12)


def test_a_lone_sub_point_lands_in_two_bins_with_the_weights() -> None:
    """A 1 m cell (one sub-point) 600 m east: w to the bin whose centre lies below 600 m."""
    transform = Affine(1.0, 0, 599.5, 0, -1.0, 0.5)
    polar = polar_map(np.ones((1, 1)), transform, (0.0, 0.0), distance_edges=EDGES, n_az=4)
    lower, weight = distance_shares(600.0, EDGES)
    expected = np.zeros(EDGES.size - 1)
    expected[lower] = weight
    expected[lower + 1] = 1.0 - weight
    np.testing.assert_allclose(polar.flux[0, :, 1], expected, rtol=1e-12, atol=1e-15)
    assert 0.0 < weight < 1.0


@pytest.mark.parametrize("nearest", [False, True])
def test_the_compiled_scatter_equals_numpy_for_either_rule(nearest: bool) -> None:
    rng = np.random.default_rng(8)
    index = rng.choice(120 * 120, 3000, replace=False)
    rows, cols = np.divmod(index, 120)
    density = rng.lognormal(0.0, 1.0, (1, rows.size))
    transform = Affine(25.0, 0, 0, 0, -25.0, 3000.0)
    observer = (1500.0, 1500.0)  # on a cell corner
    cells = _lit_polar_cells(
        rows, cols, density, transform, observer, distance_edges=EDGES, n_az=64,
        max_samples=16, bins=_nearest_bin if nearest else distance_shares,
    )  # fmt: skip
    maps, dropped = polar_flux_levels(
        rows, cols, cells.flux, np.ones((1, rows.size)), transform, observer,
        distance_edges=EDGES, n_az=64, _nearest=nearest,
    )  # fmt: skip
    expected = cells.binned()
    np.testing.assert_allclose(maps[0], expected, rtol=1e-12, atol=1e-12 * expected.max())
    assert dropped[0] == pytest.approx(0.0, abs=1e-9)


# --- the zenith of a lone source moved away from the observer --------------------------------

POSITIONS = np.arange(3000.0, 7000.0 + 1.0, 100.0)  # [m]
#: Largest |L / fit - 1| about a cubic in ln r allowed with sharing; one bin saws by far more.
SMOOTH_BOUND = 0.03


def _deviation(luminance: np.ndarray) -> float:
    x = np.log(POSITIONS)
    fit = np.exp(np.polyval(np.polyfit(x, np.log(luminance), 3), x))
    return float(np.max(np.abs(luminance / fit - 1.0)))


def _sweep(table, rule) -> np.ndarray:
    tables = kernel_slice(table, observer_altitude=0.0)
    z = zenith_per_lumen(tables)
    out = []
    for x in POSITIONS:  # a 100 m cell centred x m east of the observer
        cells = _lit_polar_cells(
            [0], [0], [[1.0]], Affine(100.0, 0, x - 50.0, 0, -100.0, 50.0), (0.0, 0.0),
            distance_edges=tables.distance_edges, n_az=tables.n_az, max_samples=16, bins=rule,
        )  # fmt: skip
        out.append(cells.per_cell(z)[0])
    return np.asarray(out)


def test_a_lone_sources_zenith_is_smooth_in_its_distance() -> None:
    """The short form of ``benchmarks/bench_sky_distance_bins.py`` on a coarse kernel."""
    spec = KernelSpec(r_min=10.0, r_max=30_000.0, n_distance=32, n_elevation=4, n_azimuth=8)
    table = build_kernel(spec, progress=False).kernel
    shared = _deviation(_sweep(table, distance_shares))
    one_bin = _deviation(_sweep(table, _nearest_bin))
    assert shared < SMOOTH_BOUND < one_bin, (shared, one_bin)
    assert one_bin > 5 * shared
