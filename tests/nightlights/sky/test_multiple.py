"""The multiple-scattering factor in the kernel (nightlights.sky.multiple)."""

from __future__ import annotations

import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.sky import multiple
from nightlights.sky.atmosphere import Atmosphere, garstang_atmosphere
from nightlights.sky.build import compute_kernel
from nightlights.sky.kernel import sky_luminance
from nightlights.sky.montecarlo import monte_carlo_luminance
from nightlights.sky.spec import KernelSpec

SMALL = {"r_min": 500.0, "r_max": 60e3, "n_distance": 6, "n_elevation": 6, "n_azimuth": 8}


@pytest.mark.parametrize("atmosphere", [Atmosphere(), garstang_atmosphere(1.0)])
@pytest.mark.parametrize("shape", ["lambertian", "uplight", "garstang_lobe"])
def test_shipped_tables_cover_the_default_atmospheres(atmosphere: Atmosphere, shape: str) -> None:
    table = multiple.multiple_scattering_table(atmosphere, shape)
    assert table.source == "shipped"
    assert table.factor.shape == (4, 3, 12)
    assert np.all(table.factor >= 1.0)
    # the zenith does not depend on the azimuth: one value per distance
    np.testing.assert_allclose(table.factor[-1], table.factor[-1, :1].repeat(3, axis=0))
    # near the source the factor is modest; it grows with distance out to 50 km
    near = table(90.0, 0.0, 1e3)
    far = table(90.0, 0.0, 50e3)
    assert 1.0 < near < 1.6 < far


def test_interpolation_is_exact_on_the_grid_and_clamped_outside() -> None:
    table = multiple.multiple_scattering_table(Atmosphere(), "lambertian")
    el, az, r = np.meshgrid(
        multiple.FACTOR_ELEVATIONS,
        multiple.FACTOR_AZIMUTHS,
        multiple.FACTOR_DISTANCES,
        indexing="ij",
    )
    np.testing.assert_allclose(table(el, az, r), table.factor, rtol=1e-12)
    r_min, r_max = multiple.FACTOR_DISTANCES[0], multiple.FACTOR_DISTANCES[-1]
    assert table(45.0, 0.0, 10.0) == pytest.approx(table(45.0, 0.0, r_min), rel=1e-12)
    assert table(45.0, 0.0, 5e6) == pytest.approx(table(45.0, 0.0, r_max), rel=1e-12)
    assert table(1.0, 0.0, 3e3) == pytest.approx(table(8.0, 0.0, 3e3), rel=1e-12)
    # relative azimuths fold: -30 and 330 are 30; 200 is 160
    assert table(45.0, -30.0, 3e3) == pytest.approx(table(45.0, 30.0, 3e3), rel=1e-12)
    assert table(45.0, 200.0, 3e3) == pytest.approx(table(45.0, 160.0, 3e3), rel=1e-12)
    # between grid points, ln f is the monotone cubic (Fritsch-Carlson) through the nodes in
    # ln r, as scipy's PCHIP, and linear in elevation
    from scipy.interpolate import PchipInterpolator

    r = np.geomspace(100.0, 300e3, 301)
    for k in (0, 2):  # elevations 8 and 45 deg, away from the source
        pchip = PchipInterpolator(np.log(multiple.FACTOR_DISTANCES), np.log(table.factor[k, 2]))
        np.testing.assert_allclose(table(el[k, 0, 0], 180.0, r), np.exp(pchip(np.log(r))), 1e-12)
    between = np.sqrt(table(20.0, 180.0, r) * table(45.0, 180.0, r))  # ln f halfway: geometric
    np.testing.assert_allclose(table(32.5, 180.0, r), between, rtol=1e-12)


def test_kernel_multiplies_single_scattering_by_the_factor() -> None:
    single = compute_kernel(KernelSpec(**SMALL, multiple_scattering="single"), progress=False)
    default = compute_kernel(KernelSpec(**SMALL), progress=False)
    assert KernelSpec().multiple_scattering == "monte-carlo"
    assert "lambertian: shipped" in default.attrs["multiple_scattering_tables"]
    assert "multiple_scattering_tables" not in single.attrs
    spec = KernelSpec(**SMALL)
    table = multiple.multiple_scattering_table(spec.atmosphere, "lambertian")
    el = spec.elevations[:, None]
    az = spec.azimuths[None, :]
    for k, r in enumerate(spec.distances):
        ratio = default["kernel"].values[0, 0, k] / single["kernel"].values[0, 0, k]
        np.testing.assert_allclose(ratio, table(el, az, r), rtol=1e-5)
    # the specification round-trips through the attributes, and old kernels read as single
    assert KernelSpec.from_kernel(default).content_hash == default.attrs["content_hash"]
    attrs = dict(single.attrs)
    attrs.pop("multiple_scattering")
    assert KernelSpec.from_attrs(attrs).multiple_scattering == "single"


def test_kernel_without_extinction_stays_single_and_says_so() -> None:
    spec = KernelSpec(**SMALL, atmosphere=Atmosphere(extinction=False))
    ds = compute_kernel(spec, progress=False)
    assert ds.attrs["multiple_scattering_tables"].startswith("none: extinction is off")


def test_unknown_model_and_shape_are_refused() -> None:
    with pytest.raises(InputError, match="multiple_scattering 'double'"):
        KernelSpec(multiple_scattering="double")
    with pytest.raises(InputError, match="emission shape 'sideways'"):
        multiple.multiple_scattering_table(Atmosphere(), "sideways")


def test_tabulated_function_borrows_the_nearest_shape() -> None:
    low = 'tabulated:{"angles": [0, 60, 80, 90], "intensities": [0.1, 0.2, 1.0, 1.0]}'
    high = 'tabulated:{"angles": [0, 30, 60, 90], "intensities": [1.0, 0.87, 0.5, 0.0]}'
    assert multiple.nearest_shape(high) == "lambertian"
    assert multiple.nearest_shape(low) in ("uplight", "garstang_lobe")


def test_tables_digest_follows_the_tables_used(monkeypatch: pytest.MonkeyPatch) -> None:
    atmosphere = Atmosphere()
    high = 'tabulated:{"angles": [0, 30, 60, 90], "intensities": [1.0, 0.87, 0.5, 0.0]}'
    lambertian = multiple.tables_digest(atmosphere, ("lambertian",), 4.0)
    assert lambertian == multiple.tables_digest(atmosphere, ("lambertian",), 4.0)
    assert lambertian == multiple.tables_digest(atmosphere, (high,), 4.0)  # its stand-in
    assert lambertian != multiple.tables_digest(atmosphere, ("garstang_lobe",), 4.0)
    assert lambertian != multiple.tables_digest(Atmosphere(turbidity=3.0), ("lambertian",), 4.0)
    # another shipped table (more photons, new values) gives another digest
    shipped = multiple._shipped()
    key = f"lambertian|4|{multiple._atmosphere_key(atmosphere)}"
    changed = dict(shipped) | {key: dict(shipped[key]) | {"photons": 1}}
    monkeypatch.setattr(multiple, "_shipped", lambda: changed)
    assert lambertian != multiple.tables_digest(atmosphere, ("lambertian",), 4.0)


def test_default_within_ten_percent_of_an_independent_monte_carlo() -> None:
    """The default (single x shipped factor) against an all-orders Monte Carlo of another
    seed (turbidity 2, Lambertian and psi^4 lobe, zenith and 45 deg towards and away, 1-20 km):
    within 10 % plus two of the reference's standard errors. Farther away an 8,000-photon
    reference is too noisy to check 10 % (bench_sky_multiple_scattering_tables.py compares
    with 300,000 photons out to 300 km)."""
    atmosphere = Atmosphere()
    el = np.array([90.0, 45.0, 45.0])[:, None]
    az = np.array([0.0, 0.0, 180.0])[:, None]
    r = np.array([1e3, 3e3, 10e3, 20e3])[None, :]
    for shape in ("lambertian", "garstang_lobe"):
        mc = monte_carlo_luminance(
            el, az, r, atmosphere=atmosphere, emission=shape, photons=8_000, seed=7
        )
        single = sky_luminance(el, az, r, atmosphere=atmosphere, emission=shape).ravel()
        default = single * multiple.multiple_scattering_factor(atmosphere, shape, el, az, r).ravel()
        relative = np.abs(default / mc.total - 1.0)
        bound = 0.10 + 2.0 * mc.total_standard_error / mc.total
        assert np.all(relative <= bound), (shape, relative.round(3), bound.round(3))
