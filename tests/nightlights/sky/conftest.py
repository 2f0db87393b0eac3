"""Small kernels shared by the skyglow runtime tests (built once per session)."""

from __future__ import annotations

import pytest
import xarray as xr

from nightlights.sky import KernelSpec, build_kernel


@pytest.fixture(scope="session")
def small_kernel() -> xr.Dataset:
    """A 24-bin, 8 x 32 kernel over 5 m - 20 km with an uplight table (~1 s)."""
    spec = KernelSpec(
        r_min=5.0, r_max=20_000.0, n_distance=24, n_elevation=8, n_azimuth=32, uplight=True
    )
    return build_kernel(spec, progress=False).kernel
