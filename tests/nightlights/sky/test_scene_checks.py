"""What ``prepare_scene`` refuses (one-line errors) or warns about, instead of a sky that looks
measured: infinite or empty emission, observers off the Earth or beyond every lit cell's reach,
degree-like coordinates without ``observer_crs``, grid options a given kernel cannot honour,
absurd atmospheres, and a DEM with a hole under a lit cell (the same refusal in every stage)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import xarray as xr
from affine import Affine

import nightlights as nl
from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.explore import ExploreSession
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.build import compute_kernel
from nightlights.sky.setup import prepare_scene

TRANSFORM = Affine(100, 0, 500_000, 0, -100, 6_700_000)  # 40 x 40 cells of 100 m
INSIDE = (502_000.0, 6_698_000.0)


def _raster(fill: float = 0.0, **cells: float) -> Raster:
    flux = np.full((1, 40, 40), fill)
    flux[0, 10:12, 10:12] = 1.0
    for key, value in cells.items():
        row, col = (int(v) for v in key[1:].split("_"))
        flux[0, row, col] = value
    return Raster(flux, TRANSFORM, "EPSG:32635")


def test_infinite_flux_is_refused_with_its_count(small_kernel: xr.Dataset) -> None:
    raster = _raster(c3_3=np.inf, c4_4=-np.inf)
    with pytest.raises(InputError, match=r"in-memory emission raster: 2 non-finite \(inf\)"):
        prepare_scene(Scene(raster, kernel=small_kernel), Observer(*INSIDE))


@pytest.mark.parametrize(("fill", "what"), [(np.nan, "are nodata"), (0.0, "zero or nodata")])
def test_a_raster_without_lit_cells_is_refused(
    small_kernel: xr.Dataset, fill: float, what: str
) -> None:
    raster = Raster(np.full((1, 40, 40), fill), TRANSFORM, "EPSG:32635")
    with pytest.raises(InputError, match=f"no lit cell .*{what}"):
        prepare_scene(Scene(raster, kernel=small_kernel), Observer(*INSIDE))


def test_an_observer_beyond_every_cell_is_refused_before_any_kernel_is_built(
    tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import nightlights.sky.scene as setup_module

    def no_build(*args: object, **kwargs: object) -> None:
        raise AssertionError("a kernel was built for an observer out of reach")

    monkeypatch.setattr(setup_module, "get_or_build_kernel", no_build)
    far = (INSIDE[0] + 6.0e6, INSIDE[1])  # 6000 km east
    with pytest.raises(InputError, match=r"outside the lit cells .*kernel's range"):
        prepare_scene(Scene(_raster(), cache_dir=tmp_path), Observer(*far))


def test_a_dark_site_outside_the_raster_within_reach_is_legal(small_kernel: xr.Dataset) -> None:
    dark_site = (496_000.0, 6_699_000.0)  # 4 km west of the raster, 5 km from the lit cells
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)
        setup = prepare_scene(Scene(_raster(), kernel=small_kernel), Observer(*dark_site))
    assert setup.xy == dark_site and setup.polar_cells().binned().sum() > 0


def test_an_observer_beyond_a_given_kernel_is_refused(small_kernel: xr.Dataset) -> None:
    beyond = (INSIDE[0] + 30_000.0, INSIDE[1])  # 20 km kernel
    with pytest.raises(InputError, match=r"kernel's range \(20 km\)"):
        prepare_scene(Scene(_raster(), kernel=small_kernel), Observer(*beyond))


def test_degrees_without_an_observer_crs_get_the_hint(small_kernel: xr.Dataset) -> None:
    with pytest.raises(InputError, match="look like degrees: give observer_crs='EPSG:4326'"):
        prepare_scene(Scene(_raster(), kernel=small_kernel), Observer(24.9, 60.2))


def test_degree_like_numbers_near_a_local_raster_warn() -> None:
    local = Raster(_raster().data, Affine(10, 0, 0, 0, -10, 400), "EPSG:32635")
    spec = KernelSpec(r_min=5.0, r_max=2000.0, n_distance=8, n_elevation=4, n_azimuth=8)
    with pytest.warns(DataQualityWarning, match="look like degrees"):
        prepare_scene(
            Scene(local, kernel=compute_kernel(spec, progress=False)), Observer(-50.0, 60.0)
        )


@pytest.mark.parametrize("observer", [(24.9, 95.0), (400.0, 60.0)])
def test_coordinates_off_the_earth_are_refused(
    small_kernel: xr.Dataset, observer: tuple[float, float]
) -> None:
    with pytest.raises(InputError, match="latitude within"):
        prepare_scene(Scene(_raster(), kernel=small_kernel), Observer(*observer, crs="EPSG:4326"))


def test_a_garbage_observer_crs_is_a_crs_error(small_kernel: xr.Dataset) -> None:
    with pytest.raises(CRSError, match="not a CRS"):
        prepare_scene(Scene(_raster(), kernel=small_kernel), Observer(*INSIDE, crs="EPSG:999999"))


@pytest.mark.parametrize("option", ["n_azimuth", "n_elevation", "n_distance"])
def test_grid_options_a_given_kernel_fixes_are_refused(
    small_kernel: xr.Dataset, option: str
) -> None:
    with pytest.raises(InputError, match=f"{option}=1: the kernel fixes the grid"):
        prepare_scene(Scene(_raster(), kernel=small_kernel, **{option: 1}), Observer(*INSIDE))
    # the kernel's own values are accepted
    own = {"n_azimuth": 32, "n_elevation": 8, "n_distance": 24}[option]
    assert prepare_scene(
        Scene(_raster(), kernel=small_kernel, **{option: own}), Observer(*INSIDE)
    ).slices


@pytest.mark.parametrize(
    ("parameters", "match"),
    [
        ({"turbidity": 1e6}, "turbidity 1000000.0; expected 1 .* to 64"),
        ({"turbidity": 0.5}, "turbidity 0.5"),
        ({"turbidity": np.nan}, "turbidity nan"),
        ({"aerosol_optical_depth": 1e3}, "optical depth from 0 to 10"),
        ({"wavelength_nm": 5.0}, "300-1100 nm"),
        ({"aerosol_scale_height": 1e9}, "at most 100000 m"),
        ({"angstrom_exponent": -3.0}, "angstrom_exponent"),
    ],
)
def test_absurd_atmospheres_are_one_line_errors(parameters: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        Atmosphere(**parameters)


def test_a_kernel_that_is_zero_everywhere_is_refused() -> None:
    # No accepted atmosphere gives one (the range checks keep it so); the check stays as the
    # last guard against a black sky for any scene.
    from nightlights.sky.build import _check_tables

    spec = KernelSpec(r_min=10.0, r_max=1000.0, n_distance=2, n_elevation=4, n_azimuth=8)
    with pytest.raises(InputError, match="zero everywhere: with turbidity 2"):
        _check_tables({"lambertian": np.zeros((1, 1, 2, 4, 8))}, spec)
    with pytest.raises(InputError, match="non-finite"):
        _check_tables({"lambertian": np.full((1, 1, 2, 4, 8), np.nan)}, spec)


def test_skyglow_outputs_are_all_or_nothing(
    small_kernel: xr.Dataset, tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import nightlights.sky.stage as stage_module
    from nightlights.sky import skyglow

    panorama, polar, png = tmp_path / "p.nc", tmp_path / "polar.nc", tmp_path / "p.png"
    panorama.write_bytes(b"previous")

    def broken(*args: object, **kwargs: object) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(stage_module, "render_panorama", broken)
    scene = Scene(_raster(), kernel=small_kernel)
    with pytest.raises(OSError, match="disk full"):
        skyglow(scene, Observer(*INSIDE), panorama, png=png, polar_output=polar)
    assert panorama.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.nc"]  # no temporary left
    monkeypatch.undo()
    skyglow(scene, Observer(*INSIDE), panorama, png=png, polar_output=polar)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.nc", "p.png", "polar.nc"]


def _holed_dem(row: int, col: int) -> Raster:
    """A flat DEM at 0 m on the emission grid with one nodata pixel."""
    heights = np.zeros((1, 40, 40))
    heights[0, row, col] = np.nan
    return Raster(heights, TRANSFORM, "EPSG:32635", ("height",), ("m",))


#: Every stage that takes a DEM, called on a scene whose DEM has a hole under a lit cell.
DEM_STAGES = {
    "skyglow": lambda scene: nl.skyglow(scene, Observer(*INSIDE), progress=False),
    "inverse_q": lambda scene: nl.inverse_q(scene, Observer(*INSIDE), progress=False),
    "inverse_s": lambda scene: nl.inverse_s(
        scene, Observer(*INSIDE), region="zenith:30", progress=False
    ),
    "observers": lambda scene: nl.observers(
        scene, [Observer(*INSIDE, name="a")], top_cells=0, progress=False
    ),
    "explore": lambda scene: ExploreSession(scene, progress=False),
    "darkness": lambda scene: nl.darkness(scene, progress=False),
}


@pytest.mark.parametrize("stage", sorted(DEM_STAGES))
def test_a_dem_hole_under_a_lit_cell_is_refused_by_every_stage(
    small_kernel: xr.Dataset, stage: str
) -> None:
    scene = Scene(_raster(), kernel=small_kernel, dem=_holed_dem(10, 11))
    with pytest.raises(InputError, match=r"in-memory DEM: no terrain height under 1 of \d+"):
        DEM_STAGES[stage](scene)
