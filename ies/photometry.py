"""The :class:`Photometry` object: an absolute candela table with lookups and flux integrals.

Readers (:mod:`ies.lm63`, :mod:`ies.eulumdat`) build it; everything downstream (irradiance,
emission, BUG ratings) only uses its methods. Angles follow the file's photometric type:

* type C (road and area luminaires, every EULUMDAT file): ``vertical`` is the polar angle
  from nadir (0 = straight down, 90 = horizontal, 180 = zenith), ``horizontal`` the C-plane
  azimuth, unfolded to cover 0..360 deg;
* type A and B (automotive, floodlights): ``vertical`` and ``horizontal`` are the file's own
  latitude/longitude-like angles in -90..90 deg; lookups happen in that frame (no conversion
  to type C). A table that starts at 0 deg is mirrored to negative angles (LM-63 symmetric
  A/B files list 0..90 only).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ies.bug import BUG_ZONES, BUGRating, bug_rating_from_zones
from ies.errors import PhotometryError
from ies.grid import CubicTable, Kernel, bilinear, node_weights, zone_nodes

logger = logging.getLogger(__name__)

PhotometricType = Literal["A", "B", "C"]
InterpolationMethod = Literal["bilinear", "cubic"]

#: Relative difference between declared and integrated flux above which readers warn.
FLUX_MISMATCH_TOLERANCE = 0.05


def _frozen_array(values: ArrayLike) -> NDArray[np.float64]:
    array = np.array(values, dtype=float)
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class Photometry:
    """Absolute luminous intensity distribution of a luminaire, read from IES or EULUMDAT.

    Attributes
    ----------
    photometric_type : {"C", "B", "A"}
        LM-63 photometric type.
    vertical_angles : ndarray, shape (n_v,)
        Ascending vertical angles; type C: 0 = nadir, 180 = zenith [deg].
    horizontal_angles : ndarray, shape (n_h,)
        Ascending horizontal angles; type C: unfolded to 0..360 inclusive [deg].
    candela : ndarray, shape (n_h, n_v)
        Absolute intensity with candela multiplier, ballast factor and TILT factor applied [cd].
    declared_lumens : float or None
        Rated lamp flux, lumens per lamp x number of lamps; None for absolute photometry [lm].
    source : str
        File the table came from.
    format : str
        ``"IES LM-63-2002"``, ``"EULUMDAT"``, ....
    version : str
        Format version (``"1986"``, ``"1991"``, ``"1995"``, ``"2002"``, ``"2019"``, ``""``).
    keywords : Mapping[str, str]
        Header keywords (``[MANUFAC]`` -> ``"MANUFAC"``) or EULUMDAT header fields.
    symmetry : str
        Horizontal symmetry of the file (see :func:`ies.grid.unfold_type_c`).
    luminous_opening : tuple of float
        Width, length, height of the luminous opening; negative values code round shapes as
        in LM-63 [m].
    warnings : tuple of str
        Problems found while reading (each also issued as a :class:`PhotometryWarning`).
    ballast_factor : float
        Ballast factor (and, up to LM-63-1995, ballast-lamp photometric factor) applied [1].
    candela_multiplier : float
        File multiplier applied to the raw values [1].
    input_watts : float or None
        Luminaire input power [W].
    declared_light_output_ratio : float or None
        Light output ratio stated by the file (EULUMDAT LORL) [1].
    tilt_angles, tilt_factors : tuple of float
        LM-63 TILT=INCLUDE table: lamp tilt [deg] and lamp-output multiplier [1].
    """

    photometric_type: PhotometricType
    vertical_angles: NDArray[np.float64]
    horizontal_angles: NDArray[np.float64]
    candela: NDArray[np.float64]
    declared_lumens: float | None = None
    source: str = "<string>"
    format: str = ""
    version: str = ""
    keywords: Mapping[str, str] = field(default_factory=dict)
    symmetry: str = ""
    luminous_opening: tuple[float, float, float] = (0.0, 0.0, 0.0)
    warnings: tuple[str, ...] = ()
    ballast_factor: float = 1.0
    candela_multiplier: float = 1.0
    input_watts: float | None = None
    declared_light_output_ratio: float | None = None
    tilt_angles: tuple[float, ...] = ()
    tilt_factors: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "vertical_angles", _frozen_array(self.vertical_angles))
        object.__setattr__(self, "horizontal_angles", _frozen_array(self.horizontal_angles))
        object.__setattr__(self, "candela", _frozen_array(self.candela))
        where = self.source
        if self.photometric_type not in ("A", "B", "C"):
            raise PhotometryError(
                f"{where}: photometric type {self.photometric_type!r}, expected 'A', 'B' or 'C'"
            )
        v, h, cd = self.vertical_angles, self.horizontal_angles, self.candela
        if v.ndim != 1 or h.ndim != 1 or cd.shape != (h.size, v.size):
            raise PhotometryError(
                f"{where}: candela shape {cd.shape} does not match "
                f"(n_horizontal, n_vertical) = ({h.size}, {v.size})"
            )
        if v.size < 2:
            raise PhotometryError(
                f"{where}: degenerate grid with {v.size} vertical angle(s); at least 2 are "
                "needed to interpolate and integrate"
            )
        for name, angles in (("vertical", v), ("horizontal", h)):
            if not np.all(np.isfinite(angles)) or np.any(np.diff(angles) <= 0):
                raise PhotometryError(f"{where}: {name} angles must be finite and increasing")
        if not np.all(np.isfinite(cd)) or np.any(cd < 0):
            raise PhotometryError(f"{where}: candela values must be finite and >= 0")
        if self.photometric_type == "C":
            if v[0] < -1e-9 or v[-1] > 180.0 + 1e-9:
                raise PhotometryError(
                    f"{where}: type C vertical angles {v[0]:g}..{v[-1]:g} deg outside 0..180"
                )
            if abs(h[0]) > 1e-9 or abs(h[-1] - 360.0) > 1e-9:
                raise PhotometryError(
                    f"{where}: type C horizontal angles must be unfolded "
                    f"to 0..360 deg, got {h[0]:g}..{h[-1]:g}"
                )
        elif v[0] < -90 - 1e-9 or v[-1] > 90 + 1e-9 or h[0] < -90 - 1e-9 or h[-1] > 90 + 1e-9:
            raise PhotometryError(
                f"{where}: type {self.photometric_type} angles must lie in -90..90 deg"
            )

    # ------------------------------------------------------------------ lookups
    @property
    def is_absolute(self) -> bool:
        """True for absolute photometry (no declared lamp lumens)."""
        return self.declared_lumens is None

    @cached_property
    def _cubic(self) -> CubicTable:
        return CubicTable(
            self.vertical_angles,
            self.horizontal_angles,
            self.candela,
            periodic=self.photometric_type == "C",
        )

    def intensity(
        self,
        vertical: ArrayLike,
        horizontal: ArrayLike,
        *,
        method: InterpolationMethod = "bilinear",
    ) -> NDArray[np.float64]:
        """Luminous intensity towards any direction, vectorised.

        Parameters
        ----------
        vertical : array_like
            Vertical angle; type C: from nadir, 0..180 [deg].
        horizontal : array_like
            Horizontal angle, broadcast against ``vertical``; type C wraps modulo 360 [deg].
        method : {"bilinear", "cubic"}
            Bilinear interpolation of the unfolded grid (Chuang 2011, Eq. 4), or a bicubic
            interpolating spline clipped at 0 cd.

        Returns
        -------
        ndarray
            Intensity; 0 outside the measured vertical range (a 0-90 deg file has no
            upward light); NaN for NaN angles [cd].

        References
        ----------
        Chuang 2011, Sec. 4.2, Eq. 4.

        Examples
        --------
        >>> import numpy as np
        >>> p = Photometry("C", [0.0, 90.0, 180.0], [0.0, 360.0], np.full((2, 3), 100.0))
        >>> float(p.intensity(45.0, 123.0))
        100.0
        """
        if method == "bilinear":
            return bilinear(
                self.vertical_angles,
                self.horizontal_angles,
                self.candela,
                vertical,
                horizontal,
                periodic=self.photometric_type == "C",
            )
        if method == "cubic":
            return self._cubic(vertical, horizontal)
        raise PhotometryError(f"interpolation method {method!r}: expected 'bilinear' or 'cubic'")

    # ------------------------------------------------------------------ integrals
    def _kernels(self) -> tuple[Kernel, Kernel]:
        """Solid-angle weight along (vertical, horizontal) for this photometric type."""
        kernels: dict[str, tuple[Kernel, Kernel]] = {
            "C": ("sin", "one"),
            "A": ("cos", "one"),
            "B": ("one", "cos"),
        }
        return kernels[self.photometric_type]

    def zone_flux(
        self,
        vertical_range: tuple[float, float],
        horizontal_range: tuple[float, float] = (0.0, 360.0),
    ) -> float:
        """Flux inside a rectangle of angles, exact for the bilinear interpolant.

        Parameters
        ----------
        vertical_range : tuple of float
            (from, to) vertical angles [deg].
        horizontal_range : tuple of float
            (from, to) horizontal angles; type C ranges may wrap (e.g. (270, 450)) [deg].

        Returns
        -------
        float
            :math:`\\Phi = \\iint I(V, H)\\, d\\Omega` over the zone [lm].
        """
        v_low, v_high = vertical_range
        h_low, h_high = horizontal_range
        if h_high < h_low or v_high < v_low:
            raise PhotometryError(f"empty angle range {vertical_range}, {horizontal_range}")
        pieces: list[tuple[float, float]] = []
        if self.photometric_type == "C":
            if h_high - h_low >= 360.0:
                pieces = [(0.0, 360.0)]
            else:
                start = h_low % 360.0
                end = start + (h_high - h_low)
                pieces = [(start, min(end, 360.0))]
                if end > 360.0:
                    pieces.append((0.0, end - 360.0))
        else:
            pieces = [(h_low, h_high)]
        v_kernel, h_kernel = self._kernels()
        v_nodes = zone_nodes(self.vertical_angles, v_low, v_high)
        if v_nodes.size == 0:
            return 0.0
        v_weights = node_weights(v_nodes, v_kernel)
        total = 0.0
        for low, high in pieces:
            h_nodes = zone_nodes(self.horizontal_angles, low, high)
            if h_nodes.size == 0:
                continue
            h_weights = node_weights(h_nodes, h_kernel)
            values = self.intensity(v_nodes[None, :], h_nodes[:, None])
            total += float(h_weights @ values @ v_weights)
        return total

    @cached_property
    def _total_flux(self) -> float:
        return (
            self.zone_flux((-180.0, 180.0), (-180.0, 540.0))
            if self.photometric_type != "C"
            else self.zone_flux((0.0, 180.0), (0.0, 360.0))
        )

    def luminous_flux(self) -> float:
        """Total luminous flux by integrating the distribution over the sphere.

        The integral of the piecewise-bilinear interpolant is evaluated exactly: with
        :math:`d\\Omega = \\sin V\\, dV\\, dH` (type C), inside each grid cell the integrand
        is a product of a linear function of H and a linear function of V times sin V, whose
        integrals have closed forms (:func:`ies.grid.node_weights`). Types A and B use
        :math:`\\cos V\\, dV\\, dH` and :math:`\\cos H\\, dH\\, dV` over the measured angles.

        Returns
        -------
        float
            Luminous flux [lm].

        Examples
        --------
        >>> import numpy as np
        >>> p = Photometry("C", [0.0, 180.0], [0.0, 360.0], np.ones((2, 2)))
        >>> round(p.luminous_flux(), 9) == round(4 * np.pi, 9)
        True
        """
        return self._total_flux

    def downward_flux(self) -> float:
        """Flux below the horizontal plane (type C: V < 90; types A/B: V < 0) [lm]."""
        if self.photometric_type == "C":
            return self.zone_flux((0.0, 90.0))
        return self.zone_flux((-90.0, 0.0), (-90.0, 90.0))

    def upward_flux(self) -> float:
        """Flux above the horizontal plane (type C: V > 90; types A/B: V > 0) [lm]."""
        if self.photometric_type == "C":
            return self.zone_flux((90.0, 180.0))
        return self.zone_flux((0.0, 90.0), (-90.0, 90.0))

    @property
    def lamp_flux(self) -> float:
        """Reference flux for ratios: declared lumens x ballast factor, or for absolute
        photometry the integrated luminaire flux [lm]."""
        if self.declared_lumens is None:
            return self.luminous_flux()
        return self.declared_lumens * self.ballast_factor

    def light_output_ratio(self) -> float:
        """Integrated luminaire flux over lamp flux (1 for absolute photometry)."""
        lamp = self.lamp_flux
        return self.luminous_flux() / lamp if lamp > 0 else float("nan")

    def upward_light_output_ratio(self) -> float:
        """ULOR: upward flux over lamp flux.

        For absolute photometry (LM-63 lumens = -1) the lamp flux is unknown and the
        integrated luminaire flux is used instead, so the value is the upward fraction of
        the luminaire's own output (the "upward flux ratio").

        Returns
        -------
        float
            Upward light output ratio [1].
        """
        lamp = self.lamp_flux
        return self.upward_flux() / lamp if lamp > 0 else 0.0

    def expected_flux(self) -> float | None:
        """The luminaire flux the file declares, or None for absolute photometry.

        IES: lamp lumens x lamps x ballast factor (the candela already carry the multiplier).
        EULUMDAT: lamp flux x light output ratio (LORL).

        Returns
        -------
        float or None
            Declared luminaire flux [lm].
        """
        if self.declared_lumens is None:
            return None
        ratio = self.declared_light_output_ratio
        return self.declared_lumens * self.ballast_factor * (1.0 if ratio is None else ratio)

    def bug_rating(self, *, street_azimuth: float = 90.0) -> BUGRating:
        """BUG rating (IES TM-15-11) from exact zone lumens.

        Parameters
        ----------
        street_azimuth : float
            Horizontal angle that faces the street (front); the front half-space is
            ``street_azimuth +- 90``. LM-63 roadway files put the street side at 90 [deg].

        Returns
        -------
        BUGRating
            Ratings and zone lumens.

        References
        ----------
        IES TM-15-11, Addendum A.
        """
        if self.photometric_type != "C":
            raise PhotometryError(
                f"{self.source}: BUG ratings need type C photometry, got type "
                f"{self.photometric_type}"
            )
        front = (street_azimuth - 90.0, street_azimuth + 90.0)
        back = (street_azimuth + 90.0, street_azimuth + 270.0)
        halves = {"front": front, "back": back, "all": (0.0, 360.0)}
        zones = {
            name: self.zone_flux((v_from, v_to), halves[half])
            for name, (v_from, v_to, half) in BUG_ZONES.items()
        }
        return bug_rating_from_zones(zones)

    # ------------------------------------------------------------------ derived tables
    def scaled(self, factor: float) -> Photometry:
        """A copy with every intensity (and the declared lumens) multiplied by ``factor``.

        Parameters
        ----------
        factor : float
            Non-negative multiplier [1].

        Returns
        -------
        Photometry
            Scaled copy.
        """
        if not np.isfinite(factor) or factor < 0:
            raise PhotometryError(f"scale factor {factor!r}: expected a finite value >= 0")
        lumens = None if self.declared_lumens is None else self.declared_lumens * factor
        return replace(self, candela=self.candela * factor, declared_lumens=lumens)

    def tilt_factor(self, tilt: float) -> float:
        """Lamp-output multiplier of the TILT=INCLUDE table at a lamp tilt.

        Parameters
        ----------
        tilt : float
            Tilt of the lamp from its photometric position [deg].

        Returns
        -------
        float
            Multiplier, linearly interpolated; 1 without a table [1].
        """
        if not self.tilt_angles:
            return 1.0
        return float(np.interp(abs(tilt), self.tilt_angles, self.tilt_factors))

    def with_tilt(self, tilt: float) -> Photometry:
        """The distribution of the luminaire mounted at ``tilt``: candela scaled by the
        TILT=INCLUDE lamp-output multiplier relative to the untilted position.

        Parameters
        ----------
        tilt : float
            Mounting tilt [deg].

        Returns
        -------
        Photometry
            Copy with the lamp-output multiplier applied [1].
        """
        base = self.tilt_factor(0.0)
        factor = self.tilt_factor(tilt) / base if base > 0 else 1.0
        return replace(self, candela=self.candela * factor)

    def summary(self) -> dict[str, object]:
        """Plain-data summary (format, grid, fluxes, ULOR, BUG, warnings) for reports [1]."""
        rating = self.bug_rating() if self.photometric_type == "C" else None
        return {
            "source": self.source,
            "format": self.format,
            "version": self.version,
            "photometric_type": self.photometric_type,
            "symmetry": self.symmetry,
            "grid": {
                "n_vertical": int(self.vertical_angles.size),
                "n_horizontal": int(self.horizontal_angles.size),
                "vertical_range": [float(self.vertical_angles[0]), float(self.vertical_angles[-1])],
            },
            "declared_lumens": self.declared_lumens,
            "expected_flux": self.expected_flux(),
            "integrated_flux": self.luminous_flux(),
            "downward_flux": self.downward_flux(),
            "upward_flux": self.upward_flux(),
            "ulor": self.upward_light_output_ratio(),
            "bug_rating": None if rating is None else str(rating),
            "bug_zone_lumens": None if rating is None else dict(rating.zone_lumens),
            "max_candela": float(self.candela.max()),
            "warnings": list(self.warnings),
        }


def check_declared_flux(photometry: Photometry, *, found: list[str]) -> Photometry:
    """Warn when declared and integrated flux differ by more than 5 %, and attach warnings.

    Parameters
    ----------
    photometry : Photometry
        A freshly read table.
    found : list of str
        Warnings already collected by the reader; issued here and stored on the result.

    Returns
    -------
    Photometry
        ``photometry`` with ``warnings`` filled in.
    """
    import warnings as _warnings

    from ies.errors import FluxMismatchWarning, PhotometryWarning

    messages = list(found)
    for message in found:
        _warnings.warn(f"{photometry.source}: {message}", PhotometryWarning, stacklevel=3)
    expected = photometry.expected_flux()
    integrated = photometry.luminous_flux()
    if expected is not None and expected > 0:
        difference = integrated / expected - 1.0
        if abs(difference) > FLUX_MISMATCH_TOLERANCE:
            message = (
                f"integrated flux {integrated:.1f} lm differs from the declared "
                f"{expected:.1f} lm by {100 * difference:+.1f} % (implied light output ratio "
                f"{integrated / expected:.3f}; relative photometry of a luminaire that absorbs "
                "light, or an inconsistent file)"
            )
            messages.append(message)
            _warnings.warn(f"{photometry.source}: {message}", FluxMismatchWarning, stacklevel=3)
    return replace(photometry, warnings=tuple(messages))


def forward_azimuth(photometry: Photometry, *, step: float = 1.0) -> float:
    """Horizontal direction of the downward light's mean direction (type C).

    The horizontal components of :math:`\\int I(V, H)\\, \\hat{u}\\, d\\Omega` over the
    lower hemisphere, with :math:`\\hat{u} = (\\sin V \\cos H, \\sin V \\sin H)`, give the
    C-plane angle towards which a road luminaire throws its light (its street side).

    Parameters
    ----------
    photometry : Photometry
        Type C table.
    step : float
        Midpoint-rule step of the evaluation grid [deg].

    Returns
    -------
    float
        Azimuth in [0, 360); NaN for a rotationally symmetric lobe [deg].
    """
    if photometry.photometric_type != "C":
        raise PhotometryError(f"{photometry.source}: forward azimuth needs type C photometry")
    v = np.arange(step / 2, 90.0, step)
    h = np.arange(step / 2, 360.0, step)
    intensity = photometry.intensity(v[None, :], h[:, None])
    vr, hr = np.radians(v), np.radians(h)
    weight = intensity * np.sin(vr)[None, :] ** 2  # sin V from d-omega, sin V from u
    x = float(np.sum(weight * np.cos(hr)[:, None]))
    y = float(np.sum(weight * np.sin(hr)[:, None]))
    total = float(np.sum(weight))
    if total <= 0 or np.hypot(x, y) < 1e-6 * total:
        return float("nan")
    return float(np.degrees(np.arctan2(y, x)) % 360.0)
