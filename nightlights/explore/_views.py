"""What :class:`~nightlights.explore.ExploreSession` answers: panoramas, per-cell maps,
dimmings and the state of the edits, each a frozen record with a JSON-ready form."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nightlights._typing import FloatArray

__all__ = ["DimmingView", "EditView", "InfluenceView", "PanoramaView"]


def _json_float(value: float) -> float | None:
    return None if not math.isfinite(value) else float(value)


@dataclass(frozen=True)
class PanoramaView:
    """The sky an observer sees, as :class:`ExploreSession` computed it.

    Attributes
    ----------
    x, y
        Observer in the raster CRS [m].
    observer_altitude
        Eye altitude above sea level [m].
    elevation, azimuth
        Pixel centres [deg], azimuth clockwise from north.
    luminance
        Shape ``(n_el, n_az)``: artificial sky luminance [cd m-2], NaN below the terrain.
    zenith_luminance
        Mean of the top row [cd m-2].
    zenith_magnitude
        Zenith sky brightness [mag arcsec-2].
    bortle
        Bortle class of the zenith [1]; None for a sky whose luminance is not finite (never
        a made-up class), with the reason in ``bortle_reason``.
    seconds
        Time of the computation [s].
    source
        ``current``, ``original`` (before the edits) or ``dimmed``.
    dimming
        For ``dimmed``: the dimming fraction of each lit cell of the current emission [1].
    bortle_reason
        Why ``bortle`` is None (:data:`nightlights.brightness.NON_FINITE_SKY`), else None.
    """

    x: float
    y: float
    observer_altitude: float
    elevation: FloatArray
    azimuth: FloatArray
    luminance: FloatArray
    zenith_luminance: float
    zenith_magnitude: float
    bortle: int | None
    seconds: float
    source: str = "current"
    dimming: FloatArray | None = field(default=None, repr=False)
    bortle_reason: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (NaN as None) of the figures and the luminance grid."""
        shown = self.luminance.astype(object)
        shown[~np.isfinite(self.luminance)] = None
        luminance = shown.tolist()
        return {
            "x": self.x,
            "y": self.y,
            "observer_altitude": self.observer_altitude,
            "azimuth": self.azimuth.tolist(),
            "elevation": self.elevation.tolist(),
            "luminance": luminance,
            "zenith_luminance": _json_float(self.zenith_luminance),
            "zenith_magnitude": _json_float(self.zenith_magnitude),
            "bortle": self.bortle,
            "bortle_reason": self.bortle_reason,
            "seconds": self.seconds,
            "source": self.source,
        }


@dataclass(frozen=True)
class InfluenceView:
    """Each lit cell's part of the sky for one observer (Dobashi et al. 2023, Eqs. 10-14).

    Attributes
    ----------
    kind
        ``q`` (the whole sky or the zenith) or ``s`` (a region of the sky).
    metric
        ``pca-norm``, ``zenith``, ``hemisphere`` (Q) or ``region`` (S).
    grid
        Shape ``(rows, cols)``: the value of every lit cell, NaN where unlit [cd m-2].
    values
        Shape ``(n_lit,)``: the same for the lit cells of the current emission [cd m-2].
    total
        Sum of the values [cd m-2].
    panorama_value
        What the values add up to in the forward panorama (NaN for ``pca-norm``) [cd m-2].
    seconds
        Time of the computation [s].
    """

    kind: str
    metric: str
    grid: FloatArray
    values: FloatArray
    total: float
    panorama_value: float
    seconds: float
    unit: str = "cd m-2"


@dataclass(frozen=True)
class DimmingView:
    """A dimming of the current emission and the sky it leaves.

    Attributes
    ----------
    cells
        Shape ``(n_lit,)``: fraction of each lit cell's flux removed [1].
    rows, cols
        Raster row and column of each lit cell.
    shape
        (rows, cols) of the raster.
    panorama
        The sky after dimming.
    before
        The sky before.
    flux_removed
        Flux removed [lm].
    flux_removed_percent
        The same as a share of the emission's flux [%].
    method
        ``eq12`` (Dobashi Eq. 12 on Q or S), ``greedy`` or ``lp`` (least-flux dimming).
    seconds
        Time of the computation [s].
    params
        What made it (JSON-ready).
    """

    cells: FloatArray
    rows: NDArray[np.int64]
    cols: NDArray[np.int64]
    shape: tuple[int, int]
    panorama: PanoramaView
    before: PanoramaView
    flux_removed: float
    flux_removed_percent: float
    method: str
    seconds: float
    params: dict[str, Any]

    @cached_property
    def fraction(self) -> FloatArray:
        """Shape ``(rows, cols)``: the fraction removed, NaN where unlit [1] (made on first
        use: a slider move does not need the grid)."""
        grid = np.full(self.shape, np.nan)
        grid[self.rows, self.cols] = self.cells
        return grid


@dataclass(frozen=True)
class EditView:
    """The state of the emission after an edit, undo or redo.

    Attributes
    ----------
    edit_version
        Bumped by every change [1].
    changed_cells
        Cells the step changed [1].
    n_lit
        Lit cells now [1].
    total_flux
        Upward flux now [lm].
    can_undo, can_redo
        Whether a step can be undone or redone.
    """

    edit_version: int
    changed_cells: int
    n_lit: int
    total_flux: float
    can_undo: bool
    can_redo: bool

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return dict(self.__dict__)
