"""Irradiance tiles on a real dask.distributed LocalCluster equal the local result; the
stage's COG holds the tiles' values."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from distributed import Client, LocalCluster

from ies.library import load_library
from nightlights.ground import (
    InfluenceThreshold,
    IntensityTable,
    Luminaires,
    compute_irradiance,
    grid_from_bounds,
    irradiance,
    luminaire_rotation,
)
from nightlights.ground.stage import COG_OPTIONS


def make_luminaires(n: int, rng: np.random.Generator) -> Luminaires:
    tables = (
        IntensityTable.from_function(lambda v, h: np.where(v < 90, 800 * np.cos(np.radians(v)), 0)),
        IntensityTable.from_function(lambda v, h: 300 + 200 * np.cos(np.radians(h)) + 0 * v),
    )
    heading, tilt = rng.uniform(0, 360, n), rng.uniform(0, 15, n)
    return Luminaires(
        light_id=np.arange(n),
        light_point=np.column_stack(
            [rng.uniform(0, 300, n), rng.uniform(0, 300, n), rng.uniform(5, 12, n)]
        ),
        rotation=luminaire_rotation(heading, tilt),
        street_azimuth=np.full(n, 90.0),
        mounting_height=np.full(n, 8.0),
        tilt=tilt,
        roll=np.zeros(n),
        table_index=rng.integers(0, 2, n),
        intensity_scale=np.ones(n),
        tables=tables,
        spectra=(None, None),
        names=("a", "b"),
    )


def two_band_scene(n: int, seed: int) -> tuple:
    """A 300 m square at 2 m, ``n`` lights and two bands (grid, lights, weights, radii)."""
    rng = np.random.default_rng(seed)
    luminaires = make_luminaires(n, rng)
    grid = grid_from_bounds((0, 0, 300, 300), 2.0)
    radius = luminaires.radius(InfluenceThreshold("energy", 0.02))
    weights = np.column_stack([np.ones(n), rng.uniform(0.5, 2, n)])
    return grid, luminaires, weights, radius


@pytest.mark.parametrize("processes", [False, True])
def test_local_cluster_equals_single_process(processes: bool) -> None:
    grid, luminaires, weights, radius = two_band_scene(60, seed=11)
    local = compute_irradiance(grid, luminaires, weights, radius, tile_size=40, progress=False)
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=processes, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        by_address = compute_irradiance(
            grid,
            luminaires,
            weights,
            radius,
            tile_size=40,
            scheduler=cluster.scheduler_address,
            progress=False,
        )
        by_client = compute_irradiance(
            grid, luminaires, weights, radius, tile_size=40, scheduler=client, progress=False
        )
    np.testing.assert_array_equal(by_address.bands, local.bands)
    np.testing.assert_array_equal(by_client.bands, local.bands)
    assert by_address.n_pairs == local.n_pairs > 0
    assert local.bands.shape == (2, 150, 150)


def test_a_failing_tile_raises_and_returns_nothing() -> None:
    rng = np.random.default_rng(2)
    luminaires = make_luminaires(5, rng)
    grid = grid_from_bounds((0, 0, 300, 300), 2.0)
    bad_weights = np.ones((4, 1))  # wrong length: the tiles fail with IndexError
    with pytest.raises(IndexError):
        compute_irradiance(
            grid, luminaires, bad_weights, np.full(5, 50.0), tile_size=40, progress=False
        )


def test_stage_writes_a_valid_cog_of_the_tiled_values(tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    n = 40
    frame = gpd.GeoDataFrame(
        {
            "system_id": rng.choice(sorted(load_library().systems), n),
            "heading": rng.uniform(0, 360, n),
        },
        geometry=gpd.points_from_xy(rng.uniform(0, 700, n), rng.uniform(0, 600, n)),
        crs="EPSG:32633",
    )
    out = tmp_path / "irradiance.tif"
    bounds = (0, 0, 700, 600)
    result = irradiance(frame, out, resolution=1.0, bounds=bounds, tile_size=300, progress=False)
    in_memory = irradiance(frame, resolution=1.0, bounds=bounds, tile_size=64, progress=False)
    with rasterio.open(out) as dataset:
        structure = dataset.tags(ns="IMAGE_STRUCTURE")
        assert structure["LAYOUT"] == "COG"
        assert structure["COMPRESSION"] == COG_OPTIONS["compress"] == "ZSTD"
        assert structure["PREDICTOR"] == "3"  # floating-point predictor
        assert dataset.overviews(1)[0] == 2 and dataset.profile["blockxsize"] == 512
        data = dataset.read(1)
        # the first overview: means of 2 x 2 pixels
        half = dataset.read(1, out_shape=(300, 350))
    assert (data > 0).mean() > 0.5
    np.testing.assert_array_equal(data, result.raster.data[0].astype(np.float32))
    means = data.astype(float).reshape(300, 2, 350, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(half, means, rtol=1e-6)
    np.testing.assert_array_equal(in_memory.raster.data, result.raster.data)
    assert result.grid == in_memory.grid and result.path == out


def test_streamed_tiles_equal_the_gathered_raster_locally_and_on_a_cluster() -> None:
    grid, luminaires, weights, radius = two_band_scene(40, seed=5)
    gathered = compute_irradiance(grid, luminaires, weights, radius, tile_size=40, progress=False)
    assert gathered.bands is not None and gathered.lit

    def stream(**options) -> tuple[np.ndarray, object]:
        canvas = np.full((2, grid.rows, grid.cols), np.nan, dtype=np.float32)
        seen = []

        def write(tile, values) -> None:
            seen.append((tile.row0, tile.col0))
            canvas[:, tile.row0 : tile.row0 + tile.rows, tile.col0 : tile.col0 + tile.cols] = values

        result = compute_irradiance(
            grid, luminaires, weights, radius, tile_size=40, progress=False, write=write, **options
        )
        assert len(seen) == len(set(seen)) == 16  # every tile once (4 x 4 tiles of 40)
        return canvas, result

    local, result = stream()
    assert result.bands is None and result.lit
    assert (result.n_pairs, result.n_lights) == (gathered.n_pairs, gathered.n_lights)
    np.testing.assert_array_equal(local, gathered.bands)
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        remote, _ = stream(scheduler=client)
    np.testing.assert_array_equal(remote, gathered.bands)


def test_the_progress_bar_advances_once_per_tile(monkeypatch: pytest.MonkeyPatch) -> None:
    import nightlights.ground.tiles as tiles

    advanced, prefixes = [], []
    real = tiles.TaskProgress

    class Counting(real):  # type: ignore[misc, valid-type]
        def __init__(self, advance, prefix) -> None:
            prefixes.append(prefix)
            super().__init__(lambda: (advanced.append(1), advance()), prefix)

    monkeypatch.setattr(tiles, "TaskProgress", Counting)
    assert tiles.compute_tiles(lambda x, shared: x + shared, [(1,), (2,), (3,)], shared=10) == [
        11,
        12,
        13,
    ]
    assert len(advanced) == 3
    # every call's tasks have keys of their own: on a cluster that several runs share, equal
    # keys would be taken for the same task and one run would get another's tiles
    tiles.compute_tiles(lambda x, shared: x + shared, [(1,)], shared=20)
    assert len(set(prefixes)) == 2
