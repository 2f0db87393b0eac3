"""Running a project: stages cached by content hashes, reruns only what changed, --force,
and an interrupted stage leaves no output that looks complete."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import nightlights
from nightlights.project import ProjectError, check, run
from nightlights.project._cache import RECORD_FOLDER

ALL = ["skyglow:a", "skyglow:b", "inverse-q:a", "inverse-q:b"]


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new, 1), encoding="utf-8")


@pytest.fixture
def ran_once(small_project: Path) -> Path:
    """The small project after one full run."""
    result = run(small_project, progress=False)
    assert result.ran == ALL and result.cached == []
    return small_project


def test_a_second_run_skips_every_stage_and_keeps_the_outputs(ran_once: Path) -> None:
    out = ran_once.parent / "out"
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.is_file()}
    result = run(ran_once, progress=False)
    assert result.ran == [] and result.cached == ALL
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.is_file()} == before
    # the figures of cached stages are reported as when they ran
    assert set(result.zenith) == {"a", "b"}
    assert result.zenith["a"][0] < result.zenith["b"][0]  # a stands by the lit cells
    assert len(result.findings) == 2
    assert check(ran_once) == [(name, True) for name in ALL]


def test_moving_one_observer_reruns_only_its_sky_stages(ran_once: Path) -> None:
    _edit(ran_once, "b = [385200.0, 6671200.0]", "b = [385300.0, 6671200.0]")
    assert check(ran_once) == [
        ("skyglow:a", True),
        ("skyglow:b", False),
        ("inverse-q:a", True),
        ("inverse-q:b", False),
    ]
    result = run(ran_once, progress=False)
    assert result.ran == ["skyglow:b", "inverse-q:b"]
    assert result.cached == ["skyglow:a", "inverse-q:a"]


def test_a_changed_option_reruns_its_stage(ran_once: Path) -> None:
    _edit(ran_once, 'metric = "zenith"', 'metric = "hemisphere"')
    assert run(ran_once, progress=False).ran == ["inverse-q:a", "inverse-q:b"]


def test_a_changed_input_reruns_the_stages_that_read_it(ran_once: Path) -> None:
    import rasterio

    with rasterio.open(ran_once.parent / "emission.tif", "r+") as raster:
        data = raster.read(1)
        data[0, 0] = 1.0
        raster.write(data, 1)
    assert run(ran_once, progress=False).ran == ALL


def test_an_output_changed_or_removed_since_is_made_again(ran_once: Path) -> None:
    out = ran_once.parent / "out"
    (out / "skyglow_a.nc").write_bytes(b"not a panorama")
    (out / "inverse_q_b.tif").unlink()
    assert run(ran_once, progress=False).ran == ["skyglow:a", "inverse-q:b"]


def test_force_reruns_a_stage_and_what_follows_it(ran_once: Path) -> None:
    assert run(ran_once, force=["skyglow"], progress=False).ran == ["skyglow:a", "skyglow:b"]
    with pytest.raises(ProjectError, match=r"force 'darkness': not a stage of .*; allowed: "):
        run(ran_once, force=["darkness"], progress=False)


def test_an_interrupted_stage_leaves_no_output_that_looks_complete(
    ran_once: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = ran_once.parent / "out"
    _edit(ran_once, "a = [385500.0, 6671500.0]", "a = [385450.0, 6671500.0]")

    def interrupted(scene: Any, observer: Any, output: Path, **kwargs: Any) -> None:
        Path(output).write_bytes(b"half a panorama")
        raise KeyboardInterrupt

    monkeypatch.setattr(nightlights, "skyglow", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run(ran_once, progress=False)
    # the stale panorama of the old position is gone with its record; nothing half-written
    assert not (out / "skyglow_a.nc").exists()
    assert (out / "skyglow_b.nc").exists()
    records = out / RECORD_FOLDER
    assert not (records / "skyglow@a.json").exists()
    assert sorted(p.name for p in records.iterdir() if p.is_dir()) == []
    monkeypatch.undo()
    assert run(ran_once, progress=False).ran == ["skyglow:a", "inverse-q:a"]


def test_the_output_folder_can_be_given(small_project: Path, tmp_path: Path) -> None:
    result = run(small_project, tmp_path / "elsewhere", progress=False)
    assert result.folder == tmp_path / "elsewhere"
    assert (tmp_path / "elsewhere" / "skyglow_a.nc").is_file()
    assert not (small_project.parent / "out").exists()


def test_an_output_folder_where_a_stage_would_replace_an_input_is_refused(
    small_project: Path,
) -> None:
    import shutil

    shutil.copy(small_project.parent / "emission.tif", small_project.parent / "darkness.tif")
    _edit(small_project, 'emission = "emission.tif"', 'emission = "darkness.tif"')
    _edit(small_project, "[stages.skyglow]", "[stages.darkness]\n\n[stages.skyglow]")
    with pytest.raises(
        ProjectError,
        match=r"stage darkness would write .*darkness\.tif, which is the input inputs.emission",
    ):
        run(small_project, small_project.parent, progress=False)
    assert not (small_project.parent / ".nightlights").exists()


def test_a_staging_folder_left_by_a_killed_run_is_removed(ran_once: Path) -> None:
    left = ran_once.parent / "out" / RECORD_FOLDER / "skyglow@a.x1.partial"
    left.mkdir()
    (left / "skyglow_a.nc").write_bytes(b"half")
    assert run(ran_once, progress=False).ran == []
    assert not left.exists()


def test_the_observers_stage_writes_the_summary_layer_and_a_panorama_folder(
    small_project: Path,
) -> None:
    import geopandas as gpd

    _edit(
        small_project,
        "[stages.skyglow]",
        "[stages.observers]\npanoramas = true\n\n[stages.skyglow]",
    )
    result = run(small_project, progress=False)
    assert "observers" in result.ran
    out = small_project.parent / "out"
    summary = gpd.read_file(out / "observers.gpkg", layer="observers")
    assert list(summary["name"]) == ["a", "b"]
    assert sorted(p.name for p in (out / "observers_panoramas").iterdir()) == ["a.nc", "b.nc"]
    # a panorama removed from the folder: the stage runs again
    (out / "observers_panoramas" / "b.nc").unlink()
    assert run(small_project, progress=False).ran == ["observers"]
    assert (out / "observers_panoramas" / "b.nc").is_file()


def test_a_dem_reaches_the_sky_stages_and_its_content_is_in_their_key(small_project: Path) -> None:
    import numpy as np
    import rasterio
    from rasterio.transform import from_origin

    dem = small_project.parent / "dem.tif"

    def write_dem(height: float) -> None:
        with rasterio.open(
            dem,
            "w",
            driver="GTiff",
            width=40,
            height=40,
            count=1,
            dtype="float32",
            crs="EPSG:3067",
            transform=from_origin(384500.0, 6672500.0, 50.0, 50.0),
        ) as dst:
            dst.write(np.full((40, 40), height, dtype="float32"), 1)

    write_dem(0.0)
    _edit(small_project, 'emission = "emission.tif"', 'emission = "emission.tif"\ndem = "dem.tif"')
    first = run(small_project, progress=False)
    assert first.ran == ALL
    assert run(small_project, progress=False).ran == []
    write_dem(3.0)
    assert run(small_project, progress=False).ran == ALL


def test_the_kernel_build_is_reported_when_it_is_not_cached(
    small_project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("NIGHTLIGHTS_CACHE", str(tmp_path / "empty-cache"))
    events: list[tuple[str, str]] = []
    run(small_project, progress=False, on_task=lambda name, event, s: events.append((name, event)))
    assert events[:4] == [
        ("skyglow:a", "start"),
        ("kernel", "start"),
        ("kernel", "ran"),
        ("skyglow:a", "ran"),
    ]
    events.clear()
    run(
        small_project,
        tmp_path / "again",
        progress=False,
        on_task=lambda name, event, s: events.append((name, event)),
    )
    assert ("kernel", "start") not in events
