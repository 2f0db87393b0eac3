"""Benchmark: the default pipeline against published zenith sky brightness at real sites.

The validation set of real skies (:func:`nightlights.meter.real_skies.read_real_skies`:
published clear, moonless zenith readings with their citations) is held against what a new
user gets from a real satellite mosaic at default options:

1. the mosaic: the VIIRS annual 2025 radiance at 15 arcsec (EPSG:4326, 73-135 E, 18-54 N)
   that the MIT-licensed package ``stargazing-place-finder`` 0.9.1 ships as
   ``light_pollution/resources/viirs_china_2025.tif`` (Earth Observation Group VIIRS data), is
   fetched at benchmark time with the package installer (``pip download --no-deps``) into a
   cache folder and read from the wheel (a zip): never at run time, never in the tests;
2. for each site: the mosaic cropped to +-:data:`CROP_RADIUS` around it (in degrees of
   latitude and longitude, geographic as the mosaic), then the two commands a user runs,
   as library calls: :func:`nightlights.emission_from_viirs` (``nightlights emission viirs``)
   and :func:`nightlights.darkness` on it (``nightlights darkness``), each at its defaults; the
   zenith luminance of the map's cell that holds the site;
3. plus a natural zenith of :data:`NATURAL_SKY` mag arcsec-2 (V), added as luminance:
   :math:`m = -2.5 \\log_{10}((L_{art} + L_{nat}) / 1.08\\times10^5)`.

Reported: bias (model - measured), RMS and median absolute residual [mag arcsec-2] overall and
per class (city centre, suburb, rural, observatory); a predicted-against-measured chart (1:1
line, classes coloured) and a residual-against-brightness chart; the time per site (crop,
emission, darkness) and the darkness map's own time on one crop (the reference for a speed
budget of later defaults). Rows whose band is not V or an SQM (e.g. SDSS g) are listed but left
out of the figures.

There is nothing fitted yet; :func:`held_out` nevertheless gives k-fold (by site) held-out
figures for any model choice (a function from the training rows to a predictor of the test
rows), so that later model choices are judged by held-out, never in-sample, figures. The
default pipeline has no free parameter: its held-out figures equal its in-sample ones.

Run: ``python benchmarks/bench_real_skies.py [--quick] [--out DIR] [--cache DIR]
[--wheel PATH]`` (``--quick``: four sites, one of each class; ``--cache``: where the wheel, the
extracted mosaic and the per-site model values are kept, default
``~/.cache/nightlights-bench/real_skies``; ``--wheel``: an already downloaded wheel). Writes
``real_skies.json`` and ``.png``.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import _harness as harness
import numpy as np

#: The package that ships the mosaic, its version and the mosaic's path in the wheel.
PACKAGE, VERSION = "stargazing-place-finder", "0.9.1"
MOSAIC_MEMBER = "light_pollution/resources/viirs_china_2025.tif"
#: Radius of the crop around a site [m]: the default kernel's 300 km and a margin.
CROP_RADIUS = 330_000.0
#: Natural zenith sky brightness added to the model's artificial sky [mag arcsec-2] (V).
NATURAL_SKY = 21.7
#: Luminance of 0 mag arcsec-2 [cd m-2] (the project's convention).
ZERO_POINT = 1.08e5
#: Bands the figures use (V-band photometry and Sky Quality Meters).
BANDS = ("V", "SQM")
#: Folds of the held-out figures [1].
FOLDS = 5
#: Default cache folder.
CACHE = Path.home() / ".cache" / "nightlights-bench" / "real_skies"

Predictor = Callable[[list[dict[str, Any]]], np.ndarray]
Model = Callable[[list[dict[str, Any]]], Predictor]


# --------------------------------------------------------------------------------------------
# The mosaic


def fetch_mosaic(cache: Path, wheel: Path | None = None) -> Path:
    """The mosaic GeoTIFF, extracted into ``cache`` from the wheel (downloaded if needed)."""
    cache.mkdir(parents=True, exist_ok=True)
    tif = cache / Path(MOSAIC_MEMBER).name
    if tif.is_file():
        return tif
    if wheel is None:
        found = sorted(cache.glob("stargazing_place_finder-*.whl"))
        if not found:
            subprocess.run(
                [sys.executable, "-m", "pip", "download", "--no-deps", "--dest", str(cache),
                 f"{PACKAGE}=={VERSION}"],
                check=True,
            )  # fmt: skip
            found = sorted(cache.glob("stargazing_place_finder-*.whl"))
        wheel = found[-1]
    with zipfile.ZipFile(wheel) as archive:
        partial = tif.with_suffix(".part")
        with archive.open(MOSAIC_MEMBER) as src, partial.open("wb") as dst:
            while chunk := src.read(1 << 22):
                dst.write(chunk)
        partial.rename(tif)
    return tif


def crop(mosaic: Path, lon: float, lat: float, out: Path) -> Path:
    """The mosaic within +-CROP_RADIUS of (lon, lat), on the mosaic's own grid."""
    import rasterio
    from rasterio.windows import Window, from_bounds

    half_lat = math.degrees(CROP_RADIUS / 6_371_008.8)
    half_lon = half_lat / math.cos(math.radians(lat))
    with rasterio.open(mosaic) as src:
        window = (
            from_bounds(
                lon - half_lon, lat - half_lat, lon + half_lon, lat + half_lat, src.transform
            )
            .round_offsets()
            .round_lengths()
        )
        window = window.intersection(Window(0, 0, src.width, src.height))
        data = src.read(1, window=window)
        profile = src.profile | {
            "height": data.shape[0],
            "width": data.shape[1],
            "transform": src.window_transform(window),
            "tiled": False,
            "compress": "deflate",
        }
        profile.pop("blockxsize", None)
        profile.pop("blockysize", None)
    with rasterio.open(out, "w", **profile) as dst:
        dst.write(data, 1)
    return out


# --------------------------------------------------------------------------------------------
# The model at a site


def model_site(mosaic: Path, site: dict[str, Any], folder: Path) -> dict[str, Any]:
    """Artificial zenith luminance at the site from the default pipeline, and its times."""
    import geopandas as gpd

    import nightlights as nl
    from nightlights.io.terrain import sample_raster

    folder.mkdir(parents=True, exist_ok=True)
    lon, lat = site["longitude"], site["latitude"]
    start = time.perf_counter()
    viirs = crop(mosaic, lon, lat, folder / "viirs.tif")
    cropped = time.perf_counter()
    emission = nl.emission_from_viirs(viirs, folder / "emission.tif", progress=False)
    emitted = time.perf_counter()
    result = nl.darkness(nl.Scene(folder / "emission.tif"), progress=False)
    done = time.perf_counter()
    point = gpd.GeoSeries.from_xy([lon], [lat], crs="EPSG:4326")
    zenith = float(sample_raster(result.raster, point, band=0, name="darkness")[0])
    raster = result.raster
    return {
        "artificial_cd_m2": zenith,
        "cells": int(raster.data.shape[-1] * raster.data.shape[-2]),
        "crs": str(raster.crs),
        "flux_lm": float(sum(emission.total_flux.values())),
        "seconds": {
            "crop": cropped - start,
            "emission": emitted - cropped,
            "darkness": done - emitted,
            "darkness_map": float(result.seconds),
        },
    }


def magnitude(luminance: np.ndarray | float) -> np.ndarray:
    """Sky brightness [mag arcsec-2] of a luminance [cd m-2]."""
    return -2.5 * np.log10(np.asarray(luminance, dtype=float) / ZERO_POINT)


def natural_luminance(mag: float = NATURAL_SKY) -> float:
    """Luminance [cd m-2] of a sky brightness [mag arcsec-2]."""
    return ZERO_POINT * 10 ** (-0.4 * mag)


# --------------------------------------------------------------------------------------------
# Figures and held-out figures


def figures(residual: np.ndarray) -> dict[str, float | int]:
    """Bias, RMS and median absolute residual [mag arcsec-2] and the count."""
    r = np.asarray(residual, dtype=float)
    if r.size == 0:
        return {"n": 0, "bias": math.nan, "rms": math.nan, "median_abs": math.nan}
    return {
        "n": int(r.size),
        "bias": float(r.mean()),
        "rms": float(np.sqrt(np.mean(r**2))),
        "median_abs": float(np.median(np.abs(r))),
    }


def by_class(rows: Sequence[dict[str, Any]], residual: np.ndarray) -> dict[str, Any]:
    """:func:`figures` overall and per site class."""
    from nightlights.meter.real_skies import SITE_CLASSES

    classes = np.array([r["site_class"] for r in rows])
    out: dict[str, Any] = {"all": figures(residual)}
    for name in SITE_CLASSES:
        out[name] = figures(residual[classes == name])
    return out


def default_model(train: list[dict[str, Any]]) -> Predictor:
    """The default pipeline plus the fixed natural sky: nothing is fitted to ``train``."""
    del train
    nat = natural_luminance()

    def predict(rows: list[dict[str, Any]]) -> np.ndarray:
        return magnitude(np.array([r["artificial_cd_m2"] for r in rows]) + nat)

    return predict


def held_out(
    rows: Sequence[dict[str, Any]], model: Model, folds: int = FOLDS, seed: int = 0
) -> tuple[np.ndarray, dict[str, Any]]:
    """k-fold (by site) held-out predictions of ``model`` and their figures per class.

    ``model(train_rows)`` returns a predictor of magnitudes [mag arcsec-2] for other rows;
    each site is predicted once, by the model trained on the folds that do not hold it.
    """
    rows = list(rows)
    order = np.random.default_rng(seed).permutation(len(rows))
    fold_of = np.empty(len(rows), dtype=int)
    fold_of[order] = np.arange(len(rows)) % max(1, min(folds, len(rows)))
    predicted = np.full(len(rows), np.nan)
    for k in np.unique(fold_of):
        test = np.flatnonzero(fold_of == k)
        train = [rows[i] for i in np.flatnonzero(fold_of != k)]
        predicted[test] = model(train)([rows[i] for i in test])
    measured = np.array([r["value"] for r in rows])
    return predicted, by_class(rows, predicted - measured)


# --------------------------------------------------------------------------------------------
# Chart


COLOURS = {
    "city centre": "tab:red",
    "suburb": "tab:orange",
    "rural": "tab:green",
    "observatory": "tab:blue",
}


def plot(payload: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 5.2))
    sites = [s for s in payload["sites"] if s["in_figures"]]
    for name, colour in COLOURS.items():
        chosen = [s for s in sites if s["site_class"] == name]
        if not chosen:
            continue
        m = [s["measured"] for s in chosen]
        p = [s["predicted"] for s in chosen]
        stats = payload["figures"][name]
        label = f"{name} (n={stats['n']}, bias {stats['bias']:+.2f}, RMS {stats['rms']:.2f})"
        left.scatter(m, p, color=colour, label=label, s=30, zorder=3)
        right.scatter(m, np.subtract(p, m), color=colour, s=30, zorder=3)
    lo, hi = 13.5, 22.5
    left.plot([lo, hi], [lo, hi], color="k", lw=0.8, label="1:1")
    left.axhline(NATURAL_SKY, color="grey", ls=":", lw=0.8)
    left.set_xlim(lo, hi)
    left.set_ylim(lo, hi)
    left.invert_xaxis()
    left.invert_yaxis()
    left.set_xlabel("measured zenith [mag arcsec$^{-2}$]")
    left.set_ylabel("model zenith (default pipeline + 21.7 natural) [mag arcsec$^{-2}$]")
    overall = payload["figures"]["all"]
    left.set_title(
        f"{overall['n']} published skies: bias {overall['bias']:+.2f}, "
        f"RMS {overall['rms']:.2f}, median |r| {overall['median_abs']:.2f}"
    )
    left.legend(fontsize=8, loc="upper left")
    right.axhline(0, color="k", lw=0.8)
    right.set_xlim(lo, hi)
    right.invert_xaxis()
    right.set_xlabel("measured zenith [mag arcsec$^{-2}$] (brighter to the right)")
    right.set_ylabel("model - measured [mag arcsec$^{-2}$] (> 0: model too dark)")
    right.set_title("Residual against brightness")
    for s in sites:
        right.annotate(
            s["name"].split("(")[0].strip()[:26],
            (s["measured"], s["predicted"] - s["measured"]),
            fontsize=6,
            xytext=(3, 2),
            textcoords="offset points",
        )
    fig.tight_layout()
    return fig


# --------------------------------------------------------------------------------------------


def main() -> None:
    from pyproj import CRS

    from nightlights.meter.real_skies import read_real_skies

    parser = harness.argument_parser(__doc__, quick="four sites, one of each class")
    parser.add_argument("--cache", type=Path, default=CACHE, help="cache folder")
    parser.add_argument("--wheel", type=Path, default=None, help="an already downloaded wheel")
    args = harness.parse_args(parser)
    table = read_real_skies()
    if args.quick:
        table = table.groupby("site_class", sort=False).head(1)
    mosaic = fetch_mosaic(args.cache, args.wheel)
    store = args.cache / "sites.json"
    cached = json.loads(store.read_text()) if store.is_file() else {}
    rows: list[dict[str, Any]] = []
    for record in table.to_dict("records"):
        key = f"{record['name']}|{record['latitude']:.5f}|{record['longitude']:.5f}"
        if key not in cached:
            slug = "".join(c if c.isalnum() else "_" for c in record["name"])[:60]
            cached[key] = model_site(mosaic, record, args.cache / "sites" / slug)
            store.write_text(json.dumps(cached, indent=1))
        rows.append(record | cached[key])
        print(
            f"{record['name'][:50]:50s} {magnitude(cached[key]['artificial_cd_m2']):6.2f} "
            f"{cached[key]['seconds']['darkness']:6.1f} s",
            flush=True,
        )
    in_figures = [r["band"] in BANDS for r in rows]
    used = [r for r, keep in zip(rows, in_figures, strict=True) if keep]
    predicted_all = default_model(used)(rows)
    measured = np.array([r["value"] for r in used])
    predicted = default_model(used)(used)
    in_sample = by_class(used, predicted - measured)
    _, held = held_out(used, default_model)
    times = np.array([[r["seconds"][k] for k in ("crop", "emission", "darkness")] for r in rows])
    largest = max(rows, key=lambda r: r["cells"])
    payload = {
        "mosaic": {
            "package": f"{PACKAGE}=={VERSION}",
            "member": MOSAIC_MEMBER,
            "licence": "MIT (package metadata)",
            "data": "Earth Observation Group (EOG) VIIRS DNB annual composite 2025",
        },
        "crop_radius_m": CROP_RADIUS,
        "natural_sky": NATURAL_SKY,
        "figures": in_sample,
        "classes": [{"site_class": k, **v} for k, v in in_sample.items()],
        "held_out": {
            "folds": FOLDS,
            "model": "default (nothing fitted)",
            "figures": held,
            "classes": [{"site_class": k, **v} for k, v in held.items()],
        },
        "seconds_per_site": {
            "crop": float(np.median(times[:, 0])),
            "emission": float(np.median(times[:, 1])),
            "darkness": float(np.median(times[:, 2])),
            "total": float(np.median(times.sum(axis=1))),
        },
        "darkness_timing": {
            "site": largest["name"],
            "cells": largest["cells"],
            "crs": CRS.from_user_input(largest["crs"]).to_string(),
            "darkness_s": largest["seconds"]["darkness"],
            "darkness_map_s": largest["seconds"]["darkness_map"],
        },
        "sites": [
            {
                "name": r["name"],
                "site_class": r["site_class"],
                "band": r["band"],
                "statistic": r["statistic"],
                "instrument": r["instrument"],
                "citation": r["citation"],
                "verified": r["verified"],
                "lon": r["longitude"],
                "lat": r["latitude"],
                "measured": r["value"],
                "artificial": float(magnitude(r["artificial_cd_m2"])),
                "predicted": float(p),
                "residual": float(p - r["value"]),
                "in_figures": keep,
                "seconds": r["seconds"],
            }
            for r, p, keep in zip(rows, predicted_all, in_figures, strict=True)
        ],
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    harness.write_results(args.out, "real_skies", payload, quick=args.quick, plot=plot)


if __name__ == "__main__":
    main()
