"""The shipped Bright Star Catalogue: its size, its fields, and the parser that made it."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import nightlights.nightsky as nightsky
from nightlights.errors import InputError
from nightlights.nightsky.catalog import FIELDS, PROPER_NAMES, STORED, StarCatalog, load_catalog

BUILD_SCRIPT = Path(nightsky.__file__).parent / "data" / "build_bsc5.py"

#: Three records of CDS V/50 ``catalog`` (HR 424 Polaris, HR 2491 Sirius, HR 92 with no J2000
#: position), copied byte for byte; the ReadMe's byte layout.
RECORDS = (
    "  92 NOVA 1572                                     B Cas                        "
    "                                                                                "
    "                                    *"
    "\n"
    " 424  1Alp UMiBD+88    8   8890   308 907    1477  Alp UMi  012233.7+88462602314"
    "8.7+891551123.28 26.46 2.02  +0.60 +0.38 +0.31   F7:Ib-II          v+0.038-0.015"
    " +.007-017SBO    17  6.8  18.4AB   5*"
    "\n"
    "2491  9Alp CMaBD-16 1591  48915151881 257I   5423           064044.6-16344406450"
    "8.9-164258227.22-08.88-1.46   0.00 -0.05 -0.03   A1Vm               -0.553-1.205"
    " +.375-008SBO    13 10.3  11.2AB   4*"
    "\n"
)


def _build_module() -> ModuleType:
    spec = importlib.util.spec_from_file_location("build_bsc5", BUILD_SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_catalogue_size_and_fields() -> None:
    stars = load_catalog()
    assert isinstance(stars, StarCatalog)
    # Hoffleit & Warren 1991: 9,110 records, 9,096 with a J2000 position and V, 8,786 with B-V
    assert len(stars) == 9096
    assert int(np.sum(np.isfinite(stars.bv))) == 8786
    assert np.all(np.diff(stars.hr) > 0)
    assert np.all((stars.ra >= 0) & (stars.ra < 360))
    assert np.all(np.abs(stars.dec) <= 90)
    assert np.all(np.isfinite(stars.vmag)) and stars.vmag.max() < 8.0
    assert all(getattr(stars, field).shape == (9096,) for field in FIELDS)


def test_sirius_and_polaris_as_in_the_catalogue() -> None:
    stars = load_catalog()
    sirius = stars.select(stars.hr == 2491)
    # CDS V/50 HR 2491: 06 45 08.9 -16 42 58, V -1.46, B-V 0.00, pm -0.553 -1.205
    assert str(sirius.name[0]) == "Sirius"
    assert str(sirius.designation[0]) == "9 Alp CMa"
    assert sirius.ra[0] == pytest.approx(15 * (6 + 45 / 60 + 8.9 / 3600), abs=1e-9)
    assert sirius.dec[0] == pytest.approx(-(16 + 42 / 60 + 58 / 3600), abs=1e-9)
    assert (sirius.vmag[0], sirius.bv[0]) == (-1.46, 0.0)
    assert (sirius.pm_ra[0], sirius.pm_dec[0]) == (-0.553, -1.205)
    polaris = stars.select(stars.hr == 424)
    assert str(polaris.designation[0]) == "1 Alp UMi"
    assert polaris.pm_ra[0] == 0.038  # mu_alpha cos(dec): 44 mas/yr (Hipparcos 44.2)


def test_catalogue_is_cached_and_read_only() -> None:
    stars = load_catalog()
    assert load_catalog() is stars
    with pytest.raises(ValueError, match="read-only"):
        stars.vmag[0] = 0.0


def test_parser_reads_records_and_skips_one_without_position() -> None:
    build = _build_module()
    stars = load_catalog()
    parsed = build.parse_bsc5(RECORDS)
    assert parsed["hr"].tolist() == [424, 2491]  # HR 92 (Tycho's nova) has no position
    for row, hr in enumerate((424, 2491)):
        index = int(np.flatnonzero(stars.hr == hr)[0])
        for field in STORED:
            stored = getattr(stars, "designation" if field == "name" else field)[index]
            value = parsed[field][row]
            if field in ("pm_ra", "pm_dec", "vmag", "bv"):
                assert round(float(value), 3) == stored
            else:
                assert value == stored


def test_star_name_layout() -> None:
    build = _build_module()
    assert build.star_name(" 33    Psc") == "33 Psc"
    assert build.star_name("   Alp1Cen") == "Alp1 Cen"
    assert build.star_name("          ") == ""


#: The Bayer designations of the IAU names (IAU Catalog of Star Names), to check the HR numbers
#: of PROPER_NAMES against the catalogue's own designations.
BAYER = {
    "Alpheratz": "Alp And",
    "Schedar": "Alp Cas",
    "Diphda": "Bet Cet",
    "Polaris": "Alp UMi",
    "Achernar": "Alp Eri",
    "Hamal": "Alp Ari",
    "Algol": "Bet Per",
    "Mirfak": "Alp Per",
    "Aldebaran": "Alp Tau",
    "Capella": "Alp Aur",
    "Rigel": "Bet Ori",
    "Bellatrix": "Gam Ori",
    "Elnath": "Bet Tau",
    "Alnilam": "Eps Ori",
    "Alnitak": "Zet Ori",
    "Betelgeuse": "Alp Ori",
    "Menkalinan": "Bet Aur",
    "Mirzam": "Bet CMa",
    "Canopus": "Alp Car",
    "Alhena": "Gam Gem",
    "Sirius": "Alp CMa",
    "Adhara": "Eps CMa",
    "Wezen": "Del CMa",
    "Castor": "Alp Gem",
    "Procyon": "Alp CMi",
    "Pollux": "Bet Gem",
    "Naos": "Zet Pup",
    "Avior": "Eps Car",
    "Suhail": "Lam Vel",
    "Miaplacidus": "Bet Car",
    "Alphard": "Alp Hya",
    "Regulus": "Alp Leo",
    "Dubhe": "Alp UMa",
    "Denebola": "Bet Leo",
    "Acrux": "Alp1 Cru",
    "Gacrux": "Gam Cru",
    "Mimosa": "Bet Cru",
    "Alioth": "Eps UMa",
    "Spica": "Alp Vir",
    "Alkaid": "Eta UMa",
    "Hadar": "Bet Cen",
    "Menkent": "The Cen",
    "Arcturus": "Alp Boo",
    "Rigil Kentaurus": "Alp1 Cen",
    "Alphecca": "Alp CrB",
    "Dschubba": "Del Sco",
    "Antares": "Alp Sco",
    "Atria": "Alp TrA",
    "Shaula": "Lam Sco",
    "Sargas": "The Sco",
    "Rasalhague": "Alp Oph",
    "Kaus Australis": "Eps Sgr",
    "Vega": "Alp Lyr",
    "Nunki": "Sig Sgr",
    "Altair": "Alp Aql",
    "Peacock": "Alp Pav",
    "Deneb": "Alp Cyg",
    "Enif": "Eps Peg",
    "Alnair": "Alp Gru",
    "Fomalhaut": "Alp PsA",
    "Scheat": "Bet Peg",
    "Markab": "Alp Peg",
}


def test_proper_names_sit_on_their_bayer_stars() -> None:
    stars = load_catalog()
    assert sorted(PROPER_NAMES.values()) == sorted(BAYER)
    for hr, name in PROPER_NAMES.items():
        index = stars.find(hr)
        assert str(stars.name[index]) == name
        assert str(stars.designation[index]).endswith(BAYER[name]), name
    assert np.sum(stars.name != stars.designation) == len(PROPER_NAMES)


def test_find_by_number_name_or_designation() -> None:
    stars = load_catalog()
    sirius = stars.find(2491)
    assert stars.find("Sirius") == stars.find("  sirius ") == sirius
    assert stars.find("9 Alp CMa") == stars.find("alp cma") == sirius
    assert stars.find(np.int16(2491)) == sirius
    with pytest.raises(InputError, match="not in the catalogue"):
        stars.find("Vulcan")
    with pytest.raises(InputError, match="not in the catalogue"):
        stars.find(9999)
