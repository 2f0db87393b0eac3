"""The streamed kernel build (shared bases, no raw tables) and the default build's safety on
small altitude grids."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nightlights.sky.build import (
    MAX_INTERPOLATED_SPAN,
    altitude_pairs,
    compute_kernel,
    kernel_memory,
    streams,
)
from nightlights.sky.spec import KernelSpec

GRID = {
    "r_min": 10.0,
    "r_max": 3000.0,
    "n_distance": 6,
    "n_elevation": 4,
    "n_azimuth": 8,
    "source_altitudes": np.arange(4) * 100.0,
    "observer_altitudes": np.arange(5) * 100.0,
    "uplight": True,
    "altitude_step": 3,
}


def test_streamed_build_equals_the_in_memory_one() -> None:
    """The same settings built level by level through disk and in memory (where the raw
    tables are output) give the same bases, coefficients and error."""
    streamed_spec = KernelSpec(**GRID, store_tables=False)
    assert streams(streamed_spec) and not streams(KernelSpec(**GRID))
    streamed = compute_kernel(streamed_spec, progress=False)
    held = compute_kernel(KernelSpec(**GRID), progress=False)
    assert "kernel" not in streamed and "kernel" in held
    for name in ("basis", "coefficient", "coefficient_uplight", "basis_fft_real"):
        np.testing.assert_array_equal(streamed[name].values, held[name].values)
    assert streamed.attrs["pca_components"] == held.attrs["pca_components"]
    assert streamed.attrs["pca_mean_error"] == held.attrs["pca_mean_error"] <= 0.003
    assert streamed.attrs["multiple_scattering_tables"] == held.attrs["multiple_scattering_tables"]
    assert streamed.attrs["content_hash"] == streamed_spec.content_hash


def test_streamed_estimate_grows_with_observer_levels_by_their_output_only() -> None:
    """The streamed estimate holds one level of images: another observer level adds only its
    summary and coefficients (k directions of p pixels, m images x k), not its images, while
    the in-memory tables grow by every level's images."""
    from nightlights.sky.build import ESTIMATED_COMPONENTS

    common = {"n_distance": 64, "n_elevation": 32, "n_azimuth": 128}
    sources = np.arange(8) * 62.5

    def estimate(levels: int, store: bool) -> float:
        spec = KernelSpec(
            **common,
            source_altitudes=sources,
            observer_altitudes=np.arange(levels) * 62.5,
            store_tables=store,
        )
        return kernel_memory(spec)

    m, p = 8 * 64, 32 * 128  # one level's images and pixels
    k = min(m, p, ESTIMATED_COMPONENTS)
    per_level_output = 8.0 * (k * p + 2 * m * k)
    assert estimate(16, False) - estimate(1, False) <= 15 * per_level_output
    assert estimate(16, True) - estimate(1, True) >= 15 * 2 * 4.0 * m * p  # two table copies


@pytest.mark.parametrize("levels", [1, 2, 3])
def test_small_grids_are_integrated_in_full(levels: int) -> None:
    """1-3 levels: the middle of three levels is interpolated only when its neighbours are
    within 937.5 m of each other (300 m apart), else integrated (the span cap)."""
    for spacing in (300.0, 500.0, 1000.0):
        h = np.arange(levels) * spacing
        computed, interpolated = altitude_pairs(h, h, 15)
        span_ok = spacing * 2 <= MAX_INTERPOLATED_SPAN
        assert computed.all() == (levels < 3 or not span_ok)
        for pair in interpolated:
            low, high = h[pair.lower[0]], h[pair.upper[0]]
            assert high - low <= MAX_INTERPOLATED_SPAN


def test_span_cap_keeps_the_step_on_dobashis_grid() -> None:
    """Dobashi's 16 levels 62.5 m apart: the cap (15 x 62.5 m) leaves the 60 pairs of step 15;
    levels twice as far apart are integrated every 7 levels."""
    h = np.arange(16) * 62.5
    assert int(altitude_pairs(h, h, 15)[0].sum()) == 60
    wide, interpolated = altitude_pairs(2 * h, 2 * h, 15)
    assert int(wide.sum()) > 60
    assert max(2 * h[p.upper[0]] - 2 * h[p.lower[0]] for p in interpolated) <= 937.5


def test_a_scene_kernel_with_one_observer_level_integrates_every_pair() -> None:
    spec = KernelSpec(source_altitudes=np.arange(16) * 50.0, n_distance=4, n_elevation=2)
    computed, interpolated = altitude_pairs(
        np.asarray(spec.observer_altitudes), np.asarray(spec.source_altitudes), spec.altitude_step
    )
    assert computed.all() and not interpolated


def test_level_rows_read_blocks_into_one_shared_buffer(tmp_path: Path) -> None:
    """A level file read a block of rows at a time gives the rows of the array; consecutive
    blocks go into one buffer shared by the levels, other keys are copied."""
    from nightlights.sky.build import _LevelRows

    tables = np.arange(2 * 3 * 5 * 2 * 4, dtype=np.float32).reshape(2, 3, 5, 2, 4)
    buffer: list[np.ndarray] = []
    levels = []
    for o in range(2):
        np.save(tmp_path / f"final-{o}.npy", tables[o : o + 1])
        levels.append(_LevelRows(tmp_path / f"final-{o}.npy", (15, 8), buffer))
    for o, level in enumerate(levels):
        rows = tables[o].reshape(15, 8)
        for key in (slice(0, 4), slice(12, 40), slice(None), slice(3, 3), slice(None, None, 4)):
            np.testing.assert_array_equal(level[key], rows[key])
    first = levels[0][0:15]
    assert np.shares_memory(first, levels[1][0:15])  # the shared buffer: valid until the next read
    assert not np.shares_memory(levels[0][::2], buffer[0])
