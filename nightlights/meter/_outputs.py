"""The validation's files: the stations layer and the calibrated emission."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import geopandas as gpd
import pandas as pd

from nightlights.io import Raster
from nightlights.meter.calibrate import Calibration

__all__ = ["write_calibrated", "write_stations"]


def write_stations(stations: gpd.GeoDataFrame, path: Path, layer: str) -> None:
    """The stations layer, styled by residual, times as ISO text."""
    from nightlights.io.styles import residual_style
    from nightlights.io.vector import write_gpkg

    frame = stations.copy()
    for column in frame.columns:
        if pd.api.types.is_datetime64_any_dtype(frame[column]):
            frame[column] = frame[column].dt.strftime("%Y-%m-%dT%H:%M:%SZ")
    schema: dict[str, Any] = {
        name: "float"
        for name in frame.columns
        if name != "geometry" and pd.api.types.is_float_dtype(frame[name])
    }
    write_gpkg(frame, path, layer=layer, schema=schema, style=residual_style())


def write_calibrated(
    emission: Raster, calibration: Calibration, path: Path, share: float | None = None
) -> None:
    """The emission times the calibrated scale (each band by its new share of the flux when the
    low-angle band's ``share`` was fitted, from the emission's own ``share``), the fit in its
    tags."""
    from nightlights.io.raster import RasterBand, write_cog

    scale = calibration.parameters["scale"]
    factors = [scale] * emission.count
    if share is not None and "share" in calibration.parameters:
        fitted = calibration.parameters["share"]
        factors = [scale * (1.0 - fitted) / (1.0 - share), scale * fitted / share]
    tags = dict(emission.tags)
    tags.update(
        {
            "calibration_scale": f"{scale:.6g}",
            "calibration_scale_error": f"{calibration.uncertainties['scale']:.3g}",
            "calibration_folds": calibration.folds,
            "calibration_held_out_rms": f"{calibration.held_out['rms']}",
        }
    )
    if "turbidity" in calibration.parameters:
        tags["calibration_turbidity"] = f"{calibration.parameters['turbidity']:.4g}"
    if "share" in calibration.parameters:
        tags["calibration_low_angle_share"] = f"{calibration.parameters['share']:.4g}"
    bands = [
        RasterBand(
            emission.data[i] * factors[i],
            emission.descriptions[i] if i < len(emission.descriptions) else f"band_{i + 1}",
            emission.units[i] if i < len(emission.units) else "lm m-2",
            dict(emission.band_tags[i]) if i < len(emission.band_tags) else {},
        )
        for i in range(emission.count)
    ]
    crs = emission.projected_crs(source="emission raster")
    write_cog(path, bands, transform=emission.transform, crs=crs, tags=tags)
