"""The Yale Bright Star Catalogue as arrays: every star to V = 6.5 with a J2000 position.

The catalogue ships in the package as ``data/bsc5.npz`` (9,096 stars, 170 kB), converted once
from the CDS file by ``data/build_bsc5.py``; its provenance and credit are in ``data/README.md``.

References
----------
1. Hoffleit, D. & Warren Jr, W. H. 1991, "The Bright Star Catalogue, 5th Revised Ed."
   (preliminary version), NSSDC/ADC, CDS catalogue V/50.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from importlib import resources

import numpy as np
from numpy.typing import NDArray

__all__ = ["StarCatalog", "load_catalog"]

#: The fields of :class:`StarCatalog`, in order, as stored in ``bsc5.npz``.
FIELDS = ("hr", "name", "ra", "dec", "pm_ra", "pm_dec", "vmag", "bv")


@dataclass(frozen=True)
class StarCatalog:
    """Stars as parallel arrays, positions for equinox J2000 and epoch 2000.0.

    Attributes
    ----------
    hr : ndarray of int, shape (n,)
        Harvard Revised (Bright Star) number.
    name : ndarray of str, shape (n,)
        Flamsteed number, Bayer letter and constellation as in the catalogue, e.g.
        ``"9 Alp CMa"`` for Sirius (HR 2491); ``""`` for stars without one.
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
    """

    hr: NDArray[np.int_]
    name: NDArray[np.str_]
    ra: NDArray[np.float64]
    dec: NDArray[np.float64]
    pm_ra: NDArray[np.float64]
    pm_dec: NDArray[np.float64]
    vmag: NDArray[np.float64]
    bv: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.hr.size)

    def select(self, mask: NDArray[np.bool_] | NDArray[np.int_]) -> StarCatalog:
        """The stars picked by a boolean mask or an index array, as a new catalogue.

        Examples
        --------
        >>> stars = load_catalog()
        >>> bright = stars.select(stars.vmag < 1.0)
        >>> len(bright), str(bright.name[np.argmin(bright.vmag)])
        (15, '9 Alp CMa')
        """
        return StarCatalog(*(getattr(self, field)[mask] for field in FIELDS))


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
        arrays = {field: np.array(stored[field]) for field in FIELDS}
    arrays["hr"] = arrays["hr"].astype(np.int_)
    for field in ("ra", "dec"):
        arrays[field] = arrays[field].astype(np.float64)
    for field in ("pm_ra", "pm_dec", "vmag", "bv"):
        # stored as float32; the catalogue gives at most three decimals
        arrays[field] = np.round(arrays[field].astype(np.float64), 3)
    for array in arrays.values():
        array.flags.writeable = False
    return StarCatalog(**arrays)
