"""KernelSpec: attribute round trip, content hash, and the kernel it describes."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

from nightlights.emission_functions import (
    SINE_POWER_FORM,
    register_emission_shape,
    unregister_emission_shape,
)
from nightlights.errors import InputError, OutputError
from nightlights.sky import KernelResult, KernelSpec, build_kernel
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.spec import MAX_KERNEL_RANGE
from nightlights.sky.store import read_kernel

TINY = {"r_min": 20.0, "r_max": 2000.0, "n_distance": 4, "n_elevation": 4, "n_azimuth": 8}

#: One changed value per field (every field of KernelSpec is here: checked below).
CHANGES = {
    "distance_edges": (20.0, 200.0, 2000.0),
    "r_min": 30.0,
    "r_max": 3000.0,
    "n_distance": 5,
    "source_altitudes": (0.0, 100.0),
    "observer_altitudes": (10.0,),
    "n_elevation": 6,
    "n_azimuth": 10,
    "atmosphere": Atmosphere(flat_earth=True),
    "uplight": True,
    "uplight_exponent": 3.0,
    "nodes": 16,
    "leg_nodes": 6,
    "core_radius": 2.0,
    "sub_distances": 2,
    "sub_pixels": 2,
    "supersample": 4,
    "pca_energy": 0.99,
    "n_components": 2,
    "store_tables": False,
    "garstang_lobe": True,
    "tabulated_emission": 'tabulated:{"angles": [0, 90], "intensities": [1, 2]}',
    "pca_error": 0.01,
    "shared_bases": False,
    "precision": "float64",
    "altitude_step": 2,
    "multiple_scattering": "single",
    "emission_shapes": ("spec_test_lobe",),  # registered by the fixture below
}


@pytest.fixture(autouse=True, scope="module")
def _registered_shape() -> Iterator[None]:
    """A registered shape for the ``emission_shapes`` field, removed after the module."""
    register_emission_shape(
        "spec_test_lobe", code=SINE_POWER_FORM, exponent=2.0, doc="sin^2 lobe (test)"
    )
    yield
    unregister_emission_shape("spec_test_lobe")


def test_every_field_is_covered() -> None:
    assert set(CHANGES) == {f.name for f in dataclasses.fields(KernelSpec)}


def test_defaults_match_skyglow() -> None:
    spec = KernelSpec()
    assert (spec.n_elevation, spec.n_azimuth, spec.n_distance) == (64, 256, 64)
    assert spec.distance_edges[0] == 10.0 and spec.distance_edges[-1] == 100_000.0


@pytest.mark.parametrize("field", sorted(CHANGES))
def test_hash_is_sensitive_to_every_field(field: str) -> None:
    base = KernelSpec(**TINY)
    changed = KernelSpec(**{**TINY, field: CHANGES[field]})
    assert changed != base
    assert changed.content_hash != base.content_hash


def test_hash_is_stable() -> None:
    """Equal specifications, equal hashes; the value of a single-scattering kernel is pinned
    so that caches written by earlier versions (same parameters) stay valid, and the default
    (multiple scattering) differs from it."""
    assert KernelSpec(**TINY).content_hash == KernelSpec(**TINY).content_hash
    assert KernelSpec(source_altitudes=(5.0, 0.0)) == KernelSpec(source_altitudes=[0.0, 5.0])
    spec = KernelSpec.exact(n_elevation=32, n_azimuth=128, multiple_scattering="single")
    # pinned: the hash of these parameters, with the atmosphere's derived optical depths rounded
    # to HASH_DIGITS (the same with numpy 2.3 and 2.4) and the distance edges to EDGE_DIGITS
    # (the same with and without AVX-512, whose log and exp differ in the last bit)
    assert spec.content_hash == "37310802e53a30f0fd549f9a8ea06fae6be9b2cad0fd58949059ada95bf61785"
    default = KernelSpec.exact(n_elevation=32, n_azimuth=128)
    assert default.content_hash != spec.content_hash
    # the faster defaults are other parameters: another hash (caches of them are rebuilt)
    fast = KernelSpec(n_elevation=32, n_azimuth=128, multiple_scattering="single")
    assert fast.content_hash != spec.content_hash


def test_defaults_and_the_exact_path() -> None:
    """The defaults are the measured-best build; exact() restores the reference settings and
    a field given to it overrides them."""
    from nightlights.sky.spec import (
        DEFAULT_ALTITUDE_STEP,
        DEFAULT_NODES,
        DEFAULT_PCA_ERROR,
        EXACT_SETTINGS,
    )

    spec = KernelSpec(**TINY)
    assert (spec.nodes, spec.altitude_step) == (DEFAULT_NODES, DEFAULT_ALTITUDE_STEP)
    assert (spec.pca_error, spec.shared_bases, spec.precision) == (
        DEFAULT_PCA_ERROR,
        True,
        "float32",
    )
    assert not spec.is_exact
    exact = KernelSpec.exact(**TINY)
    assert exact.is_exact and all(getattr(exact, k) == v for k, v in EXACT_SETTINGS.items())
    assert KernelSpec.exact(**TINY, nodes=16).nodes == 16
    assert KernelSpec.from_attrs(exact.to_attrs()) == exact


@pytest.mark.parametrize(
    "spec",
    [
        KernelSpec(**TINY),
        KernelSpec(
            **{**TINY, **{k: v for k, v in CHANGES.items() if k not in (*TINY, "emission_shapes")}}
        ),
        KernelSpec(
            distance_edges=[1.0, 7.5, 100.0],
            atmosphere=Atmosphere(aerosol_optical_depth=0.4, rayleigh_optical_depth=0.0),
        ),
    ],
)
def test_attrs_round_trip(spec: KernelSpec) -> None:
    back = KernelSpec.from_attrs(spec.to_attrs())
    assert back == spec and back.content_hash == spec.content_hash


def test_attrs_round_trip_with_a_registered_shape() -> None:
    spec = KernelSpec(**TINY, emission_shapes=("spec_test_lobe",))
    back = KernelSpec.from_attrs(spec.to_attrs())
    assert back == spec and back.content_hash == spec.content_hash
    assert spec.emissions == ("lambertian", "spec_test_lobe")
    # no attribute without registered shapes: the files of earlier kernels stay as they were
    assert "emission_shapes" not in KernelSpec(**TINY).to_attrs()


def test_emission_shapes_must_be_registered_with_a_table() -> None:
    for names, words in (
        (("no_such_shape",), "emission model 'no_such_shape'"),
        (("uplight",), "registered shape with its own kernel table"),
        (("spec_test_lobe", "spec_test_lobe"), "each shape once"),
    ):
        with pytest.raises(InputError, match=words):
            KernelSpec(**TINY, emission_shapes=names)


def test_from_attrs_without_axes_points_to_from_kernel() -> None:
    attrs = KernelSpec(**TINY).to_attrs()
    del attrs["distance_edges"]
    with pytest.raises(InputError, match="from_kernel"):
        KernelSpec.from_attrs(attrs)


def test_kernel_file_round_trip(tmp_path: Path) -> None:
    spec = KernelSpec(**TINY, uplight=True)
    result = build_kernel(spec, tmp_path / "k.nc", progress=False)
    assert isinstance(result, KernelResult) and result.path == tmp_path / "k.nc"
    back = read_kernel(result.path)
    assert back.attrs["content_hash"] == spec.content_hash
    assert KernelSpec.from_attrs(back.attrs) == spec
    # kernels written before the axes were in the attributes: from the coordinates
    old = back.copy()
    for key in ("distance_edges", "source_altitudes", "observer_altitudes", "n_elevation"):
        old.attrs.pop(key)
    old.attrs.pop("n_azimuth")
    assert KernelSpec.from_kernel(old) == spec
    xr.testing.assert_allclose(back["coefficient"], result.kernel["coefficient"])


def test_build_kernel_writes_nothing_without_output(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = build_kernel(KernelSpec(**TINY), progress=False)
    assert result.path is None and list(tmp_path.iterdir()) == []
    assert result.spec == KernelSpec(**TINY)
    with pytest.raises(OutputError, match="does not exist"):
        build_kernel(KernelSpec(**TINY), tmp_path / "missing" / "k.nc", progress=False)


def test_spec_axes() -> None:
    spec = KernelSpec(**TINY)
    np.testing.assert_allclose(spec.edges, np.geomspace(20.0, 2000.0, 5))
    np.testing.assert_allclose(spec.distances, np.sqrt(spec.edges[:-1] * spec.edges[1:]))
    assert spec.elevations.shape == (4,) and spec.azimuths.shape == (8,)


#: r_max or distance edges beyond the kernel's supported range (MAX_KERNEL_RANGE), and its edge.
RANGES = [
    ({"r_max": 1e9}, "r_max=1000000000.0 m; expected at most 300000 m"),
    ({"r_max": 300_001.0}, "r_max=300001.0 m; expected at most 300000 m"),
    ({"distance_edges": (10.0, 1e3, 5e5)}, "distance_edges ending at 500000 m; expected at most"),
    ({"r_max": MAX_KERNEL_RANGE}, None),
]


@pytest.mark.parametrize(("changes", "message"), RANGES)
def test_r_max_is_bounded_by_the_kernels_supported_range(
    changes: dict[str, Any], message: str | None
) -> None:
    grid = {"n_distance": 4, "n_elevation": 4, "n_azimuth": 8, **changes}
    if message is None:
        assert KernelSpec(**grid).r_max == MAX_KERNEL_RANGE
        return
    with pytest.raises(InputError, match=re.escape(message)):
        KernelSpec(**grid)
