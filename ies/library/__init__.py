"""The luminaire database (LDB): light systems with photometry, spectrum and mounting.

A light system (Chuang 2011, Sec. 6.1) bundles what the placement and irradiance stages need
about one kind of streetlight: its pole height, mast-arm length and tilt, which photometric
azimuth faces the street, its photometric file, its spectrum and its flux. The bundled
database lives next to this module (``systems.toml`` plus the photometric files, provenance
in ``README.md``); :func:`load_library` reads it or any folder laid out the same way.

Examples
--------
>>> from ies.library import load_library
>>> db = load_library()
>>> db.get("road_hps").mounting_height
12.0
"""

from __future__ import annotations

import math
import os
import tomllib
import warnings
from dataclasses import dataclass, fields
from pathlib import Path

from ies.errors import LuminaireDatabaseError, PhotometryWarning
from ies.photometry import Photometry
from ies.plausibility import MAX_LUMINAIRE_FLUX, MOUNTING_RANGES
from ies.reader import read_photometry
from ies.spectra import SPDS

#: Ids the street placement stage relies on.
REQUIRED_SYSTEMS = (
    "post_top_led",
    "street_led_small",
    "street_led_medium",
    "road_led_large",
    "road_hps",
)


@dataclass(frozen=True)
class LightSystem:
    """One light system of the luminaire database.

    Attributes
    ----------
    id : str
        Identifier used by the street layers.
    description : str
        What the system is and where it is used.
    mounting_height : float
        Height of the light centre above the ground [m].
    arm_length : float
        Horizontal mast-arm outreach from the pole towards the street [m].
    tilt : float
        Upward tilt of the luminaire about its arm axis [deg].
    street_azimuth : float
        Photometric horizontal angle (C-plane) that faces the street [deg].
    photometry_file : str
        Photometric file, relative to the database folder.
    spd : str
        Name of the spectral power distribution (:data:`ies.spectra.SPDS`).
    lumens : float
        Integrated luminous flux of the luminaire as used [lm].
    provenance : str
        Source of the photometric data and of any assumption [1].
    luminaire_lumens : float or None
        If set, the file's candela are scaled so that the integrated flux equals it [lm].
    """

    id: str
    description: str
    mounting_height: float
    arm_length: float
    tilt: float
    street_azimuth: float
    photometry_file: str
    spd: str
    lumens: float
    provenance: str
    luminaire_lumens: float | None = None


class LuminaireDatabase:
    """Light systems read from a ``systems.toml``; photometry is read lazily and cached.

    Parameters
    ----------
    systems : dict of str to LightSystem
        Systems by id.
    root : Path
        Folder that photometric file names are relative to.
    """

    def __init__(self, systems: dict[str, LightSystem], root: Path) -> None:
        self.systems = systems
        self.root = root
        self._photometry: dict[str, Photometry] = {}

    def __repr__(self) -> str:
        return f"LuminaireDatabase({self.root}, systems={sorted(self.systems)})"

    def get(self, system_id: str) -> LightSystem:
        """The light system with this id.

        Parameters
        ----------
        system_id : str
            Identifier.

        Returns
        -------
        LightSystem
            The system.

        Raises
        ------
        LuminaireDatabaseError
            Unknown id; the message lists the known ids.
        """
        try:
            return self.systems[system_id]
        except KeyError:
            raise LuminaireDatabaseError(
                f"unknown light system {system_id!r} in {self.root / 'systems.toml'}; "
                f"known: {', '.join(sorted(self.systems))}"
            ) from None

    def photometry(self, system_id: str) -> Photometry:
        """Photometry of a system, scaled to ``luminaire_lumens`` when set (cached).

        Parameters
        ----------
        system_id : str
            Identifier.

        Returns
        -------
        Photometry
            Absolute candela distribution.
        """
        system = self.get(system_id)
        if system_id not in self._photometry:
            with warnings.catch_warnings():
                # declared-vs-integrated mismatches are recorded on the object already
                warnings.simplefilter("ignore", PhotometryWarning)
                photometry = read_photometry(self.root / system.photometry_file)
            if system.luminaire_lumens is not None:
                flux = photometry.luminous_flux()
                if not flux > 0:
                    raise LuminaireDatabaseError(
                        f"{self.root / system.photometry_file}: integrated flux {flux:g} lm; "
                        f"cannot scale system {system_id!r} to luminaire_lumens"
                    )
                photometry = photometry.scaled(system.luminaire_lumens / flux)
            self._photometry[system_id] = photometry
        return self._photometry[system_id]


_FIELDS = {f.name: f for f in fields(LightSystem)}
_NUMBERS = ("mounting_height", "arm_length", "tilt", "street_azimuth", "lumens", "luminaire_lumens")


def _system(system_id: str, table: dict[str, object], where: Path) -> LightSystem:
    unknown = set(table) - (set(_FIELDS) - {"id"})
    if unknown:
        raise LuminaireDatabaseError(
            f"{where}: system {system_id!r} has unknown field(s) "
            f"{sorted(unknown)}; expected {sorted(_FIELDS)}"
        )
    values: dict[str, object] = {"id": system_id}
    for name in _FIELDS:
        if name == "id":
            continue
        if name not in table:
            if name == "luminaire_lumens":
                values[name] = None
                continue
            raise LuminaireDatabaseError(f"{where}: system {system_id!r} lacks {name!r}")
        value = table[name]
        if name in _NUMBERS:
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise LuminaireDatabaseError(
                    f"{where}: system {system_id!r} field {name!r} = {value!r}, expected a number"
                )
            value = float(value)
        elif not isinstance(value, str):
            raise LuminaireDatabaseError(
                f"{where}: system {system_id!r} field {name!r} must be text"
            )
        values[name] = value
    system = LightSystem(**values)  # type: ignore[arg-type]
    _check_numbers(system, where)
    if system.spd not in SPDS:
        raise LuminaireDatabaseError(
            f"{where}: system {system_id!r} spd {system.spd!r}, expected one of {', '.join(SPDS)}"
        )
    return system


def _check_numbers(system: LightSystem, where: Path) -> None:
    """Refuse impossible mounting geometry and flux; warn about surprising geometry."""
    for name, limits in MOUNTING_RANGES.items():
        value = getattr(system, name)
        if limits.impossible(value):
            raise LuminaireDatabaseError(
                f"{where}: system {system.id!r} {name} = {value!r}; expected {limits.expected}"
            )
        if limits.unusual(value):
            warnings.warn(
                f"{where}: system {system.id!r} {name} = {value:g} {limits.unit} is unusual "
                f"(usually {limits.usual})",
                PhotometryWarning,
                stacklevel=4,
            )
    if not math.isfinite(system.street_azimuth):
        raise LuminaireDatabaseError(
            f"{where}: system {system.id!r} street_azimuth = {system.street_azimuth!r}; "
            "expected a finite angle [deg]"
        )
    for name in ("lumens", "luminaire_lumens"):
        value = getattr(system, name)
        if value is not None and not (math.isfinite(value) and 0 < value <= MAX_LUMINAIRE_FLUX):
            raise LuminaireDatabaseError(
                f"{where}: system {system.id!r} {name} = {value!r}; expected a number in "
                f"(0, {MAX_LUMINAIRE_FLUX:g}] lm"
            )


def load_library(path: str | os.PathLike[str] | None = None) -> LuminaireDatabase:
    """Read a luminaire database.

    Parameters
    ----------
    path : str, os.PathLike or None
        A ``systems.toml`` file or the folder holding one; None for the bundled database.

    Returns
    -------
    LuminaireDatabase
        The light systems.

    Raises
    ------
    LuminaireDatabaseError
        Missing or malformed file, unknown fields, missing photometric files.
    """
    if path is None:
        toml_path = Path(__file__).with_name("systems.toml")
    else:
        toml_path = Path(path)
        if toml_path.is_dir():
            toml_path = toml_path / "systems.toml"
    try:
        with open(toml_path, "rb") as handle:
            document = tomllib.load(handle)
    except OSError as exc:
        raise LuminaireDatabaseError(f"{toml_path}: cannot read ({exc.strerror})") from exc
    except tomllib.TOMLDecodeError as exc:
        raise LuminaireDatabaseError(f"{toml_path}: not valid TOML ({exc})") from exc
    unknown = sorted(set(document) - {"systems"})
    if unknown:
        raise LuminaireDatabaseError(
            f"{toml_path}: unknown top-level key {unknown[0]!r}; expected only [systems.<id>] "
            "tables"
        )
    tables = document.get("systems")
    if not isinstance(tables, dict) or not tables:
        raise LuminaireDatabaseError(f"{toml_path}: expected [systems.<id>] tables")
    for key, value in tables.items():
        if not isinstance(value, dict):
            raise LuminaireDatabaseError(
                f"{toml_path}: systems.{key} = {value!r}; expected a [systems.{key}] table"
            )
    systems = {key: _system(key, value, toml_path) for key, value in tables.items()}
    root = toml_path.parent
    for system in systems.values():
        if not (root / system.photometry_file).is_file():
            raise LuminaireDatabaseError(
                f"{toml_path}: system {system.id!r} photometry_file "
                f"{system.photometry_file!r} not found in {root}"
            )
    return LuminaireDatabase(systems, root)


__all__ = ["REQUIRED_SYSTEMS", "LightSystem", "LuminaireDatabase", "load_library"]
