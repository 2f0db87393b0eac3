"""Calibration against readings: the few parameters a user can defend, fitted in magnitudes.

The model's reading at station i is the instrument's magnitude of the artificial sky, scaled,
plus the natural sky:

.. math::

    \\hat m_i(s, \\tau) = -2.5 \\log_{10}\\frac{s\\, A_i(\\tau) + N_i}{L_0},
    \\qquad L_0 = 1.08\\times10^5\\ \\mathrm{cd\\,m^{-2}},

with ``A_i(tau)`` the artificial sky the instrument reads at turbidity ``tau`` (one darkness map
per turbidity of a grid, interpolated linearly in ``ln A`` between them), ``N_i`` the natural
sky it reads and ``s`` a flux scale of the emission (Cinzano 2005 for ``L_0``). With the
share ``f`` of an emission's low-angle band (the direct uplight, which leaves near the horizontal
and lights the sky far away) fitted too, ``A = A_o (1 - f) / (1 - f_0) + A_l f / f_0``: the two
bands' parts of the reading (``A_o``, ``A_l``) rescaled from the emission's own share ``f_0``,
the flux held. The parameters ``p = (ln s, tau, f)`` (``tau`` and ``f`` only when asked)
minimise the robust sum

.. math:: \\sum_i \\rho\\big((m_i - \\hat m_i(p)) / f\\big)

with ``rho`` the soft-L1 loss ``2(\\sqrt{1 + z^2} - 1)`` and ``f`` = :data:`ROBUST_SCALE`
(residuals well beyond ``f`` count about linearly, so a station with a wrong position or a
bad night does not drag the fit; Triggs et al. 2000 on robust costs in least squares, as
``scipy.optimize.least_squares`` implements them). The parameters' standard errors are the
Gauss-Newton ones at the solution, ``sqrt(diag((J^T J)^-1) * RSS / (n - k))``.

The calibrated model is judged on stations it did not see: k-fold cross-validation, or
leave-one-station-out (each station predicted by a fit to all the others), whose bias and RMS
are reported beside the in-sample ones (Hastie, Tibshirani & Friedman 2009, Sec. 7.10).

References
----------
1. Cinzano, P. 2005, "Night sky photometry with Sky Quality Meter", ISTIL Internal Report 9.
2. Triggs, B., McLauchlan, P., Hartley, R. & Fitzgibbon, A. 2000, "Bundle adjustment - a
   modern synthesis", Vision Algorithms: Theory and Practice, LNCS 1883, Sec. 3.3 (robust
   cost functions).
3. Hastie, T., Tibshirani, R. & Friedman, J. 2009, "The Elements of Statistical Learning",
   2nd ed., Springer, Sec. 7.10 (cross-validation).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.brightness import ZERO_POINT_LUMINANCE
from nightlights.errors import DataQualityWarning, InputError

__all__ = [
    "PARAMETERS",
    "ROBUST_SCALE",
    "Calibration",
    "Model",
    "check_station_count",
    "fit",
    "residual_statistics",
]

#: The parameters a calibration may fit: the emission's flux scale, the turbidity, and the
#: share of the emission's low-angle (direct uplight) band in its flux.
PARAMETERS = ("scale", "turbidity", "share")
#: A fitted share stays this far inside (0, 1) [1].
SHARE_MARGIN = 1e-3
#: Residual [mag] beyond which the soft-L1 loss counts about linearly: about twice the scatter
#: of repeated clear-night readings of one SQM (0.05-0.1 mag, den Outer et al. 2011 found
#: 0.5 % to 9 % between intercalibrated meters), so ordinary noise is fitted as least squares
#: and only stations several times off are down-weighted.
ROBUST_SCALE = 0.2
#: Below this span of measured brightness [mag] a fit of more than the scale is poorly
#: constrained: the turbidity trades against the scale along the whole range of distances,
#: which a set of stations of one brightness does not sample (warned).
MIN_BRIGHTNESS_SPAN = 1.0
#: A station whose artificial sky is below this share of its natural sky hardly moves with the
#: scale (at 10 %, doubling the emission brightens it by 0.1 mag); when every station is
#: below it the scale is poorly constrained (warned).
MIN_ARTIFICIAL_SHARE = 0.1
#: A parameter whose standard error exceeds this share of its value is warned about [1].
MAX_RELATIVE_ERROR = 0.5
#: The default cross-validation: each station predicted from all the others.
LEAVE_ONE_OUT = "station"


@dataclass(frozen=True)
class Model:
    """What the fit needs of the stations: the readings and the model's two parts.

    Attributes
    ----------
    measured
        The station values [mag arcsec-2], ``(n,)``.
    artificial
        The artificial sky each instrument reads [cd m-2, V-equivalent], ``(n,)`` at the
        scene's turbidity, or ``(t, n)`` at each of ``turbidities``.
    natural
        The natural sky each instrument reads [cd m-2, V-equivalent], ``(n,)``.
    turbidities
        The turbidity grid of a 2-D ``artificial`` (ascending) [1]; None for one turbidity.
    turbidity
        The scene's turbidity, the starting point of a fit [1].
    low_angle
        The part of ``artificial`` from the emission's low-angle band, same shape; None when
        the share is not fitted.
    share
        The low-angle band's share of the emission's flux [1], with ``low_angle``.
    """

    measured: FloatArray
    artificial: FloatArray
    natural: FloatArray
    turbidities: FloatArray | None = None
    turbidity: float = math.nan
    low_angle: FloatArray | None = None
    share: float = math.nan

    def __post_init__(self) -> None:
        measured = np.asarray(self.measured, dtype=float)
        natural = np.asarray(self.natural, dtype=float)
        artificial = np.asarray(self.artificial, dtype=float)
        object.__setattr__(self, "measured", measured)
        object.__setattr__(self, "natural", natural)
        object.__setattr__(self, "artificial", artificial)
        if self.turbidities is not None:
            grid = np.asarray(self.turbidities, dtype=float)
            object.__setattr__(self, "turbidities", grid)
            if artificial.shape != (grid.size, measured.size) or np.any(np.diff(grid) <= 0):
                raise InputError(
                    f"artificial of shape {artificial.shape} for {grid.size} turbidities and "
                    f"{measured.size} stations; expected ascending turbidities and one row each"
                )
        elif artificial.shape != measured.shape:
            raise InputError(
                f"artificial of shape {artificial.shape}; expected one value per station "
                f"({measured.size})"
            )
        if natural.shape != measured.shape:
            raise InputError(f"natural of shape {natural.shape}; expected ({measured.size},)")
        if self.low_angle is not None:
            low = np.asarray(self.low_angle, dtype=float)
            object.__setattr__(self, "low_angle", low)
            if low.shape != artificial.shape or not 0.0 < self.share < 1.0:
                raise InputError(
                    f"low_angle of shape {low.shape} with share {self.share}; expected the "
                    f"shape of artificial {artificial.shape} and a share in (0, 1)"
                )

    def __len__(self) -> int:
        return int(self.measured.size)

    def subset(self, index: ArrayLike) -> Model:
        """The same model on some stations."""
        index = np.asarray(index)
        return Model(
            self.measured[index],
            self.artificial[..., index],
            self.natural[index],
            self.turbidities,
            self.turbidity,
            None if self.low_angle is None else self.low_angle[..., index],
            self.share,
        )

    def _at(self, table: FloatArray, turbidity: float | None) -> FloatArray:
        """A table of readings at a turbidity, linear in ``ln A`` between grid nodes."""
        if self.turbidities is None or turbidity is None:
            return np.asarray(table if table.ndim == 1 else table[0])
        grid = self.turbidities
        t = float(np.clip(turbidity, grid[0], grid[-1]))
        k = int(np.clip(np.searchsorted(grid, t, side="right") - 1, 0, grid.size - 2))
        w = (t - grid[k]) / (grid[k + 1] - grid[k])
        low, high = table[k], table[k + 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            logs = (1.0 - w) * np.log(low) + w * np.log(high)
        out = np.exp(logs)
        # a station no light reaches at one node: interpolate linearly instead
        plain = ~np.isfinite(logs)
        out[plain] = (1.0 - w) * low[plain] + w * high[plain]
        return np.asarray(out)

    def artificial_at(self, turbidity: float | None, share: float | None = None) -> FloatArray:
        """The artificial readings at a turbidity (and a low-angle share of the flux)."""
        total = self._at(self.artificial, turbidity)
        if share is None or self.low_angle is None:
            return total
        low = self._at(self.low_angle, turbidity)
        f0 = self.share
        return np.asarray((total - low) * (1.0 - share) / (1.0 - f0) + low * share / f0)

    def predict(
        self, scale: float = 1.0, turbidity: float | None = None, share: float | None = None
    ) -> FloatArray:
        """The model's readings [mag arcsec-2] at a flux scale, turbidity and share."""
        total = scale * self.artificial_at(turbidity, share) + self.natural
        with np.errstate(divide="ignore"):
            return np.asarray(-2.5 * np.log10(total / ZERO_POINT_LUMINANCE))


@dataclass(frozen=True)
class Calibration:
    """What :func:`fit` found.

    Attributes
    ----------
    parameters
        The fitted values by name (``scale`` [1], ``turbidity`` [1], ``share`` [1]).
    uncertainties
        Their standard errors, same names.
    in_sample
        Residual statistics of the calibrated model on the stations it was fitted to
        (:func:`residual_statistics`) [mag arcsec-2].
    held_out
        The same on stations held out of the fit (cross-validation) [mag arcsec-2].
    folds
        The cross-validation: ``"station"`` (leave one station out) or ``"k-fold:<k>"``.
    predicted
        The calibrated model's reading of every station [mag arcsec-2].
    held_out_predicted
        Every station predicted by the fit that did not see it [mag arcsec-2].
    fold_parameters
        The parameters of each fold's fit, by name (their spread shows how stable they are).
    """

    parameters: dict[str, float]
    uncertainties: dict[str, float]
    in_sample: dict[str, float]
    held_out: dict[str, float]
    folds: str
    predicted: FloatArray = field(repr=False)
    held_out_predicted: FloatArray = field(repr=False)
    fold_parameters: dict[str, list[float]] = field(default_factory=dict, repr=False)

    def as_dict(self) -> dict[str, Any]:
        """The figures a summary file reports."""
        return {
            "parameters": dict(self.parameters),
            "uncertainties": dict(self.uncertainties),
            "in_sample": dict(self.in_sample),
            "held_out": dict(self.held_out),
            "folds": self.folds,
        }


def residual_statistics(residual: ArrayLike) -> dict[str, float]:
    """Count, bias, RMS and median absolute deviation of residuals (measured - predicted).

    Parameters
    ----------
    residual
        Measured minus predicted [mag arcsec-2]; positive: the sky is darker than predicted.

    Returns
    -------
    dict
        ``n`` [1], ``bias`` (mean), ``rms`` (root mean square) and ``mad`` (median of the
        absolute deviations from the median) [mag arcsec-2]; NaN for no residuals.

    Examples
    --------
    >>> residual_statistics([0.1, -0.1, 0.3])
    {'n': 3, 'bias': 0.1, 'rms': 0.19149, 'mad': 0.2}
    """
    r = np.asarray(residual, dtype=float)
    r = r[np.isfinite(r)]
    if r.size == 0:
        return {"n": 0, "bias": math.nan, "rms": math.nan, "mad": math.nan}
    return {
        "n": int(r.size),
        "bias": round(float(r.mean()), 5),
        "rms": round(float(np.sqrt(np.mean(r**2))), 5),
        "mad": round(float(np.median(np.abs(r - np.median(r)))), 5),
    }


def _check_parameters(parameters: Sequence[str], model: Model) -> tuple[str, ...]:
    names = tuple(dict.fromkeys(parameters))
    unknown = [name for name in names if name not in PARAMETERS]
    if unknown or "scale" not in names:
        raise InputError(
            f"calibrate={list(parameters)!r}; expected 'scale', optionally with "
            f"{', '.join(repr(p) for p in PARAMETERS[1:])}"
        )
    if "turbidity" in names and (model.turbidities is None or model.turbidities.size < 2):
        raise InputError(
            "calibrate='turbidity' needs the artificial sky at two turbidities or more"
        )
    if "share" in names and model.low_angle is None:
        raise InputError(
            "calibrate='share' needs the low-angle band's part of the artificial sky (an "
            "emission of two bands)"
        )
    return names


def check_station_count(n: int, parameters: Sequence[str]) -> None:
    """Refuse fewer stations than parameters + 1 (a fit and a held-out check need one more).

    Raises
    ------
    InputError
        ``n`` below ``len(parameters) + 1``.
    """
    names = tuple(dict.fromkeys(parameters))
    k = len(names)
    if n < k + 1:
        raise InputError(
            f"{n} station{'s' if n != 1 else ''} for {k} parameter{'s' if k > 1 else ''} "
            f"({', '.join(names)}); a calibration needs at least {k + 1} (one more for the "
            "held-out check)"
        )


def _solve(model: Model, names: tuple[str, ...]) -> tuple[FloatArray, FloatArray]:
    """The robust least-squares parameters (ln s[, tau][, f]) and their standard errors."""
    from scipy.optimize import least_squares

    grid = model.turbidities
    fitted = [name for name in PARAMETERS if name in names]

    def unpack(p: FloatArray) -> dict[str, float]:
        return dict(zip(fitted, (float(v) for v in p), strict=True))

    def residual(p: FloatArray) -> FloatArray:
        v = unpack(p)
        prediction = model.predict(math.exp(v["scale"]), v.get("turbidity"), v.get("share"))
        return np.asarray(model.measured - prediction)

    # start: the scale that matches the median artificial excess at the scene's turbidity
    start_t = model.turbidity if np.isfinite(model.turbidity) else None
    if "turbidity" in fitted and grid is not None:
        start_t = float(np.clip(start_t if start_t is not None else grid.mean(), grid[0], grid[-1]))
    excess = 10.0 ** (-0.4 * model.measured) * ZERO_POINT_LUMINANCE - model.natural
    artificial = model.artificial_at(start_t)
    ratio = excess[artificial > 0] / artificial[artificial > 0]
    ratio = ratio[ratio > 0]
    start = [math.log(float(np.median(ratio))) if ratio.size else 0.0]
    lower, upper = [-np.inf], [np.inf]
    if "turbidity" in fitted and grid is not None:
        # strictly inside the bounds
        first = start_t if start_t is not None else float(grid.mean())
        start.append(float(np.clip(first, grid[0] + 1e-9, grid[-1] - 1e-9)))
        lower.append(float(grid[0]))
        upper.append(float(grid[-1]))
    if "share" in fitted:
        start.append(float(np.clip(model.share, 2 * SHARE_MARGIN, 1 - 2 * SHARE_MARGIN)))
        lower.append(SHARE_MARGIN)
        upper.append(1.0 - SHARE_MARGIN)
    solution = least_squares(
        residual,
        np.array(start),
        bounds=(np.array(lower), np.array(upper)),
        loss="soft_l1",
        f_scale=ROBUST_SCALE,
        x_scale=np.ones(len(start)),
        diff_step=1e-4,
    )
    n, k = len(model), len(start)
    rss = float(np.sum(solution.fun**2))
    jtj = solution.jac.T @ solution.jac
    try:
        cov = np.linalg.inv(jtj) * (rss / (n - k) if n > k else math.nan)
        errors = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        errors = np.full(k, math.inf)
    return np.asarray(solution.x), np.asarray(errors)


def _named(
    x: FloatArray, errors: FloatArray, names: tuple[str, ...]
) -> tuple[dict[str, float], dict[str, float]]:
    fitted = [name for name in PARAMETERS if name in names]
    values = {name: float(v) for name, v in zip(fitted, x, strict=True)}
    uncertainty = {name: float(e) for name, e in zip(fitted, errors, strict=True)}
    values["scale"] = math.exp(values["scale"])
    uncertainty["scale"] = values["scale"] * uncertainty["scale"]  # d s = s d(ln s)
    return values, uncertainty


def _folds(n: int, folds: str | int, seed: int) -> tuple[str, list[FloatArray]]:
    if folds == LEAVE_ONE_OUT:
        return LEAVE_ONE_OUT, [np.array([i]) for i in range(n)]
    if isinstance(folds, bool) or not isinstance(folds, int | np.integer) or not 2 <= folds <= n:
        raise InputError(
            f"folds={folds!r}; expected 'station' (leave one station out) or an integer "
            f"2 to {n} (k-fold)"
        )
    order = np.random.default_rng(seed).permutation(n)
    return f"k-fold:{int(folds)}", [np.sort(part) for part in np.array_split(order, int(folds))]


def fit(
    model: Model,
    parameters: Sequence[str] = ("scale",),
    *,
    folds: str | int = LEAVE_ONE_OUT,
    seed: int = 0,
) -> Calibration:
    """Fit the scale (and the turbidity) to the readings and check it on held-out stations.

    Parameters
    ----------
    model
        The stations' readings and the model's artificial and natural parts (:class:`Model`).
    parameters
        ``("scale",)``, with ``"turbidity"`` and/or ``"share"``.
    folds
        ``"station"``: leave one station out; an integer k: k-fold cross-validation.
    seed
        Seed of the k-fold split.

    Returns
    -------
    Calibration
        The parameters with standard errors, the in-sample and held-out residual statistics.

    Raises
    ------
    InputError
        Unknown parameters; fewer stations than parameters + 1 (a fit and a held-out check need
        one more); a folds value that is neither ``"station"`` nor 2..n.

    Warns
    -----
    DataQualityWarning
        The stations span less than :data:`MIN_BRIGHTNESS_SPAN` with more than the scale to
        fit; every station's artificial sky is under :data:`MIN_ARTIFICIAL_SHARE` of its
        natural sky; a parameter's standard error exceeds :data:`MAX_RELATIVE_ERROR` of it.

    Examples
    --------
    >>> natural = np.full(6, 1.7e-4)
    >>> artificial = np.array([1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2])
    >>> truth = Model(np.zeros(6), artificial, natural).predict(scale=2.0)
    >>> calibration = fit(Model(truth, artificial, natural))
    >>> round(calibration.parameters["scale"], 6), calibration.held_out["rms"] < 1e-6
    (2.0, True)
    """
    names = _check_parameters(parameters, model)
    n, k = len(model), len(names)
    check_station_count(n, names)
    label, parts = _folds(n, folds, seed)
    finite = np.isfinite(model.measured)
    if not finite.all():
        raise InputError(f"{int((~finite).sum())} stations without a finite measured value")
    span = float(np.ptp(model.measured))
    if k > 1 and span < MIN_BRIGHTNESS_SPAN:
        warnings.warn(
            f"the stations span {span:.2f} mag arcsec-2 (< {MIN_BRIGHTNESS_SPAN}); "
            f"{', '.join(names[1:])} is poorly constrained beside the scale",
            DataQualityWarning,
            stacklevel=2,
        )
    reading = model.artificial_at(model.turbidity if model.turbidities is not None else None)
    if np.all(reading < MIN_ARTIFICIAL_SHARE * model.natural):
        warnings.warn(
            f"every station's artificial sky is under {MIN_ARTIFICIAL_SHARE:.0%} of its natural "
            "sky; the scale is poorly constrained (add stations nearer the lights)",
            DataQualityWarning,
            stacklevel=2,
        )
    x, errors = _solve(model, names)
    values, uncertainty = _named(x, errors, names)
    for name, value in values.items():
        if not uncertainty[name] <= MAX_RELATIVE_ERROR * abs(value):
            warnings.warn(
                f"{name} = {value:.4g} +- {uncertainty[name]:.2g}: poorly constrained by "
                f"these {n} stations",
                DataQualityWarning,
                stacklevel=2,
            )
    predicted = model.predict(values["scale"], values.get("turbidity"), values.get("share"))
    held = np.full(n, math.nan)
    per_fold: dict[str, list[float]] = {name: [] for name in names}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        for test in parts:
            train = np.setdiff1d(np.arange(n), test)
            if train.size < k:
                continue
            xf, _ = _solve(model.subset(train), names)
            fold_values, _ = _named(xf, np.zeros_like(xf), names)
            for name in names:
                per_fold[name].append(fold_values[name])
            held[test] = model.subset(test).predict(
                fold_values["scale"], fold_values.get("turbidity"), fold_values.get("share")
            )
    return Calibration(
        parameters=values,
        uncertainties=uncertainty,
        in_sample=residual_statistics(model.measured - predicted),
        held_out=residual_statistics(model.measured - held),
        folds=label,
        predicted=predicted,
        held_out_predicted=held,
        fold_parameters=per_fold,
    )
