"""Irradiance tiles on a real dask.distributed LocalCluster equal the local result."""

from __future__ import annotations

import numpy as np
import pytest
from distributed import Client, LocalCluster

from nightlights.ground import (
    InfluenceThreshold,
    IntensityTable,
    Luminaires,
    compute_irradiance,
    grid_from_bounds,
    luminaire_rotation,
)


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


@pytest.mark.parametrize("processes", [False, True])
def test_local_cluster_equals_single_process(processes: bool) -> None:
    rng = np.random.default_rng(11)
    luminaires = make_luminaires(60, rng)
    grid = grid_from_bounds((0, 0, 300, 300), 2.0)
    radius = luminaires.radius(InfluenceThreshold("energy", 0.02))
    weights = np.column_stack([np.ones(60), rng.uniform(0.5, 2, 60)])
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
