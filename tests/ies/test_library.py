"""The luminaire database: required systems, photometry, lumens, street side, bad files."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from ies.errors import LuminaireDatabaseError, PhotometryError
from ies.library import REQUIRED_SYSTEMS, load_library
from ies.photometry import forward_azimuth
from ies.spectra import SPDS


@pytest.fixture(scope="module")
def database():
    return load_library()


def test_required_systems_exist(database):
    assert set(REQUIRED_SYSTEMS) <= set(database.systems)


@pytest.mark.parametrize("system_id", REQUIRED_SYSTEMS)
def test_system_photometry_and_lumens(database, system_id):
    system = database.get(system_id)
    photometry = database.photometry(system_id)
    assert photometry is database.photometry(system_id)  # cached
    assert photometry.luminous_flux() == pytest.approx(system.lumens, rel=0.005)
    assert system.spd in SPDS
    assert system.mounting_height > 0
    assert system.provenance


@pytest.mark.parametrize("system_id", REQUIRED_SYSTEMS)
def test_street_azimuth_points_at_the_lobe(database, system_id):
    system = database.get(system_id)
    azimuth = forward_azimuth(database.photometry(system_id))
    difference = (azimuth - system.street_azimuth + 180.0) % 360.0 - 180.0
    assert abs(difference) < 45.0


def test_mounting_heights_follow_the_brief(database):
    assert 4.0 <= database.get("post_top_led").mounting_height <= 6.0
    assert database.get("street_led_small").mounting_height == 8.0
    assert database.get("street_led_medium").mounting_height == 10.0
    assert database.get("road_led_large").mounting_height == 12.0
    assert database.get("road_hps").spd == "HPS"


def test_unknown_system_lists_known_ids(database):
    with pytest.raises(PhotometryError, match="road_hps"):
        database.get("gas_lamp")


def test_malformed_databases(tmp_path):
    with pytest.raises(LuminaireDatabaseError, match="cannot read"):
        load_library(tmp_path)
    (tmp_path / "systems.toml").write_text("[systems.x\n")
    with pytest.raises(LuminaireDatabaseError, match="TOML"):
        load_library(tmp_path)
    (tmp_path / "systems.toml").write_text('[systems.x]\ndescription="d"\nmounting_height="high"\n')
    with pytest.raises(LuminaireDatabaseError, match="mounting_height"):
        load_library(tmp_path)


def test_custom_database_folder(tmp_path):
    from ies.library import __file__ as library_init

    source = tmp_path.parent / "unused"
    del source
    bundled = load_library().root
    shutil.copy(bundled / "road_luminaire_son_tpp_250w.ldt", tmp_path / "lamp.ldt")
    (tmp_path / "systems.toml").write_text(
        "[systems.mine]\n"
        'description = "test"\nmounting_height = 6.0\narm_length = 0.0\ntilt = 0.0\n'
        'street_azimuth = 90.0\nphotometry_file = "lamp.ldt"\nspd = "HPS"\n'
        'lumens = 1000.0\nluminaire_lumens = 1000.0\nprovenance = "copy"\n'
    )
    database = load_library(tmp_path / "systems.toml")
    assert database.photometry("mine").luminous_flux() == pytest.approx(1000.0)
    assert library_init
    (tmp_path / "systems.toml").write_text(
        (tmp_path / "systems.toml").read_text().replace("lamp.ldt", "missing.ldt")
    )
    with pytest.raises(LuminaireDatabaseError, match="not found"):
        load_library(tmp_path)
    assert np.isfinite(database.get("mine").street_azimuth)
