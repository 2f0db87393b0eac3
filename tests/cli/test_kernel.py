"""CLI: nightlights kernel build."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from click.testing import CliRunner

from cli.main import cli
from nightlights.sky.precompute import read_kernel


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
            "--energy",
            "0.999",
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
    result = CliRunner().invoke(
        cli, ["kernel", "build", str(tmp_path / "no" / "k.nc"), "--n-distance", "2"]
    )
    assert result.exit_code != 0 and "does not exist" in result.output


def test_kernel_build_backends_give_the_same_tables(tmp_path: Path) -> None:
    tables = {}
    for backend in ("numba", "numpy"):
        out = tmp_path / f"kernel_{backend}.nc"
        args = ["kernel", "build", str(out), "--r-max", "5000", "--n-distance", "4"]
        args += ["--n-elevation", "4", "--n-azimuth", "8", "--backend", backend]
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 0, result.output
        ds = read_kernel(out)
        assert ds.attrs["backend"] == backend
        tables[backend] = ds.kernel.values
    np.testing.assert_allclose(tables["numba"], tables["numpy"], rtol=1e-4, atol=1e-30)


def test_kernel_build_without_tables(tmp_path: Path) -> None:
    out = tmp_path / "lean.nc"
    args = ["kernel", "build", str(out), "--r-max", "5000", "--n-distance", "4"]
    args += ["--n-elevation", "4", "--n-azimuth", "8", "--no-tables"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    ds = read_kernel(out)
    assert "kernel" not in ds and "coefficient" in ds and ds.attrs["store_tables"] == 0
