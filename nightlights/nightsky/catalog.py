"""The Yale Bright Star Catalogue as arrays: every star to V = 6.5 with a J2000 position.

The catalogue ships in the package as ``data/bsc5.npz`` (9,096 stars, 170 kB), converted once
from the CDS file by ``data/build_bsc5.py``; its provenance and credit are in ``data/README.md``.

References
----------
1. Hoffleit, D. & Warren Jr, W. H. 1991, "The Bright Star Catalogue, 5th Revised Ed."
   (preliminary version), NSSDC/ADC, CDS catalogue V/50.
2. IAU Working Group on Star Names 2016-2018, "IAU Catalog of Star Names".
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from importlib import resources

import numpy as np
from numpy.typing import NDArray

from nightlights.errors import InputError

__all__ = ["PROPER_NAMES", "StarCatalog", "load_catalog"]

#: The fields of :class:`StarCatalog`, in order.
FIELDS = ("hr", "name", "ra", "dec", "pm_ra", "pm_dec", "vmag", "bv", "designation")
#: The arrays stored in ``bsc5.npz`` (its ``name`` is the catalogue's designation).
STORED = ("hr", "name", "ra", "dec", "pm_ra", "pm_dec", "vmag", "bv")

#: Proper names of bright stars, by HR number, as approved by the IAU Working Group on Star
#: Names (IAU Catalog of Star Names, 2016-2018): 62 names, 44 of them for the 48 stars
#: brighter than V = 2 (alpha2 Cen, alpha2 Cru, gamma2 Vel and delta Vel have none here).
PROPER_NAMES: dict[int, str] = {
    15: "Alpheratz",
    168: "Schedar",
    188: "Diphda",
    424: "Polaris",
    472: "Achernar",
    617: "Hamal",
    936: "Algol",
    1017: "Mirfak",
    1457: "Aldebaran",
    1708: "Capella",
    1713: "Rigel",
    1790: "Bellatrix",
    1791: "Elnath",
    1903: "Alnilam",
    1948: "Alnitak",
    2061: "Betelgeuse",
    2088: "Menkalinan",
    2294: "Mirzam",
    2326: "Canopus",
    2421: "Alhena",
    2491: "Sirius",
    2618: "Adhara",
    2693: "Wezen",
    2891: "Castor",
    2943: "Procyon",
    2990: "Pollux",
    3165: "Naos",
    3307: "Avior",
    3634: "Suhail",
    3685: "Miaplacidus",
    3748: "Alphard",
    3982: "Regulus",
    4301: "Dubhe",
    4534: "Denebola",
    4730: "Acrux",
    4763: "Gacrux",
    4853: "Mimosa",
    4905: "Alioth",
    5056: "Spica",
    5191: "Alkaid",
    5267: "Hadar",
    5288: "Menkent",
    5340: "Arcturus",
    5459: "Rigil Kentaurus",
    5793: "Alphecca",
    5953: "Dschubba",
    6134: "Antares",
    6217: "Atria",
    6527: "Shaula",
    6553: "Sargas",
    6556: "Rasalhague",
    6879: "Kaus Australis",
    7001: "Vega",
    7121: "Nunki",
    7557: "Altair",
    7790: "Peacock",
    7924: "Deneb",
    8308: "Enif",
    8425: "Alnair",
    8728: "Fomalhaut",
    8775: "Scheat",
    8781: "Markab",
}


@dataclass(frozen=True)
class StarCatalog:
    """Stars as parallel arrays, positions for equinox J2000 and epoch 2000.0.

    Attributes
    ----------
    hr : ndarray of int, shape (n,)
        Harvard Revised (Bright Star) number.
    name : ndarray of str, shape (n,)
        The IAU proper name where :data:`PROPER_NAMES` has one (``"Sirius"``), else the
        catalogue's designation; ``""`` for stars with neither.
    ra, dec : ndarray of float, shape (n,)
        Right ascension and declination [deg], equinox J2000, epoch 2000.0.
    pm_ra : ndarray of float, shape (n,)
        Annual proper motion in right ascension on the sky, mu_alpha * cos(dec)
        [arcsec yr-1] (FK5 system); Polaris's 0.038 here is its 44 mas yr-1 of Hipparcos.
    pm_dec : ndarray of float, shape (n,)
        Annual proper motion in declination [arcsec yr-1].
    vmag : ndarray of float, shape (n,)
        Johnson V magnitude [mag].
    bv : ndarray of float, shape (n,)
        Johnson B-V colour index [mag]; NaN where the catalogue has none.
    designation : ndarray of str, shape (n,)
        Flamsteed number, Bayer letter and constellation as in the catalogue, e.g.
        ``"9 Alp CMa"`` for Sirius (HR 2491); ``""`` for stars without one.
    """

    hr: NDArray[np.int_]
    name: NDArray[np.str_]
    ra: NDArray[np.float64]
    dec: NDArray[np.float64]
    pm_ra: NDArray[np.float64]
    pm_dec: NDArray[np.float64]
    vmag: NDArray[np.float64]
    bv: NDArray[np.float64]
    designation: NDArray[np.str_]

    def __len__(self) -> int:
        return int(self.hr.size)

    def select(self, mask: NDArray[np.bool_] | NDArray[np.int_]) -> StarCatalog:
        """The stars picked by a boolean mask or an index array, as a new catalogue.

        Examples
        --------
        >>> stars = load_catalog()
        >>> bright = stars.select(stars.vmag < 1.0)
        >>> len(bright), str(bright.name[np.argmin(bright.vmag)])
        (15, 'Sirius')
        """
        return StarCatalog(*(getattr(self, field)[mask] for field in FIELDS))

    def find(self, star: int | np.integer | str) -> int:
        """Index of a star given by HR number, proper name or designation.

        Parameters
        ----------
        star : int or str
            HR number (``2491``), proper name (``"Sirius"``) or designation as
            :attr:`designation` writes it, with or without the Flamsteed number
            (``"9 Alp CMa"``, ``"Alp CMa"``); case-insensitive.

        Returns
        -------
        int
            Position of the star in the arrays.

        Raises
        ------
        InputError
            No star of the catalogue has that number or name.

        Examples
        --------
        >>> stars = load_catalog()
        >>> stars.find("sirius") == stars.find(2491) == stars.find("Alp CMa")
        True
        """
        if isinstance(star, int | np.integer):
            hits = np.flatnonzero(self.hr == int(star))
        else:
            wanted = " ".join(str(star).split()).casefold()
            bayer = np.array(
                [d.split(" ", 1)[-1] if d[:1].isdigit() else d for d in self.designation]
            )
            hits = np.flatnonzero(
                (np.char.lower(self.name) == wanted)
                | (np.char.lower(self.designation) == wanted)
                | (np.char.lower(bayer) == wanted)
            )
        if hits.size == 0:
            raise InputError(f"star={star!r} is not in the catalogue (HR, proper name or Bayer)")
        return int(hits[0])


@functools.cache
def load_catalog() -> StarCatalog:
    """The Bright Star Catalogue shipped with the package (read once, then cached).

    Returns
    -------
    StarCatalog
        9,096 stars (the records of the 5th revised edition with a J2000 position and a V
        magnitude), in HR order. The arrays are read-only.

    References
    ----------
    1. Hoffleit & Warren 1991, CDS catalogue V/50.

    Examples
    --------
    >>> stars = load_catalog()
    >>> len(stars), int(stars.hr[np.argmin(stars.vmag)])
    (9096, 2491)
    """
    source = resources.files("nightlights.nightsky").joinpath("data", "bsc5.npz")
    with source.open("rb") as handle, np.load(handle, allow_pickle=False) as stored:
        arrays = {field: np.array(stored[field]) for field in STORED}
    arrays["designation"] = arrays["name"]
    arrays["name"] = np.array(
        [
            PROPER_NAMES.get(int(hr), d)
            for hr, d in zip(arrays["hr"], arrays["designation"], strict=True)
        ],
        dtype="<U16",
    )
    arrays["hr"] = arrays["hr"].astype(np.int_)
    for field in ("ra", "dec"):
        arrays[field] = arrays[field].astype(np.float64)
    for field in ("pm_ra", "pm_dec", "vmag", "bv"):
        # stored as float32; the catalogue gives at most three decimals
        arrays[field] = np.round(arrays[field].astype(np.float64), 3)
    for array in arrays.values():
        array.flags.writeable = False
    return StarCatalog(**arrays)
