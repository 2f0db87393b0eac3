"""Altitude pairs computed along lines of equal height difference, the others interpolated."""

from __future__ import annotations

import numpy as np
import pytest

from nightlights.sky.build import altitude_pairs, interpolate_pairs, kernel_tables
from nightlights.sky.pca import bright_relative_error
from nightlights.sky.spec import KernelSpec


@pytest.mark.parametrize("step", [1, 2, 3, 5, 15])
def test_altitude_pairs_interpolate_between_pairs_of_the_same_difference(step: int) -> None:
    levels = np.arange(16) * 62.5
    computed, interpolated = altitude_pairs(levels, levels, step)
    assert computed.sum() + len(interpolated) == 256
    assert np.all(np.diag(computed)[[0, -1]]) and computed[0, -1] and computed[-1, 0]
    for pair in interpolated:
        assert not computed[pair.observer, pair.source]
        assert computed[pair.lower] and computed[pair.upper]
        difference = levels[pair.source] - levels[pair.observer]
        for o, c in (pair.lower, pair.upper):
            assert levels[c] - levels[o] == difference
        lo, hi = levels[pair.lower[0]], levels[pair.upper[0]]
        assert lo < levels[pair.observer] < hi
        assert pair.weight == pytest.approx((levels[pair.observer] - lo) / (hi - lo))
        assert hi - lo <= step * 62.5
    if step == 1:
        assert interpolated == []


def test_ends_only_computes_sixty_of_dobashis_256_pairs() -> None:
    levels = np.arange(16) * 62.5
    computed, _ = altitude_pairs(levels, levels, 15)
    assert computed.sum() == 60  # 2 per line of equal difference, 1 on the two corner lines


def test_log_linear_interpolation_is_exact_for_exponential_altitude_dependence() -> None:
    levels = np.arange(6) * 100.0
    computed, interpolated = altitude_pairs(levels, levels, 5)
    pixels = np.linspace(0.5, 2.0, 12).reshape(3, 4)
    h_o, h_c = np.meshgrid(levels, levels, indexing="ij")
    exact = (
        np.exp(-h_o / 1200.0)[..., None, None] * np.exp(-(h_c - h_o) / 800.0)[..., None, None]
    ) * pixels
    table = np.where(computed[..., None, None], exact, 0.0).astype(np.float32)
    table[0, 0, 0, 0] = 0.0  # a zero pixel: linear there
    tables = {"lambertian": table}
    interpolate_pairs(tables, interpolated)
    filled = tables["lambertian"]
    mask = ~computed
    np.testing.assert_allclose(filled[mask][:, 1:], exact[mask][:, 1:], rtol=2e-6)
    assert np.all(filled[mask] > 0)


def test_interpolated_tables_match_computed_ones() -> None:
    common = {
        "r_min": 5.0,
        "r_max": 5_000.0,
        "n_distance": 6,
        "n_elevation": 4,
        "n_azimuth": 8,
        "source_altitudes": np.arange(5) * 62.5,
        "observer_altitudes": np.arange(5) * 62.5,
        "nodes": 8,
    }
    full = kernel_tables(KernelSpec(**common, altitude_step=1), progress=False)["lambertian"]
    spec = KernelSpec(**common, altitude_step=4)
    fast = kernel_tables(spec, progress=False)["lambertian"]
    computed, _ = altitude_pairs(np.arange(5) * 62.5, np.arange(5) * 62.5, 4)
    np.testing.assert_array_equal(fast[computed], full[computed])
    error = bright_relative_error(fast[~computed].reshape(-1, 32), full[~computed].reshape(-1, 32))
    assert 0.0 < error < 1e-3
    assert spec.content_hash != KernelSpec(**common, altitude_step=1).content_hash
    # the hash keys of kernel format 2: no key at the exact path's value
    assert "altitude_step" not in KernelSpec(**common, altitude_step=1).parameters()


def test_interpolation_is_log_linear_where_both_images_are_positive_else_linear() -> None:
    """Both forms computed over every pixel and then chosen give, pixel by pixel, what each
    form gives on its own pixels (float32 images, as the tables hold them)."""
    from nightlights.sky.build import _interpolated

    rng = np.random.default_rng(3)
    lower = (rng.lognormal(size=500) * 1e-9).astype(np.float32)
    upper = (lower * rng.lognormal(sigma=0.3, size=500)).astype(np.float32)
    lower[:10], upper[5:15] = 0.0, -1e-12
    w = 0.3
    got = _interpolated(lower, upper, w)
    positive = (lower > 0) & (upper > 0)
    a, b = lower.astype(float), upper.astype(float)
    np.testing.assert_array_equal(
        got[positive], np.exp((1 - w) * np.log(a[positive]) + w * np.log(b[positive]))
    )
    np.testing.assert_array_equal(got[~positive], (1 - w) * a[~positive] + w * b[~positive])
