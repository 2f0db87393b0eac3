"""The explore engine against the stages it must agree with, and where it refuses input.

Every interactive answer has a batch stage that computes the same thing: the panorama
(``skyglow_panorama``), Q and S (``inverse_q``, ``inverse_s``), Eq. 12 dimming (a panorama of
the dimmed raster) and the least-flux dimming (``least_dimming``). The engine's fast paths
(the compiled polar scatter, cached kernel levels) must give their numbers.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import xarray as xr
from affine import Affine

import nightlights as nl
from nightlights.errors import InputError, OutputError, OutputExistsError
from nightlights.explore import ExploreSession, _edits
from nightlights.inverse import InfeasibleTargetError
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
from nightlights.sky.forward import skyglow_panorama

CRS = "EPSG:32635"
TRANSFORM = Affine(20.0, 0.0, 500_000.0, 0.0, -20.0, 6_700_000.0)
OBSERVER = (500_613.3, 6_699_407.1)  # off the cell centres and edges
REGION = [(100.0, 5.0), (200.0, 5.0), (200.0, 40.0), (100.0, 40.0)]


def _raster(bands: int = 1, seed: int = 7) -> Raster:
    rng = np.random.default_rng(seed)
    data = np.zeros((bands, 60, 60))
    lit = rng.choice(3600, 400, replace=False)
    for band in range(bands):
        data[band].flat[lit] = rng.uniform(0.2, 4.0, lit.size) * (0.1 if band else 1.0)
    return Raster(data, TRANSFORM, CRS)


@pytest.fixture(scope="module")
def kernel() -> xr.Dataset:
    spec = KernelSpec(r_max=3000.0, n_distance=10, n_elevation=8, n_azimuth=32, uplight=True)
    return build_kernel(spec, progress=False).kernel


@pytest.fixture(scope="module")
def dem_kernel() -> xr.Dataset:
    spec = KernelSpec(
        r_max=3000.0,
        n_distance=10,
        n_elevation=8,
        n_azimuth=32,
        source_altitudes=(0.0, 40.0),
        observer_altitudes=(0.0, 60.0),
    )
    return build_kernel(spec, progress=False).kernel


@pytest.fixture(scope="module")
def dem() -> Raster:
    y, x = np.mgrid[0:60, 0:60]
    relief = 15.0 + 10.0 * np.sin(x / 9.0) * np.cos(y / 13.0) + 0.2 * x
    return Raster(relief[None], TRANSFORM, CRS)


@pytest.fixture
def session(kernel: xr.Dataset) -> ExploreSession:
    return ExploreSession(Scene(_raster(2), kernel=kernel))


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    finite = np.isfinite(b)
    assert np.array_equal(finite, np.isfinite(a))
    return float(np.max(np.abs(a[finite] - b[finite])) / np.max(np.abs(b[finite])))


# --- forward --------------------------------------------------------------------------------


@pytest.mark.parametrize("observer", [OBSERVER, (500_010.0, 6_698_810.0), (500_900.5, 6_699_000.0)])
def test_panorama_equals_the_skyglow_stage(
    session: ExploreSession, kernel: xr.Dataset, observer: tuple[float, float]
) -> None:
    view = session.panorama(*observer)
    reference = skyglow_panorama(
        Scene(_raster(2), kernel=kernel), Observer(*observer), progress=False
    ).panorama
    assert _relative(view.luminance, reference["luminance"].values) < 1e-9
    assert view.zenith_magnitude == pytest.approx(reference.attrs["zenith_sky_brightness"])
    assert view.bortle == reference.attrs["bortle_class_zenith"]
    payload = view.to_dict()
    assert len(payload["luminance"]) == view.elevation.size
    assert len(payload["luminance"][0]) == view.azimuth.size


def test_panorama_over_terrain_equals_the_skyglow_stage(
    dem_kernel: xr.Dataset, dem: Raster
) -> None:
    # Observer between the kernel's two observer levels, every cell at its own height, and
    # the terrain's horizon masking the panorama.
    session = ExploreSession(Scene(_raster(1), kernel=dem_kernel, dem=dem), height=2.0)
    for observer in (OBSERVER, (500_200.0, 6_699_100.0)):
        view = session.panorama(*observer)
        reference = skyglow_panorama(
            Scene(_raster(1), kernel=dem_kernel, dem=dem),
            Observer(*observer, height=2.0),
            progress=False,
        ).panorama
        assert _relative(view.luminance, reference["luminance"].values) < 1e-9
        assert view.observer_altitude == pytest.approx(reference.attrs["observer_altitude_m"])


def test_panorama_from_another_crs(session: ExploreSession) -> None:
    from pyproj import Transformer

    to_lonlat = Transformer.from_crs(CRS, "EPSG:4326", always_xy=True)
    lon, lat = to_lonlat.transform(*OBSERVER)
    view = session.panorama(lon, lat, crs="EPSG:4326")
    assert view.x == pytest.approx(OBSERVER[0], abs=1e-6)
    assert _relative(view.luminance, session.panorama(*OBSERVER).luminance) < 1e-6


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"x": 600_000.0, "y": 6_699_410.0}, "outside the lit cells"),
        ({"x": float("nan"), "y": 6_699_410.0}, "finite"),
        ({"x": OBSERVER[0], "y": OBSERVER[1], "height": -1.0}, "height"),
        ({"x": OBSERVER[0], "y": OBSERVER[1], "which": "edited"}, "which"),
    ],
)
def test_panorama_refuses_bad_observers(
    session: ExploreSession, kwargs: dict[str, object], message: str
) -> None:
    with pytest.raises(InputError, match=message):
        session.panorama(**kwargs)  # type: ignore[arg-type]


# --- inverse --------------------------------------------------------------------------------


@pytest.mark.parametrize("metric", ["pca-norm", "zenith", "hemisphere"])
def test_q_equals_the_inverse_stage(
    session: ExploreSession, kernel: xr.Dataset, metric: str
) -> None:
    view = session.influence(*OBSERVER, kind="q", metric=metric)
    stage = nl.inverse_q(Scene(_raster(2), kernel=kernel), Observer(*OBSERVER), metric=metric)
    assert _relative(view.grid, stage.raster.data[0]) < 1e-9
    if metric != "pca-norm":
        # the per-cell parts add up to the forward panorama's value
        assert view.total == pytest.approx(view.panorama_value, rel=1e-9)


def test_s_equals_the_inverse_stage(session: ExploreSession, kernel: xr.Dataset) -> None:
    view = session.influence(*OBSERVER, kind="s", region=REGION)
    text = " ".join(f"{az},{el}" for az, el in [*REGION, REGION[0]])
    stage = nl.inverse_s(Scene(_raster(2), kernel=kernel), Observer(*OBSERVER), region=text)
    assert _relative(view.grid, stage.raster.data[0]) < 1e-9
    assert view.total == pytest.approx(view.panorama_value, rel=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"kind": "x"}, "kind"),
        ({"kind": "q", "metric": "max"}, "metric"),
        ({"kind": "s"}, "region"),
        ({"kind": "s", "region": [(0.0, 10.0), (90.0, 10.0)]}, "3"),
        ({"kind": "s", "region": [(0.0, 10.0), (90.0, float("inf")), (9.0, 9.0)]}, "finite"),
    ],
)
def test_influence_refuses_bad_requests(
    session: ExploreSession, kwargs: dict[str, object], message: str
) -> None:
    with pytest.raises(InputError, match=message):
        session.influence(*OBSERVER, **kwargs)  # type: ignore[arg-type]


def test_eq12_dimming_equals_a_panorama_of_the_dimmed_raster(
    session: ExploreSession, kernel: xr.Dataset
) -> None:
    q = session.influence(*OBSERVER, kind="q", metric="zenith")
    qa, qb = np.nanpercentile(q.values, [50, 95])
    view = session.dim(*OBSERVER, by="q", metric="zenith", qa=qa, qb=qb, gamma=0.7)
    fraction = np.nan_to_num(view.fraction)
    assert 0 < fraction.max() <= 0.7
    dimmed = _raster(2)
    dimmed = Raster(dimmed.data * (1 - fraction)[None], TRANSFORM, CRS)
    reference = skyglow_panorama(
        Scene(dimmed, kernel=kernel), Observer(*OBSERVER), progress=False
    ).panorama
    assert _relative(view.panorama.luminance, reference["luminance"].values) < 1e-9
    flux = _raster(2).data.sum(axis=0) * 400.0  # [lm]
    assert view.flux_removed == pytest.approx(float(np.sum(flux * fraction)))
    assert view.flux_removed_percent == pytest.approx(100 * view.flux_removed / flux.sum())
    assert view.panorama.zenith_magnitude > view.before.zenith_magnitude


def test_least_dimming_reaches_the_target_with_the_stage_flux(
    session: ExploreSession, kernel: xr.Dataset
) -> None:
    before = session.panorama(*OBSERVER).zenith_magnitude
    target = before + 0.4
    view = session.least_dimming(*OBSERVER, target_zenith=target)
    assert view.panorama.zenith_magnitude == pytest.approx(target, abs=1e-6)
    stage = nl.least_dimming(
        Scene(_raster(2), kernel=kernel),
        [Observer(*OBSERVER)],
        target_zenith=target,
        progress=False,
    )
    assert view.flux_removed == pytest.approx(stage.summary["flux_removed_lm"], rel=1e-6)


def test_least_dimming_of_a_region_and_unreachable_targets(session: ExploreSession) -> None:
    region_view = session.least_dimming(*OBSERVER, region=REGION, target_region=23.0)
    assert region_view.flux_removed > 0
    with pytest.raises(InfeasibleTargetError):
        session.least_dimming(*OBSERVER, target_zenith=30.0, max_dimming=0.2)
    with pytest.raises(InputError, match="one target"):
        session.least_dimming(*OBSERVER)


# --- edits ------------------------------------------------------------------------------------


def test_paint_erase_scale_and_undo_redo_restore_exactly(session: ExploreSession) -> None:
    original = session.emission("current").copy()
    centre = session.panorama(*OBSERVER).zenith_luminance
    painted = session.edit("paint", [(500_300.0, 6_699_700.0)], radius=50.0, value=8.0)
    assert painted.changed_cells > 0 and painted.can_undo and not painted.can_redo
    assert session.panorama(*OBSERVER).zenith_luminance > centre
    session.edit("erase", [(500_000.0, 6_700_000.0), (501_200.0, 6_698_800.0)], radius=30.0)
    scaled = session.edit("scale", [OBSERVER], radius=200.0, value=0.5)
    assert scaled.edit_version == 3
    for _ in range(3):
        session.undo()
    np.testing.assert_array_equal(session.emission("current"), original)
    assert session.panorama(*OBSERVER).zenith_luminance == pytest.approx(centre, rel=1e-12)
    session.redo()
    assert session.panorama(*OBSERVER, which="original").zenith_luminance == pytest.approx(
        centre, rel=1e-12
    )
    assert session.emission("current").max() == pytest.approx(8.0)


def test_paint_splits_between_bands_as_the_raster(session: ExploreSession) -> None:
    session.edit("paint", [OBSERVER], radius=5.0, value=11.0)
    cols, rows = ~session.transform @ OBSERVER
    data = session.current_raster().data[:, int(rows), int(cols)]
    assert data.sum() == pytest.approx(11.0)
    totals = _raster(2).data.sum(axis=(1, 2))
    assert data[1] / data[0] == pytest.approx(totals[1] / totals[0])


@pytest.mark.parametrize(
    ("op", "points", "radius", "value", "message"),
    [
        ("smudge", [OBSERVER], 10.0, 1.0, "edit"),
        ("paint", [], 10.0, 1.0, "point"),
        ("paint", [(float("nan"), 0.0)], 10.0, 1.0, "finite"),
        ("paint", [OBSERVER], 0.0, 1.0, "radius"),
        ("paint", [OBSERVER], 10.0, -1.0, "value"),
        ("scale", [OBSERVER], 10.0, None, "value"),
    ],
)
def test_edits_refuse_bad_strokes(
    session: ExploreSession,
    op: str,
    points: list[tuple[float, float]],
    radius: float,
    value: float | None,
    message: str,
) -> None:
    with pytest.raises(InputError, match=message):
        session.edit(op, points, radius=radius, value=value)
    assert not session.can_undo


def test_a_stroke_off_the_raster_changes_nothing_and_undo_needs_history(
    session: ExploreSession,
) -> None:
    view = session.edit("erase", [(0.0, 0.0)], radius=10.0)
    assert view.changed_cells == 0 and view.edit_version == 0
    with pytest.raises(InputError, match="nothing to undo"):
        session.undo()
    with pytest.raises(InputError, match="nothing to redo"):
        session.redo()


def test_history_beyond_its_memory_is_kept_as_operations(
    session: ExploreSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(_edits, "HISTORY_BYTES", 1)
    for k in range(3):
        session.edit("paint", [(500_100.0 + 200 * k, 6_699_500.0)], radius=30.0, value=3.0)
    assert len(session._edits.ops) == 3
    session.undo()
    assert not session.can_undo  # only the last step could be kept


# --- files ------------------------------------------------------------------------------------


def test_session_file_reopens_with_its_edits(tmp_path, kernel: xr.Dataset) -> None:
    emission = _raster(2).write(tmp_path / "emission.tif")
    kernel_path = tmp_path / "kernel.nc"
    kernel.to_netcdf(kernel_path, engine="h5netcdf")
    session = ExploreSession(Scene(emission, kernel=kernel_path))
    session.edit("paint", [(500_300.0, 6_699_700.0)], radius=50.0, value=8.0)
    session.edit("erase", [OBSERVER], radius=100.0)
    saved = session.save(tmp_path / "s.json", observer=OBSERVER)
    content = json.loads(saved.read_text())
    assert content["emission"] == "emission.tif" and len(content["edits"]) == 2
    with pytest.raises(OutputExistsError):
        session.save(saved)
    reopened = ExploreSession.open(saved)
    np.testing.assert_array_equal(reopened.emission(), session.emission())
    assert reopened.saved_observer == list(OBSERVER)
    assert (
        _relative(reopened.panorama(*OBSERVER).luminance, session.panorama(*OBSERVER).luminance)
        < 1e-12
    )


def test_exports_never_replace_the_files_the_session_was_opened_from(
    tmp_path, kernel: xr.Dataset
) -> None:
    emission = _raster(2).write(tmp_path / "emission.tif")
    kernel_path = tmp_path / "kernel.nc"
    kernel.to_netcdf(kernel_path, engine="h5netcdf")
    session = ExploreSession(nl.Scene(emission, kernel=kernel_path))
    before = {path: path.read_bytes() for path in (emission, kernel_path)}
    (tmp_path / "link.tif").symlink_to(emission)
    view = session.panorama(*OBSERVER)
    for write, label in (
        (lambda: session.export_emission(emission, overwrite=True), "emission"),
        (lambda: session.export_emission(tmp_path / "link.tif", overwrite=True), "emission"),
        (lambda: session.save(kernel_path, overwrite=True), "kernel"),
        (lambda: session.export_panorama(view, nc=kernel_path, overwrite=True), "kernel"),
    ):
        with pytest.raises(OutputError, match=f"is the input {label} "):
            write()
    assert {path: path.read_bytes() for path in before} == before


def test_session_file_errors(tmp_path, kernel: xr.Dataset) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(InputError, match="not a session file"):
        ExploreSession.open(bad)
    bad.write_text(json.dumps({"format": "nightlights-explore", "version": 99}))
    with pytest.raises(InputError, match="version"):
        ExploreSession.open(bad)
    bad.write_text(
        json.dumps({"format": "nightlights-explore", "version": 1, "emission": "gone.tif"})
    )
    with pytest.raises(InputError, match="does not exist"):
        ExploreSession.open(bad)
    with pytest.raises(InputError, match="in-memory"):
        ExploreSession(Scene(_raster(1), kernel=kernel)).save(tmp_path / "x.json")


def test_session_file_warns_when_the_emission_changed(tmp_path, kernel: xr.Dataset) -> None:
    emission = _raster(1).write(tmp_path / "emission.tif")
    kernel.to_netcdf(tmp_path / "kernel.nc", engine="h5netcdf")
    saved = ExploreSession(Scene(emission, kernel=tmp_path / "kernel.nc")).save(tmp_path / "s.json")
    _raster(1, seed=8).write(emission)
    with pytest.warns(UserWarning, match="changed"):
        ExploreSession.open(saved)


def test_exports_are_the_stage_files(tmp_path, session: ExploreSession, kernel) -> None:
    session.edit("scale", [OBSERVER], radius=300.0, value=0.25)
    written = session.export_emission(tmp_path / "edited.tif")
    np.testing.assert_allclose(Raster.read(written).data, session.current_raster().data, rtol=1e-6)
    with pytest.raises(OutputExistsError):
        session.export_emission(written)
    view = session.dim(*OBSERVER, by="s", region=REGION, qa=0.0, qb=1e-9, gamma=0.5)
    plan = session.export_dimming(tmp_path / "plan.tif", view)
    np.testing.assert_allclose(Raster.read(plan).data[0], view.fraction, rtol=1e-6)
    files = session.export_panorama(view.panorama, nc=tmp_path / "p.nc", png=tmp_path / "p.png")
    assert [f.name for f in files] == ["p.nc", "p.png"]
    with xr.open_dataset(files[0], engine="h5netcdf") as saved:
        assert _relative(saved["luminance"].values, view.panorama.luminance) < 1e-9
    with pytest.raises(InputError, match="NetCDF or a PNG"):
        session.export_panorama(view.panorama)


def test_scene_kernel_reaches_across_the_raster(tmp_path) -> None:
    # Without a kernel the session builds one from any cell to the farthest corner.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        session = ExploreSession(Scene(_raster(1), cache_dir=tmp_path), progress=False)
    diagonal = float(np.hypot(1200.0, 1200.0))
    assert session.kernel_info["range_m"] >= diagonal
    corner = session.panorama(500_001.0, 6_698_801.0)
    assert corner.zenith_luminance > 0


def test_each_band_reads_its_emission_function_as_the_stage_does() -> None:
    # An untagged single band is Garstang's F = G = 0.15 mix when the kernel has the lobe
    # table, and a tagged band reads its own function: the session must mix the kernel's
    # tables as the skyglow stage does.
    spec = KernelSpec(
        r_max=3000.0, n_distance=10, n_elevation=8, n_azimuth=32, garstang_lobe=True, uplight=True
    )
    table = build_kernel(spec, progress=False).kernel
    untagged = _raster(1)
    tagged = Raster(untagged.data, TRANSFORM, CRS, band_tags=({"emission_function": "uplight"},))
    lambertian = ExploreSession(Scene(untagged, kernel=build_kernel(
        KernelSpec(r_max=3000.0, n_distance=10, n_elevation=8, n_azimuth=32), progress=False
    ).kernel)).panorama(*OBSERVER).luminance  # fmt: skip
    for raster in (untagged, tagged):
        view = ExploreSession(Scene(raster, kernel=table)).panorama(*OBSERVER)
        reference = skyglow_panorama(
            Scene(raster, kernel=table), Observer(*OBSERVER), progress=False
        ).panorama
        assert _relative(view.luminance, reference["luminance"].values) < 1e-9
        assert not np.allclose(view.luminance, lambertian, rtol=1e-3)
