"""``nightlights kernel build``."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

from nightlights.sky.store import read_kernel
from nightlights_cli.main import cli

SMALL = ["--r-max", "5000", "--n-distance", "4", "--n-elevation", "4", "--n-azimuth", "8"]


def test_kernel_build_writes_a_kernel(tmp_path: Path) -> None:
    out = tmp_path / "kernel.nc"
    result = CliRunner().invoke(
        cli,
        [
            "kernel",
            "build",
            str(out),
            "--turbidity",
            "3",
            "--r-max",
            "20000",
            "--n-distance",
            "6",
            "--n-elevation",
            "4",
            "--n-azimuth",
            "8",
            "--observer-altitude",
            "0",
            "--observer-altitude",
            "300",
            "--nodes",
            "12",
            "--pca-energy",
            "0.999",
            "--tables",
        ],
    )
    assert result.exit_code == 0, result.output
    ds = read_kernel(out)
    assert ds.kernel.shape == (2, 1, 6, 4, 8)
    assert ds.attrs["turbidity"] == 3.0
    assert ds.distance_edges.values[-1] == 20000.0
    assert "bases" in result.output


def test_kernel_build_bad_value_is_one_line(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        cli, ["kernel", "build", str(tmp_path / "k.nc"), "--turbidity", "0.5"]
    )
    assert result.exit_code != 0
    assert "turbidity" in result.output and "Traceback" not in result.output
    result = CliRunner().invoke(cli, ["kernel", "build", str(tmp_path / "no" / "k.nc"), *SMALL])
    assert result.exit_code != 0 and "does not exist" in result.output


def test_kernel_build_backends_give_the_same_tables(tmp_path: Path) -> None:
    tables = {}
    for backend in ("numba", "numpy"):
        out = tmp_path / f"kernel_{backend}.nc"
        args = ["kernel", "build", str(out), *SMALL, "--backend", backend, "--tables"]
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 0, result.output
        ds = read_kernel(out)
        assert ds.attrs["backend"] == backend
        tables[backend] = ds.kernel.values
    np.testing.assert_allclose(tables["numba"], tables["numpy"], rtol=1e-4, atol=1e-30)


def test_kernel_build_without_tables(tmp_path: Path) -> None:
    out = tmp_path / "lean.nc"
    result = CliRunner().invoke(cli, ["kernel", "build", "-o", str(out), *SMALL])
    assert result.exit_code == 0, result.output
    ds = read_kernel(out)
    assert "kernel" not in ds and "coefficient" in ds and ds.attrs["store_tables"] == 0
    shared = tmp_path / "shared.nc"
    args = [*SMALL, "--pca-error", "0.01", "--shared-bases", "--precision", "float32"]
    result = CliRunner().invoke(cli, ["kernel", "build", "-o", str(shared), *args])
    assert result.exit_code == 0, result.output
    assert "mean error" in result.output
    ds = read_kernel(shared)
    assert ds.attrs["shared_bases"] == 1 and ds.attrs["pca_mean_error"] <= 0.01


@pytest.fixture
def fake_build(fake_stage):
    kernel = SimpleNamespace(
        sizes={"distance": 1, "elevation": 1, "azimuth": 2, "component": 1},
        explained_energy=np.ones(1),
        attrs={"content_hash": "0" * 64},
    )
    return fake_stage("build_kernel", SimpleNamespace(kernel=kernel))


def test_kernel_build_defaults_are_skyglows_grid(fake_build, tmp_path: Path) -> None:
    """Same panorama grid as skyglow --n-elevation/--n-azimuth and KernelSpec: 64 x 256."""
    import nightlights as nl

    result = CliRunner().invoke(cli, ["kernel", "build", str(tmp_path / "k.nc")])
    assert result.exit_code == 0, result.output
    (spec, out) = fake_build.args
    assert out == str(tmp_path / "k.nc")
    assert (spec.n_elevation, spec.n_azimuth, spec.n_distance) == (64, 256, 64)
    # every default of the command is KernelSpec's, but the raw tables come only on request
    assert spec == nl.KernelSpec(store_tables=False)


def test_kernel_build_storage_and_precompute_options(fake_build, tmp_path: Path) -> None:
    args = ["--pca-error", "0.01", "--shared-bases", "--precision", "float32"]
    args += ["--altitude-step", "15", "--tables"]
    result = CliRunner().invoke(cli, ["kernel", "build", str(tmp_path / "k.nc"), *args])
    assert result.exit_code == 0, result.output
    spec = fake_build.args[0]
    assert (spec.pca_error, spec.shared_bases, spec.precision) == (0.01, True, "float32")
    assert (spec.altitude_step, spec.store_tables) == (15, True)
    bad = ["kernel", "build", str(tmp_path / "b.nc"), "--pca-error", "2"]
    result = CliRunner().invoke(cli, bad)
    assert result.exit_code != 0 and "pca_error" in result.output
    assert "Traceback" not in result.output
    assert fake_build.kwargs == {"backend": "auto", "progress": True}


def test_n_components_and_its_deprecated_spelling(fake_build, tmp_path: Path) -> None:
    result = CliRunner().invoke(
        cli, ["kernel", "build", str(tmp_path / "a.nc"), "--n-components", "7"]
    )
    assert result.exit_code == 0, result.output
    assert fake_build.calls[-1][0][0].n_components == 7 and result.stderr.count("Deprecation") == 0
    result = CliRunner().invoke(
        cli, ["kernel", "build", str(tmp_path / "b.nc"), "--components", "5"]
    )
    assert result.exit_code == 0, result.output
    assert fake_build.calls[-1][0][0].n_components == 5
    assert "DeprecationWarning: --components is deprecated; use --n-components." in result.stderr
    both = ["kernel", "build", str(tmp_path / "c.nc"), "--components", "5", "--n-components", "7"]
    result = CliRunner().invoke(cli, both)
    assert result.exit_code == 2 and "give only one of" in result.output


def test_kernel_build_refuses_an_existing_output(fake_build, tmp_path: Path) -> None:
    out = tmp_path / "k.nc"
    out.write_bytes(b"keep")
    result = CliRunner().invoke(cli, ["kernel", "build", str(out)])
    assert result.exit_code == 1 and "give --overwrite" in result.output
    assert fake_build.calls == [] and out.read_bytes() == b"keep"
    assert CliRunner().invoke(cli, ["kernel", "build", str(out), "--overwrite"]).exit_code == 0
    result = CliRunner().invoke(cli, ["kernel", "build"])
    assert result.exit_code == 2 and "missing OUTPUT" in result.output


def test_kernel_build_multiple_scattering_choice(tmp_path: Path) -> None:
    """The default counts all scattering orders (brighter than single scattering everywhere);
    --multiple-scattering single keeps Dobashi's single scattering; each kernel says which."""
    kernels = {}
    for choice in ("monte-carlo", "single"):
        out = tmp_path / f"{choice}.nc"
        args = ["kernel", "build", str(out), *SMALL, "--tables", "--multiple-scattering", choice]
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 0, result.output
        kernels[choice] = read_kernel(out)
    assert kernels["monte-carlo"].attrs["multiple_scattering"] == "monte-carlo"
    assert kernels["single"].attrs["multiple_scattering"] == "single"
    ratio = kernels["monte-carlo"].kernel.values / kernels["single"].kernel.values
    assert np.all(ratio >= 1.0) and ratio.max() > 1.05


def test_kernel_build_exact_restores_the_reference(fake_build, tmp_path: Path) -> None:
    """--exact: the reference build for every setting not given; a given one stays."""
    import nightlights as nl

    result = CliRunner().invoke(cli, ["kernel", "build", str(tmp_path / "k.nc"), "--exact"])
    assert result.exit_code == 0, result.output
    spec = fake_build.calls[-1][0][0]
    assert spec == nl.KernelSpec.exact(store_tables=False) and spec.is_exact
    assert (spec.nodes, spec.pca_error, spec.altitude_step) == (12, None, 1)
    args = ["kernel", "build", str(tmp_path / "k2.nc"), "--exact", "--nodes", "16"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    spec = fake_build.calls[-1][0][0]
    assert (spec.nodes, spec.shared_bases, spec.precision) == (16, False, "float64")


def test_a_given_pca_energy_replaces_the_default_error_target(fake_build, tmp_path: Path) -> None:
    args = ["kernel", "build", str(tmp_path / "k.nc"), "--pca-energy", "0.9999"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    spec = fake_build.calls[-1][0][0]
    assert (spec.pca_energy, spec.pca_error) == (0.9999, None)
    args += ["--pca-error", "0.02"]
    result = CliRunner().invoke(cli, [*args[:2], str(tmp_path / "k2.nc"), *args[3:]])
    assert result.exit_code == 0, result.output
    assert fake_build.calls[-1][0][0].pca_error == 0.02
