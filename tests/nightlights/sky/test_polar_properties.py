"""Property tests of the polar map: flux bookkeeping for any raster, observer and binning."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from affine import Affine
from hypothesis import given, settings
from hypothesis import strategies as st

from nightlights.errors import DataQualityWarning
from nightlights.sky.polar import polar_map

CELL = 50.0
TRANSFORM = Affine(CELL, 0, 1000.0, 0, -CELL, 2000.0)  # 8 x 8 cells over 400 x 400 m


@st.composite
def scenes(draw: st.DrawFn) -> tuple[np.ndarray, tuple[float, float], int]:
    """An 8 x 8 emission raster (some cells dark), an observer near it and an azimuth count."""
    values = draw(
        st.lists(
            st.one_of(st.just(0.0), st.floats(min_value=1e-3, max_value=50.0)),
            min_size=64,
            max_size=64,
        )
    )
    # Observer anywhere from inside the raster to 200 m outside it, possibly on a cell edge.
    x = draw(st.floats(min_value=800.0, max_value=1600.0))
    y = draw(st.floats(min_value=1400.0, max_value=2200.0))
    n_az = draw(st.sampled_from([4, 16, 33, 64, 256]))
    return np.asarray(values).reshape(8, 8), (x, y), n_az


@settings(max_examples=60, deadline=None)
@given(scenes())
def test_polar_map_conserves_flux_for_any_observer(scene) -> None:
    """Every lumen lands in exactly one bin when the distance range covers the raster."""
    emission, observer, n_az = scene
    edges = np.geomspace(1.0, 5_000.0, 20)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)  # nothing may be dropped
        polar = polar_map(emission, TRANSFORM, observer, distance_edges=edges, n_az=n_az)
    total = emission.sum() * CELL**2
    assert polar.flux.shape == (1, edges.size - 1, n_az)
    assert np.all(polar.flux >= 0.0)
    assert polar.total_flux[0] == pytest.approx(total, rel=1e-12)
    assert polar.flux.sum() == pytest.approx(total, rel=1e-12, abs=1e-9)
    assert polar.dropped_flux[0] == pytest.approx(0.0, abs=1e-9 * max(total, 1.0))


@settings(max_examples=40, deadline=None)
@given(scenes(), st.floats(min_value=30.0, max_value=600.0))
def test_binned_plus_dropped_is_the_total(scene, r_max: float) -> None:
    """With a short kernel range the binned and the dropped flux still add up to the total,
    and the warning appears exactly when something is dropped."""
    emission, observer, n_az = scene
    edges = np.geomspace(1.0, r_max, 12)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        polar = polar_map(emission, TRANSFORM, observer, distance_edges=edges, n_az=n_az)
    total = emission.sum() * CELL**2
    assert polar.flux.sum() + polar.dropped_flux.sum() == pytest.approx(total, rel=1e-12, abs=1e-9)
    assert polar.dropped_flux[0] >= -1e-9 * max(total, 1.0)
    warned = any(issubclass(w.category, DataQualityWarning) for w in caught)
    assert warned == bool(polar.dropped_flux[0] > 1e-9 * total)


@settings(max_examples=30, deadline=None)
@given(scenes(), st.floats(min_value=0.01, max_value=10.0))
def test_bands_are_binned_identically(scene, ratio: float) -> None:
    """A second band proportional to the first gives a proportional polar map (same geometry)."""
    emission, observer, n_az = scene
    edges = np.geomspace(1.0, 5_000.0, 16)
    polar = polar_map(
        np.stack([emission, ratio * emission]), TRANSFORM, observer, distance_edges=edges, n_az=n_az
    )
    np.testing.assert_allclose(polar.flux[1], ratio * polar.flux[0], rtol=1e-12, atol=1e-12)


def test_rotating_the_scene_rotates_the_polar_map() -> None:
    """A raster rotated by 90 deg clockwise about the observer shifts the map by n_az / 4 bins
    (azimuth clockwise from north)."""
    rng = np.random.default_rng(3)
    emission = rng.random((8, 8)) * (rng.random((8, 8)) > 0.5)
    observer = (1200.0, 1800.0)  # the raster's centre
    edges = np.geomspace(1.0, 5_000.0, 16)
    n_az = 64
    base = polar_map(emission, TRANSFORM, observer, distance_edges=edges, n_az=n_az)
    # np.rot90(k=-1) turns the picture clockwise: what was north (top) is now east (right).
    turned = polar_map(
        np.rot90(emission, k=-1), TRANSFORM, observer, distance_edges=edges, n_az=n_az
    )
    np.testing.assert_allclose(
        turned.flux[0], np.roll(base.flux[0], n_az // 4, axis=1), rtol=1e-9, atol=1e-9
    )
