"""The compiled illuminance kernel against the numpy reference, and its tiling invariance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ies.library import load_library
from nightlights.errors import InputError
from nightlights.ground import (
    InfluenceThreshold,
    IntensityTable,
    Luminaires,
    compute_irradiance,
    grid_from_bounds,
    ground_illuminance,
    luminaire_rotation,
    resolve_luminaires,
    surface_normals,
)
from nightlights.ground._illuminance_numba import BLOCK, _arctan, _atan2, _reduce
from nightlights.ground.illuminance import window_and_pairs

#: Agreement of the backends on every pixel [1] (the kernels differ in the order of their
#: sums and in the arc tangent's last bits).
RTOL = 1e-6


def tables() -> tuple[IntensityTable, ...]:
    def street(v: np.ndarray, h: np.ndarray) -> np.ndarray:
        # an asymmetric lobe with a hard cut-off at 80 deg and uplight above 100 deg
        lobe = 900 * np.cos(np.radians(v)) ** 2 * (1 + 0.7 * np.cos(np.radians(h - 90)))
        return np.where(v < 80, lobe, np.where(v > 100, 15.0, 0.0))

    return (
        IntensityTable.from_function(street, vertical_step=2.5, horizontal_step=5.0),
        IntensityTable.from_function(lambda v, h: 300 + 200 * np.cos(np.radians(h)) + 0 * v),
        IntensityTable.from_function(lambda v, h: 50.0 + v, vertical_step=0.5, horizontal_step=2.5),
    )


def scene(n: int, side: float, rng: np.random.Generator) -> dict:
    heading = rng.uniform(0, 360, n)
    return {
        "light_point": np.column_stack(
            [rng.uniform(-20, side + 20, n), rng.uniform(-20, side + 20, n), rng.uniform(3, 14, n)]
        ),
        "rotation": luminaire_rotation(heading, rng.uniform(-15, 15, n), rng.uniform(-10, 10, n)),
        "street_azimuth": rng.choice([0.0, 90.0, 270.0], n),
        "table_index": rng.integers(0, 3, n),
        "weights": np.column_stack([np.ones(n), rng.uniform(0.2, 3.0, n)]),
        "radius": rng.uniform(5, 60, n),
    }


def both(shape, origin, resolution, lights, **kwargs) -> tuple[np.ndarray, ...]:
    results = [
        window_and_pairs(
            shape,
            origin,
            resolution,
            lights["light_point"],
            lights["rotation"],
            lights["street_azimuth"],
            lights["table_index"],
            tables(),
            lights["weights"],
            radius=lights.get("radius"),
            backend=backend,
            **kwargs,
        )
        for backend in ("numba", "numpy")
    ]
    (fast, fast_pairs), (reference, reference_pairs) = results
    assert fast_pairs == reference_pairs > 0
    return fast, reference


def assert_agree(fast: np.ndarray, reference: np.ndarray) -> None:
    assert np.array_equal(fast == 0, reference == 0)
    lit = reference != 0
    assert np.all(np.abs(fast[lit] - reference[lit]) <= RTOL * np.abs(reference[lit]))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_numba_equals_numpy_on_every_pixel_on_flat_ground(seed: int) -> None:
    rng = np.random.default_rng(seed)
    fast, reference = both((120, 150), (0.25, 239.75), 2.0, scene(80, 240.0, rng))
    assert_agree(fast, reference)
    assert reference.shape == (2, 120, 150) and (reference > 0).mean() > 0.5


def test_numba_equals_numpy_over_terrain() -> None:
    rng = np.random.default_rng(5)
    y, x = np.mgrid[0:100, 0:130]
    ground_z = 4.0 * np.sin(x / 17.0) + 0.05 * y + rng.normal(0, 0.2, x.shape)
    normals = surface_normals(ground_z, 1.5)
    lights = scene(40, 180.0, rng)
    lights["light_point"][:, 2] += 6.0
    fast, reference = both(
        (100, 130), (0.0, 150.0), 1.5, lights, ground_z=ground_z, normals=normals
    )
    assert_agree(fast, reference)
    # the same ground given as a window of a larger grid
    fast_window, reference_window = both(
        (60, 70),
        (0.0, 150.0),
        1.5,
        lights,
        ground_z=ground_z[20:80, 20:90],
        normals=normals[20:80, 20:90],
        offset=(20, 20),
    )
    assert_agree(fast_window, reference_window)
    np.testing.assert_array_equal(fast_window, fast[:, 20:80, 20:90])


def test_unbounded_regions_and_lights_at_pixel_centres() -> None:
    rng = np.random.default_rng(7)
    lights = scene(12, 40.0, rng)
    lights["radius"] = None
    # two lights straight above pixel centres, one on the ground at a pixel centre (the
    # 1 cm guard of the inverse-square law) and one 5 mm beside a centre
    lights["light_point"][:4] = [
        [10.0, 20.0, 6.0],
        [20.0, 10.0, 9.0],
        [30.0, 30.0, 0.0],
        [30.005, 10.0, 0.004],
    ]
    fast, reference = both((41, 41), (0.0, 40.0), 1.0, lights)
    assert_agree(fast, reference)
    assert np.all(np.isfinite(fast))


def test_bundled_luminaires_agree() -> None:
    import geopandas as gpd

    rng = np.random.default_rng(3)
    database = load_library()
    names = sorted(database.systems)
    n = 60
    frame = gpd.GeoDataFrame(
        {
            "system_id": rng.choice(names, n),
            "heading": rng.uniform(0, 360, n),
            "tilt": rng.choice([0.0, 5.0, 10.0], n),
        },
        geometry=gpd.points_from_xy(rng.uniform(0, 200, n), rng.uniform(0, 200, n)),
        crs="EPSG:32633",
    )
    luminaires = resolve_luminaires(frame, database)
    grid = grid_from_bounds((0, 0, 200, 200), 1.0)
    radius = luminaires.radius(InfluenceThreshold())
    weights = np.ones((n, 1))
    fast, reference = (
        compute_irradiance(
            grid, luminaires, weights, radius, backend=backend, tile_size=128, progress=False
        )
        for backend in ("numba", "numpy")
    )
    assert fast.n_pairs == reference.n_pairs > 0
    # float32 rasters: both round the float64 sums, which agree to ~1e-13
    assert_agree(fast.bands.astype(float), reference.bands.astype(float))


def make_luminaires(n: int, rng: np.random.Generator) -> Luminaires:
    lights = scene(n, 300.0, rng)
    return Luminaires(
        light_id=np.arange(n),
        light_point=lights["light_point"],
        rotation=lights["rotation"],
        street_azimuth=lights["street_azimuth"],
        mounting_height=lights["light_point"][:, 2],
        tilt=np.zeros(n),
        roll=np.zeros(n),
        table_index=lights["table_index"],
        intensity_scale=np.ones(n),
        tables=tables(),
        spectra=(None, None, None),
        names=("street", "side", "ramp"),
    )


def test_numba_output_is_bit_identical_for_any_tiling() -> None:
    rng = np.random.default_rng(11)
    luminaires = make_luminaires(70, rng)
    grid = grid_from_bounds((0.3, 99.8, 150.3, 249.8), 1.25)
    radius = rng.uniform(5, 70, 70)
    weights = np.column_stack([np.ones(70), rng.uniform(0.5, 2, 70)])
    y, x = np.mgrid[0 : grid.rows, 0 : grid.cols]
    ground_z = 3.0 * np.cos(x / 23.0) * np.sin(y / 31.0)
    for ground in ({}, {"ground_z": ground_z, "normals": surface_normals(ground_z, 1.25)}):
        results = [
            compute_irradiance(
                grid, luminaires, weights, radius, tile_size=size, progress=False, **ground
            )
            for size in (120, 37, 11)
        ]
        for result in results[1:]:
            np.testing.assert_array_equal(result.bands, results[0].bands)
            assert result.n_pairs == results[0].n_pairs


def test_ground_illuminance_backends_and_a_bad_backend() -> None:
    table = IntensityTable.from_function(lambda v, h: np.where(v < 90, 1000.0, 0.0))
    args = (
        (9, 9),
        (-4.0, 4.0),
        1.0,
        np.array([[0.0, 0.0, 5.0]]),
        luminaire_rotation([0.0]),
        np.zeros(1),
        np.zeros(1, int),
        [table],
        np.ones((1, 1)),
    )
    fast = ground_illuminance(*args)
    reference = ground_illuminance(*args, backend="numpy")
    assert_agree(fast, reference)
    # straight below: E = I / h^2
    assert fast[0, 4, 4] == pytest.approx(1000.0 / 25.0, rel=1e-12)
    with pytest.raises(InputError, match="backend 'cuda'"):
        ground_illuminance(*args, backend="cuda")
    empty = ground_illuminance(
        (3, 4), (0.0, 0.0), 1.0, *[a[:0] for a in args[3:7]], [table], np.ones((0, 2))
    )
    assert empty.shape == (2, 3, 4) and not empty.any()


def test_arc_tangent_matches_the_c_library() -> None:
    rng = np.random.default_rng(0)
    values = np.concatenate(
        [rng.normal(0, 1, 4000), rng.normal(0, 1e-9, 100), [0.0, 1.0, -1.0, 1e300, -1e-300]]
    )
    for y in values[::7]:
        for x in values[::11]:
            assert abs(_atan2(y, x) - math.atan2(y, x)) <= 4.5e-16 * max(1.0, abs(math.atan2(y, x)))
    assert _atan2(0.0, 0.0) == 0.0
    # exactly on the reduction's switch, tan(pi / 8)
    t = math.tan(math.pi / 8)
    assert _atan2(t, 1.0) == pytest.approx(math.pi / 8, rel=2e-16)


def test_the_reduction_for_the_upper_half_plane_is_the_general_one_there() -> None:
    # V = atan2(|b_xy|, -b_z) has y >= 0: the kernel's shorter reduction for it
    rng = np.random.default_rng(1)
    for y, x in zip(np.abs(rng.normal(0, 1, 2000)), rng.normal(0, 1, 2000), strict=True):
        upper, general = _reduce(y, x, True), _reduce(y, x, False)
        assert upper == general
        numerator, denominator, offset = upper
        assert abs(offset + _arctan(numerator / denominator) - math.atan2(y, x)) <= 4.5e-16 * 4


def test_a_nan_ground_height_touches_its_own_pixel_only() -> None:
    ground_z = np.zeros((10, 10))
    normals = surface_normals(ground_z, 1.0)
    table = IntensityTable.from_function(lambda v, h: 100.0 + v)

    def lit(ground: np.ndarray) -> np.ndarray:
        return ground_illuminance(
            (10, 10),
            (0.0, 9.0),
            1.0,
            np.array([[4.0, 6.0, 5.0], [7.0, 2.0, 4.0]]),
            luminaire_rotation([0.0, 30.0]),
            np.zeros(2),
            np.zeros(2, int),
            [table],
            np.ones((2, 1)),
            ground_z=ground,
            normals=normals,
        )[0]

    flat = lit(ground_z)
    ground_z[3, 4] = np.nan  # the table lookup clamps: no read outside the table
    holed = lit(ground_z)
    np.testing.assert_array_equal(np.delete(holed, 34), np.delete(flat, 34))


def test_windows_larger_than_a_block_agree_and_tile_to_the_same_bits() -> None:
    """Windows of several of the kernel's blocks (BLOCK pixels) in both directions, one band
    (the fused lookup-and-add) and two, at 1 m with the bundled photometries and tilts."""
    import geopandas as gpd

    rng = np.random.default_rng(13)
    database = load_library()
    names = sorted(database.systems)
    n = 300
    side = 2 * BLOCK + 90.0
    frame = gpd.GeoDataFrame(
        {
            "system_id": rng.choice(names, n),
            "heading": rng.uniform(0, 360, n),
            "tilt": rng.choice([0.0, 5.0, 10.0], n),
        },
        geometry=gpd.points_from_xy(rng.uniform(-40, side + 40, n), rng.uniform(0, side, n)),
        crs="EPSG:32633",
    )
    luminaires = resolve_luminaires(frame, database)
    grid = grid_from_bounds((0, 0, side, side - 30.0), 1.0)
    radius = luminaires.radius(InfluenceThreshold())
    two = np.column_stack([np.ones(n), rng.uniform(0.2, 3.0, n)])
    runs = {
        # one worker: the 1024-pixel tile is halved to 512 only (balanced_tile_size)
        (bands, size): compute_irradiance(
            grid, luminaires, two[:, :bands], radius, tile_size=size, num_workers=1, progress=False
        )
        for bands in (1, 2)
        for size in (1024, BLOCK + 1, 100, 37)
    }
    one = runs[1, 1024]
    assert one.bands.shape == (1, grid.rows, grid.cols) and grid.rows > 2 * BLOCK
    for (bands, _), result in runs.items():
        np.testing.assert_array_equal(result.bands, runs[bands, 1024].bands)
        assert result.n_pairs == one.n_pairs > 0
    # the one-band path adds the same bits as the general one
    np.testing.assert_array_equal(runs[2, 1024].bands[0], one.bands[0])
    # and the whole grid as one window
    whole, pairs = window_and_pairs(
        (grid.rows, grid.cols),
        (0.5, grid.y_max - 0.5),
        1.0,
        luminaires.light_point,
        luminaires.rotation,
        luminaires.street_azimuth,
        luminaires.table_index,
        luminaires.tables,
        two,
        radius=radius,
    )
    assert pairs == one.n_pairs
    np.testing.assert_array_equal(whole.astype(np.float32), runs[2, 1024].bands)
    reference = compute_irradiance(
        grid, luminaires, two, radius, tile_size=1024, progress=False, backend="numpy"
    )
    assert reference.n_pairs == one.n_pairs
    assert_agree(runs[2, 1024].bands.astype(float), reference.bands.astype(float))
