"""``nightlights inverse q | s | dim | plan`` (and the deprecated ``reduce``) on a tiny two-band
emission raster and a tiny kernel: the outputs and their bands, refusal to replace outputs, usage
errors (exit status 2) and domain errors (exit status 1, one line, no traceback)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from affine import Affine
from click.testing import CliRunner, Result

import nightlights.inverse
from nightlights.io import Raster
from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky.brightness import luminance_to_magnitude
from nightlights_cli.main import cli

#: Observer at the centre of the 20 x 20 grid of 100 m cells [m, EPSG:32635].
OBSERVER = ["--observer", "501000,6699000"]
SECOND_OBSERVER = ["--observer", "500550,6698450"]


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> SimpleNamespace:
    """A tiny kernel (built once for the module) and a two-band emission raster [lm m-2]."""
    folder = tmp_path_factory.mktemp("inverse")
    kernel = folder / "kernel.nc"
    spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16, uplight=True)
    build_kernel(spec, kernel, progress=False)
    data = np.zeros((2, 20, 20))
    data[0, 4:7, 14:17] = 2.0  # a bright block north-east of the observer
    data[1, 4:7, 14:17] = 0.2
    data[0, 15, 3] = 1.0  # one faint cell south-west
    emission = folder / "emission.tif"
    Raster(
        data,
        Affine(100, 0, 500_000, 0, -100, 6_700_000),
        "EPSG:32635",
        ("reflected", "uplight"),
        ("lm m-2", "lm m-2"),
    ).write(emission)
    return SimpleNamespace(kernel=kernel, emission=emission, lit=np.any(data > 0, axis=0))


def _invoke(*args: Any) -> Result:
    return CliRunner().invoke(cli, ["inverse", *(str(a) for a in args)])


def _one_line_error(result: Result, *words: str) -> None:
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output and result.exception is not None
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.output
    for word in words:
        assert word in lines[0], (word, lines[0])


def _q(files: SimpleNamespace, out: Path, *options: Any) -> Result:
    return _invoke("q", files.emission, out, *OBSERVER, "--kernel", files.kernel, *options)


# --- q and s ------------------------------------------------------------------------------------


def test_q_writes_one_band_on_the_emission_grid(files: SimpleNamespace, tmp_path: Path) -> None:
    out = tmp_path / "q.tif"
    result = _q(files, out)
    assert result.exit_code == 0, result.output
    assert "pca-norm" in result.output and str(out) in result.output
    q = Raster.read(out)
    assert q.descriptions == ("q_pca_norm",) and q.shape == (20, 20)
    assert np.array_equal(np.isfinite(q.data[0]), files.lit)  # NaN exactly where unlit
    assert np.nanmin(q.data) > 0
    assert q.tags["metric"] == "pca-norm"


def test_q_zenith_metric_adds_up_to_the_panorama(files: SimpleNamespace, tmp_path: Path) -> None:
    out = tmp_path / "z.tif"
    result = _invoke(  # -o: EMISSION is the only positional path
        "q", files.emission, "-o", out, *OBSERVER, "--kernel", files.kernel, "--metric", "zenith"
    )
    assert result.exit_code == 0, result.output
    assert "mag arcsec-2" in result.output and "forward panorama" in result.output
    z = Raster.read(out)
    assert z.descriptions == ("zenith_luminance",) and z.units == ("cd m-2",)
    total, panorama = float(z.tags["total_cd_m2"]), float(z.tags["panorama_value_cd_m2"])
    assert np.isclose(np.nansum(z.data), total) and np.isclose(total, panorama, rtol=1e-6)


def test_s_writes_the_region_band_and_records_the_region(
    files: SimpleNamespace, tmp_path: Path
) -> None:
    out = tmp_path / "s.tif"
    args = ["s", files.emission, out, *OBSERVER, "--kernel", files.kernel]
    result = _invoke(*args, "--region", "horizon:0,90,30", "--weight", "pixel")
    assert result.exit_code == 0, result.output
    s = Raster.read(out)
    assert s.descriptions == ("region_luminance",) and s.units == ("cd m-2",)
    assert s.tags["region"] == "horizon:0,90,30" and s.tags["weight"] == "pixel"
    # the region looks north-east: the block there outweighs the south-western cell
    assert np.nanmax(s.data[0, 4:7, 14:17]) > s.data[0, 15, 3]


# --- reduce -------------------------------------------------------------------------------------


def test_reduce_by_q_writes_every_output(files: SimpleNamespace, tmp_path: Path) -> None:
    q = tmp_path / "q.tif"
    assert _q(files, q, "--metric", "zenith").exit_code == 0
    highest = float(np.nanmax(Raster.read(q).data))
    out, dimming = tmp_path / "reduced.tif", tmp_path / "dimming.tif"
    summary, png = tmp_path / "summary.json", tmp_path / "before_after.png"
    result = _invoke(
        "dim", files.emission, out, "--by", q, "--qa", 0, "--qb", highest, "--gamma", 0.5,
        "--kernel", files.kernel, "--dimming-output", dimming, "--summary-output", summary,
        "--png", png,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "flux removed" in result.output and "zenith" in result.output
    assert "mag arcsec-2" in result.output
    reduced = Raster.read(out)
    assert reduced.descriptions == ("reflected", "uplight")
    fraction = Raster.read(dimming)
    assert fraction.descriptions == ("dimming",)
    assert np.array_equal(np.isfinite(fraction.data[0]), files.lit)
    assert np.nanmax(fraction.data) == pytest.approx(0.5)  # the brightest cell: gamma_usr
    report = json.loads(summary.read_text())
    assert 0 < report["flux_removed_percent"] < 50
    zenith = report["observers"][0]["zenith"]
    assert zenith["after_mag_arcsec2"] > zenith["before_mag_arcsec2"]  # darker after
    assert f"{report['flux_removed_lm']:.4g} lm" in result.output
    assert png.stat().st_size > 1000


def _zenith_before(files: SimpleNamespace, tmp_path: Path) -> float:
    q = tmp_path / "before.tif"
    assert _q(files, q, "--metric", "zenith").exit_code == 0
    return float(luminance_to_magnitude(float(Raster.read(q).tags["panorama_value_cd_m2"])))


def test_reduce_to_a_zenith_target(files: SimpleNamespace, tmp_path: Path) -> None:
    target = _zenith_before(files, tmp_path) + 0.3  # 0.3 mag darker than now
    out, summary = tmp_path / "reduced.tif", tmp_path / "summary.json"
    result = _invoke(
        "plan", files.emission, out, *OBSERVER, "--target-zenith", target,
        "--kernel", files.kernel, "--summary-output", summary,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "flux removed" in result.output and "least-flux plan" in result.output
    after = json.loads(summary.read_text())["observers"][0]["zenith"]["after_mag_arcsec2"]
    assert after == pytest.approx(target, abs=1e-6)
    assert Raster.read(out).descriptions == ("reflected", "uplight")


def test_reduce_to_region_targets_for_two_observers(files: SimpleNamespace, tmp_path: Path) -> None:
    target = _zenith_before(files, tmp_path) + 0.2
    out, summary = tmp_path / "reduced.tif", tmp_path / "summary.json"
    result = _invoke(
        "plan", files.emission, "-o", out, *OBSERVER, *SECOND_OBSERVER,
        "--target-region", f"zenith:30:{target}", "--max-dimming", 0.9,
        "--kernel", files.kernel, "--summary-output", summary,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "observer 2" in result.output and "region zenith:30" in result.output
    report = json.loads(summary.read_text())
    assert len(report["observers"]) == 2
    for observer in report["observers"]:
        (region,) = observer["regions"]
        assert region["region"] == "zenith:30"
        assert region["after_mag_arcsec2"] >= target - 1e-6


# --- refusal to replace outputs ----------------------------------------------------------------


@pytest.mark.parametrize("which", ["output", "--dimming-output", "--summary-output", "--png"])
def test_reduce_refuses_any_existing_output_before_computing(
    files: SimpleNamespace, tmp_path: Path, which: str
) -> None:
    paths = {
        "output": tmp_path / "r.tif",
        "--dimming-output": tmp_path / "d.tif",
        "--summary-output": tmp_path / "s.json",
        "--png": tmp_path / "p.png",
    }
    paths[which].write_bytes(b"keep")
    args = ["plan", files.emission, paths["output"], *OBSERVER, "--target-zenith", 25]
    for option in ("--dimming-output", "--summary-output", "--png"):
        args += [option, paths[option]]
    result = _invoke(*args, "--kernel", files.kernel)
    assert result.exit_code == 1
    assert result.output == f"Error: {paths[which]}: exists; give --overwrite to replace it\n"
    assert paths[which].read_bytes() == b"keep"
    assert [p for p in paths.values() if p.exists()] == [paths[which]]  # nothing else written


@pytest.mark.parametrize("command", ["q", "s"])
def test_q_and_s_refuse_an_existing_output(
    files: SimpleNamespace, tmp_path: Path, command: str
) -> None:
    out = tmp_path / "out.tif"
    out.write_bytes(b"keep")
    args = [command, files.emission, out, *OBSERVER, "--kernel", files.kernel]
    args += ["--region", "zenith:30"] if command == "s" else []
    result = _invoke(*args)
    assert result.exit_code == 1 and "exists; give --overwrite" in result.output
    assert out.read_bytes() == b"keep"
    result = _invoke(*args, "--overwrite")
    assert result.exit_code == 0, result.output
    assert Raster.read(out).shape == (20, 20)


# --- usage errors (exit status 2) ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ([], "neither"),
        (["--by", "{emission}", "--qa", "0", "--qb", "1", "--target-zenith", "22"], "not both"),
        (["--by", "{emission}", "--qa", "0"], "--by needs --qa and --qb"),
        (["--by", "{emission}", "--qa", "0", "--qb", "1", *OBSERVER], "--observer"),
        (["--by", "{emission}", "--qa", "0", "--qb", "1", "--max-dimming", "0.5"], "--max-dim"),
        (["--target-zenith", "22"], "--observer"),
        (["--target-zenith", "22", *OBSERVER, "--qa", "1"], "--qa: not an option of inverse plan"),
        (["--target-zenith", "22", *OBSERVER, "--gamma", "0.5"], "--gamma"),
        (["--target-region", "zenith30", *OBSERVER], "expected REGION:MAG"),
        (["--target-region", "zenith:30:dark", *OBSERVER], "expected REGION:MAG"),
        (["--target-region", ":21", *OBSERVER], "expected REGION:MAG"),
        (["--target-zenith", "22", *OBSERVER, "--max-dimming", "lots"], "expected a number"),
        (["--target-zenith", "22", "--observer", "nowhere"], "expected X,Y"),
        (["--by", "missing.tif", "--qa", "0", "--qb", "1"], "does not exist"),
    ],
)
def test_deprecated_reduce_usage_errors(
    files: SimpleNamespace, tmp_path: Path, options: list[str], words: str
) -> None:
    """``inverse reduce`` chooses dim or plan by the options given, and refuses a mixture."""
    options = [o.format(emission=files.emission) for o in options]
    out = tmp_path / "r.tif"
    result = _invoke("reduce", files.emission, out, *options)
    assert result.exit_code == 2, result.output
    assert words in result.output and "Traceback" not in result.output
    assert not out.exists()


@pytest.mark.parametrize(
    "args",
    [
        ["q", "{emission}", "{out}", *OBSERVER, "--metric", "brightest"],
        ["q", "{emission}", "{out}"],  # no --observer
        ["q", "{emission}", "{out}", "--observer", "1,2,3"],
        ["q", "{emission}"],  # no OUTPUT
        ["s", "{emission}", "{out}", *OBSERVER],  # no --region
        ["s", "{emission}", "{out}", *OBSERVER, "--region", "zenith:30", "--method", "exact"],
        ["q", "missing.tif", "{out}", *OBSERVER],
    ],
)
def test_q_and_s_usage_errors(files: SimpleNamespace, tmp_path: Path, args: list[str]) -> None:
    out = tmp_path / "o.tif"
    result = _invoke(*(a.format(emission=files.emission, out=out) for a in args))
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and not out.exists()


# --- domain errors (exit status 1, one line) ----------------------------------------------------


def test_bad_region_is_one_line(files: SimpleNamespace, tmp_path: Path) -> None:
    out = tmp_path / "s.tif"
    bow_tie = "0,0 10,10 10,0 0,10 0,0"
    result = _invoke("s", files.emission, out, *OBSERVER, "--region", bow_tie)
    _one_line_error(result, "InputError", "crosses")
    assert not out.exists()
    result = _invoke(
        "plan", files.emission, out, *OBSERVER, "--target-region", "moon:3:22",
        "--kernel", files.kernel,
    )  # fmt: skip
    _one_line_error(result, "unknown shortcut 'moon'")


def test_observer_outside_the_raster_is_one_line(files: SimpleNamespace, tmp_path: Path) -> None:
    result = _invoke(
        "q", files.emission, tmp_path / "q.tif", "--observer", "0,0", "--kernel", files.kernel
    )
    _one_line_error(result, "InputError", "outside")


def test_bad_dimming_values_are_one_line(files: SimpleNamespace, tmp_path: Path) -> None:
    q = tmp_path / "q.tif"
    assert _q(files, q).exit_code == 0
    out = tmp_path / "r.tif"
    base = ["dim", files.emission, out, "--kernel", files.kernel]
    _one_line_error(_invoke(*base, "--by", q, "--qa", 2, "--qb", 1), "InputError")
    _one_line_error(_invoke(*base, "--by", q, "--qa", 0, "--qb", 1, "--gamma", 2), "InputError")
    plan = ["plan", files.emission, out, "--kernel", files.kernel]
    _one_line_error(_invoke(*plan, *OBSERVER, "--target-zenith", 22, "--max-dimming", 1.5), "1.5")
    assert not out.exists()


def test_unreachable_target_is_one_line(files: SimpleNamespace, tmp_path: Path) -> None:
    out = tmp_path / "r.tif"
    result = _invoke(
        "plan", files.emission, out, *OBSERVER, "--target-zenith", 30, "--max-dimming", 0.1,
        "--kernel", files.kernel,
    )  # fmt: skip
    _one_line_error(result, "InfeasibleTargetError", "mag arcsec-2")
    assert not out.exists()


# --- what reaches the library -------------------------------------------------------------------


@pytest.fixture
def fake_inverse(monkeypatch: pytest.MonkeyPatch) -> dict[str, list[tuple[Any, Any]]]:
    """Replace the four library functions by recorders returning canned results."""
    calls: dict[str, list[tuple[Any, Any]]] = {}
    influence = SimpleNamespace(metric="region", total=1e-4, panorama_value=1e-4, seconds=0.01)
    summary = {
        "flux_before_lm": 1000.0,
        "flux_removed_lm": 250.0,
        "flux_removed_percent": 25.0,
        "observers": [{"x": 1.0, "y": 2.0, "zenith": {}}],
    }
    reduced = SimpleNamespace(summary=summary)
    for name, result in [
        ("inverse_q", influence),
        ("inverse_s", influence),
        ("inverse_reduce", reduced),
        ("least_dimming", reduced),
    ]:

        def record(*args: Any, _name: str = name, _result: Any = result, **kwargs: Any) -> Any:
            calls.setdefault(_name, []).append((args, kwargs))
            return _result

        monkeypatch.setattr(nightlights.inverse, name, record, raising=False)
    return calls


def test_scene_options_reach_inverse_s(
    fake_inverse: dict[str, Any], files: SimpleNamespace, tmp_path: Path
) -> None:
    out = tmp_path / "s.tif"
    result = _invoke(
        "s", files.emission, out, *OBSERVER, "--region", "horizon:300,60,20",
        "--observer-crs", "EPSG:32635", "--observer-height", 10, "--turbidity", 3,
        "--components", 4, "--method", "brute", "--n-azimuth", 32,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    ((args, kwargs),) = fake_inverse["inverse_s"]
    scene, observer, written = args
    assert (scene.emission, written) == (str(files.emission), str(out))
    assert (observer.x, observer.y, observer.height) == (501000.0, 6699000.0, 10.0)
    assert observer.crs.to_epsg() == 32635 and kwargs["region"] == "horizon:300,60,20"
    assert (scene.turbidity, kwargs["components"], kwargs["method"]) == (3.0, 4, "brute")
    assert (scene.n_elevation, scene.n_azimuth, scene.n_distance) == (None, 32, None)
    assert kwargs["weight"] == "solid-angle" and scene.kernel is None


def test_target_regions_split_at_the_last_colon(
    fake_inverse: dict[str, Any], files: SimpleNamespace, tmp_path: Path
) -> None:
    polygon = "350,10 10,10 10,40 350,40 350,10"
    result = _invoke(
        "reduce", files.emission, tmp_path / "r.tif", *OBSERVER, *SECOND_OBSERVER,
        "--target-region", "zenith:30:21.5", "--target-region", f"{polygon}:20",
        "--max-dimming", files.emission,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "flux removed: 250 lm = 25.00 % of 1000 lm" in result.output
    ((args, kwargs),) = fake_inverse["least_dimming"]
    assert kwargs["target_region"] == [("zenith:30", 21.5), (polygon, 20.0)]
    assert kwargs["target_zenith"] is None
    assert [(o.x, o.y) for o in args[1]] == [(501000.0, 6699000.0), (500550.0, 6698450.0)]
    assert kwargs["max_dimming"] == str(files.emission)
    assert "inverse_reduce" not in fake_inverse
    assert "DeprecationWarning: cli inverse reduce is deprecated; use cli inverse plan." in (
        result.stderr
    )


def test_by_mode_reaches_inverse_reduce(
    fake_inverse: dict[str, Any], files: SimpleNamespace, tmp_path: Path
) -> None:
    result = _invoke(
        "reduce", files.emission, tmp_path / "r.tif", "--by", files.emission,
        "--qa", "1e-6", "--qb", "2e-6",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    ((_, kwargs),) = fake_inverse["inverse_reduce"]
    assert (kwargs["by"], kwargs["qa"], kwargs["qb"]) == (str(files.emission), 1e-6, 2e-6)
    assert kwargs["gamma"] == 1.0 and kwargs["png"] is None
    assert "least_dimming" not in fake_inverse
    assert "DeprecationWarning: cli inverse reduce is deprecated; use cli inverse dim." in (
        result.stderr
    )


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["dim", "{emission}", "{out}", "--by", "{emission}", "--qa", "0"], "--qb"),
        (["dim", "{emission}", "{out}", "--qa", "0", "--qb", "1"], "--by"),
        (
            [
                "dim",
                "{emission}",
                "{out}",
                "--by",
                "{emission}",
                "--qa",
                "0",
                "--qb",
                "1",
                "--target-zenith",
                "22",
            ],
            "No such option '--target-zenith'",
        ),
        (["plan", "{emission}", "{out}", *OBSERVER], "give --target-zenith and/or --target-region"),
        (["plan", "{emission}", "{out}", "--target-zenith", "22"], "--observer X,Y"),
        (
            ["plan", "{emission}", "{out}", *OBSERVER, "--target-zenith", "22", "--qa", "1"],
            "No such option '--qa'",
        ),
    ],
)
def test_dim_and_plan_usage_errors(
    files: SimpleNamespace, tmp_path: Path, args: list[str], words: str
) -> None:
    """Each job has its own options: the rule's are unknown to plan, the targets' to dim."""
    out = tmp_path / "r.tif"
    result = _invoke(*(a.format(emission=files.emission, out=out) for a in args))
    assert result.exit_code == 2, result.output
    assert words in result.output and "Traceback" not in result.output
    assert not out.exists()


def test_deprecated_output_spellings_still_work(
    fake_inverse: dict[str, Any], files: SimpleNamespace, tmp_path: Path
) -> None:
    dimming, summary = tmp_path / "d.tif", tmp_path / "s.json"
    result = _invoke(
        "dim", files.emission, tmp_path / "r.tif", "--by", files.emission, "--qa", "1e-6",
        "--qb", "2e-6", "--dimming-out", dimming, "--summary", summary,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    ((_, kwargs),) = fake_inverse["inverse_reduce"]
    assert (kwargs["dimming_output"], kwargs["summary_output"]) == (str(dimming), str(summary))
    assert "--dimming-out is deprecated; use --dimming-output." in result.stderr
    assert "--summary is deprecated; use --summary-output." in result.stderr


# --- import cost and mirrored constants ---------------------------------------------------------


def test_inverse_help_does_not_import_the_library() -> None:
    code = (
        "import sys; from click.testing import CliRunner; from nightlights_cli.main import cli; "
        "result = CliRunner().invoke(cli, ['inverse', 'plan', '--help']); "
        "assert result.exit_code == 0 and '--target-region' in result.output, result.output; "
        "heavy = {'rasterio', 'xarray', 'shapely', 'nightlights.inverse', 'nightlights.sky'} "
        "& set(sys.modules); assert not heavy, heavy"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=Path(__file__).parents[2])


def _strict_json(text: str) -> Any:
    """JSON as strict parsers read it (RFC 8259): NaN and Infinity are refused."""

    def refuse(constant: str) -> None:
        raise ValueError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


#: Dimmings that leave the observer's sky without artificial light: the zenith after is 0 cd
#: m-2, +inf mag arcsec-2, which the summary once wrote as Infinity.
DARKENED = [
    ("dim every cell", ["dim", "--by", "{q}", "--qa", "0", "--qb", "1e-30", "--gamma", "1"]),
    ("dim every cell by S", ["dim", "--by", "{s}", "--qa", "0", "--qb", "1e-30", "--gamma", "1"]),
]


@pytest.mark.parametrize(("name", "args"), DARKENED, ids=[d[0] for d in DARKENED])
def test_the_summary_of_a_sky_dimmed_to_darkness_is_strict_json(
    files: SimpleNamespace, tmp_path: Path, name: str, args: list[str]
) -> None:
    q, s = tmp_path / "q.tif", tmp_path / "s.tif"
    assert _q(files, q, "--metric", "zenith").exit_code == 0
    region = ["--region", "zenith:30"]
    made = _invoke("s", files.emission, s, *OBSERVER, "--kernel", files.kernel, *region)
    assert made.exit_code == 0, made.output
    summary = tmp_path / "summary.json"
    command, *options = (arg.format(q=q, s=s) for arg in args)
    result = _invoke(
        command, files.emission, tmp_path / "reduced.tif", *options,
        "--kernel", files.kernel, "--summary-output", summary,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    report = _strict_json(summary.read_text())
    zenith = report["observers"][0]["zenith"]
    assert zenith["after_cd_m2"] == 0.0
    assert zenith["after_mag_arcsec2"] is None
    assert "no artificial light left" in zenith["after_mag_arcsec2_null_reason"]
    assert zenith["before_mag_arcsec2"] > 0
    for area in report["observers"][0].get("regions", []):  # by S: its region too
        assert area["after_mag_arcsec2"] is None and area["after_mag_arcsec2_null_reason"]
