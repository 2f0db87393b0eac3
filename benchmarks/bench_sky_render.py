"""Night-sky rendering: the whole picture, time against resolution, the star point-spread knob.

Part 0, the picture: a 2048 x 1024 equirectangular panorama with every catalogue star above
the horizon (no limiting magnitude), the natural background, the Moon (up) and a 64 x 256
artificial skyglow panorama, tone-mapped for the dark-adapted eye and written as a PNG with its
legend, as ``nightlights sky render`` does it (:func:`nightlights.nightsky.stage.sky_render`,
in this process: without the interpreter's start and imports). Against the reference path of
the same steps in the same run, calls alternating: the numpy render (full-size temporaries,
Moon and stars drawn on their own images and added), the numpy tone mapping to floats, and the
previous writer (a matplotlib figure, reproduced here). Target: 1 s. Time: wall time, best
of 5, and the CPU time of the process (all threads) of the best call; the load average of the
machine is recorded beside them.

Part 1, resolution: :func:`nightlights.nightsky.render.render_sky` of an equirectangular
panorama (azimuth 0-360 across, elevation 0-90 down) from 256 x 64 to 2048 x 1024 pixels, the
same scene; then the night-vision tone mapping of the same image to 8-bit sRGB (as the PNG
holds it). Also fisheye and perspective views of about 2 million pixels. Time: wall time, best
of 3, and the CPU time of one call (the process's own time, less disturbed than the wall time
by other jobs on the shared machine).

Part 2, the point-spread knob: ``sigma`` [pixel] of
:func:`~nightlights.nightsky.render.splat_points` for 960 stars at random sub-pixel positions
on a 2048 x 1024 panorama. Errors against the exact values: the flux error of each star (sum
of luminance x solid angle against its illuminance) with the weights renormalised (the
renderer) and without (the Gaussian truncated at 3 sigma and pixel-integrated), the centroid
error (flux-weighted mean pixel position against the true position, the sampling bias that
makes small stars jump between pixels as they move), and the spread of the largest share of a
star's flux in one pixel with its sub-pixel position (max / min - 1, the "twinkling" of an
undersampled star). Time: splatting all catalogue stars, best of 3.

Run: ``python benchmarks/bench_sky_render.py [--quick] [--out DIR]`` (``--quick``: fewer sizes
and sigmas). Writes ``sky_render.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import _harness as harness
import numpy as np
import xarray as xr

from nightlights.nightsky.astro import star_positions
from nightlights.nightsky.catalog import load_catalog
from nightlights.nightsky.moon import moon_state
from nightlights.nightsky.render import (
    PSF_SIGMA,
    SkyOptions,
    View,
    _render_sky,
    render_sky,
    splat_points,
    view_pixels,
)
from nightlights.nightsky.stage import legend_text, sky_render
from nightlights.nightsky.tonemap import _tone_map, tone_map
from nightlights.sky import Observer

#: Helsinki, a winter evening with the waxing gibbous Moon up.
TIME, LON, LAT = "2026-01-27T19:00:00Z", 24.95, 60.17
SIZES = ((256, 64), (512, 128), (1024, 256), (2048, 512), (2048, 1024))
OTHER_VIEWS = (
    View("fisheye", 1448, 1448),
    View("perspective", 2048, 1024, azimuth=180.0, elevation=30.0, field_of_view=100.0),
)
SIGMAS = (0.25, 0.35, 0.5, 0.6, 0.7, 0.85, 1.0, 1.5, 2.0)


def panorama() -> xr.Dataset:
    """A city glow: 64 x 256, brightest toward the south-west near the horizon."""
    elevation = 90.0 - (np.arange(64) + 0.5) * 90.0 / 64
    azimuth = (np.arange(256) + 0.5) * 360.0 / 256
    el, az = np.meshgrid(elevation, azimuth, indexing="ij")
    glow = 2e-4 + 3e-3 * np.exp(-el / 15.0) * (1.0 + np.cos(np.radians(az - 225.0))) / 2.0
    return xr.Dataset(
        {"luminance": (("elevation", "azimuth"), glow)},
        coords={"elevation": elevation, "azimuth": azimuth},
    )


PICTURE = View("equirectangular", 2048, 1024)
#: Calls of each path in the picture comparison.
PICTURE_REPEATS = 5


def figure_png(rgb: np.ndarray, path: Path, legend: str) -> None:
    """The previous PNG writer: a matplotlib figure pixel for pixel, the legend strip below."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, cols = rgb.shape[:2]
    dpi, strip = 100, 40
    fig = plt.figure(figsize=(cols / dpi, (rows + strip) / dpi), dpi=dpi, facecolor="black")
    fig.figimage(np.clip(rgb, 0.0, 1.0), xo=0, yo=strip, origin="upper")
    fig.text(
        0.005,
        (strip / 2) / (rows + strip),
        legend,
        color="white",
        fontsize=8,
        va="center",
        family="monospace",
    )
    fig.savefig(path, dpi=dpi, format="png", facecolor="black")
    plt.close(fig)


def reference_picture(pano: xr.Dataset, path: Path) -> dict:
    """The picture by the reference path, step by step [s]."""
    options = SkyOptions(limiting_magnitude=False)
    steps = {}
    start = time.perf_counter()
    image = _render_sky(TIME, LON, LAT, PICTURE, pano, options, None, compiled=False)
    steps["render"] = time.perf_counter() - start
    rgb = _tone_map(image.xyz, None, image.pixels.pixel_size, compiled=False)
    steps["tone_map"] = time.perf_counter() - start - steps["render"]
    figure_png(rgb, path, legend_text(TIME, (LON, LAT), image.summary))
    steps["png"] = time.perf_counter() - start - steps["render"] - steps["tone_map"]
    return steps


def compiled_picture(pano: xr.Dataset, path: Path) -> dict:
    """The picture by the stage [s]."""
    start = time.perf_counter()
    sky_render(
        Observer.from_lonlat(LON, LAT),
        path,
        time=TIME,
        panorama=pano,
        width=PICTURE.width,
        height=PICTURE.height,
        limiting_magnitude=False,
    )
    return {"stage": time.perf_counter() - start}


def cold_cli(pano: xr.Dataset, folder: Path) -> dict:
    """One ``nightlights sky render`` of the picture in a new process: the start, the imports
    (colour-science, numba's cached machine code) and the picture [s]."""
    import resource
    import subprocess

    pano.to_netcdf(folder / "panorama.nc", engine="h5netcdf")
    command = [
        "nightlights", "sky", "render", str(folder / "cli.png"), "--time", TIME,
        "--lonlat", f"{LON},{LAT}", "--panorama", str(folder / "panorama.nc"),
        "--width", str(PICTURE.width), "--height", str(PICTURE.height), "--all-stars",
    ]  # fmt: skip
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    seconds = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"seconds": seconds, "cpu_seconds": cpu}


def picture_rows(pano: xr.Dataset) -> dict:
    folder = Path(tempfile.mkdtemp())
    runs: dict[str, list] = {"compiled": [], "reference": []}
    for _ in range(PICTURE_REPEATS):  # alternate, so that both see the same load
        for name, draw in (("compiled", compiled_picture), ("reference", reference_picture)):
            cpu = time.process_time()
            start = time.perf_counter()
            steps = draw(pano, folder / f"{name}.png")
            wall = time.perf_counter() - start
            runs[name].append(
                {"seconds": wall, "cpu_seconds": time.process_time() - cpu, "steps": steps}
            )
    # the stage's steps, timed alone: render, 8-bit tone map, PNG with the legend
    from nightlights.nightsky.stage import write_png

    options = SkyOptions(limiting_magnitude=False)
    render = harness.repeat(
        lambda: render_sky(TIME, LON, LAT, view=PICTURE, panorama=pano, options=options),
        PICTURE_REPEATS,
    )
    image = render.value
    tone = harness.repeat(
        lambda: tone_map(image.xyz, pixel_size=image.pixels.pixel_size, dtype=np.uint8),
        PICTURE_REPEATS,
    )
    text = legend_text(TIME, (LON, LAT), image.summary)
    png = harness.repeat(
        lambda: write_png(tone.value, folder / "steps.png", text, "equirectangular"),
        PICTURE_REPEATS,
    )
    cli = cold_cli(pano, folder)
    best = {name: min(rows, key=lambda row: row["seconds"]) for name, rows in runs.items()}
    result = {
        "width": PICTURE.width,
        "height": PICTURE.height,
        "seconds": best["compiled"]["seconds"],
        "cpu_seconds": best["compiled"]["cpu_seconds"],
        "reference_seconds": best["reference"]["seconds"],
        "reference_cpu_seconds": best["reference"]["cpu_seconds"],
        "reference_steps_seconds": best["reference"]["steps"],
        "speedup": best["reference"]["seconds"] / best["compiled"]["seconds"],
        "steps_seconds": {"render": render.best, "tone_map_8bit": tone.best, "png": png.best},
        "png_bytes": (folder / "compiled.png").stat().st_size,
        "reference_png_bytes": (folder / "reference.png").stat().st_size,
        "all_seconds": {name: [row["seconds"] for row in rows] for name, rows in runs.items()},
        "cli_cold_seconds": cli["seconds"],
        "cli_cold_cpu_seconds": cli["cpu_seconds"],
        "load_average_1min": os.getloadavg()[0],
    }
    print(result, flush=True)
    return result


def resolution_rows(sizes: tuple, pano: xr.Dataset) -> list[dict]:
    options = SkyOptions(limiting_magnitude=False)
    views = [View("equirectangular", w, h) for w, h in sizes] + list(OTHER_VIEWS)
    rows = []
    for view in views:
        timing = harness.repeat(
            lambda view=view: render_sky(TIME, LON, LAT, view=view, panorama=pano, options=options),
            3,
        )
        image = timing.value
        cpu_start = time.process_time()
        render_sky(TIME, LON, LAT, view=view, panorama=pano, options=options)
        cpu = time.process_time() - cpu_start
        tone = harness.repeat(
            lambda image=image: tone_map(
                image.xyz, pixel_size=image.pixels.pixel_size, dtype=np.uint8
            ),
            3,
        )
        rows.append(
            {
                "projection": view.projection,
                "width": view.shape[1],
                "height": view.shape[0],
                "pixels": view.shape[0] * view.shape[1],
                "render_seconds": timing.best,
                "render_cpu_seconds": cpu,
                "tone_map_seconds": tone.best,
                "stars_drawn": image.summary["stars_drawn"],
            }
        )
        print(rows[-1], flush=True)
    return rows


def psf_rows(sigmas: tuple) -> list[dict]:
    view = View("equirectangular", 2048, 1024)
    pixels = view_pixels(view)
    rng = np.random.default_rng(3)
    # one star per cell of 3 deg (elevation 10-58) x 6 deg (azimuth), 1 deg or more from the
    # cell's edges: a splat of 3 sigma <= 6 pixels (0.53 deg x 1.05 deg) stays in its cell
    cell_el, cell_az = np.meshgrid(np.arange(16), np.arange(60), indexing="ij")
    elevation = 10.0 + 3.0 * cell_el.ravel() + 1.5 + rng.uniform(-0.5, 0.5, cell_el.size)
    azimuth = 6.0 * cell_az.ravel() + 3.0 + rng.uniform(-0.5, 0.5, cell_az.size)
    rows_true, cols_true, _ = pixels.locate(elevation, azimuth)
    flux = np.ones(elevation.size)
    inside = (pixels.elevation >= 10.0) & (pixels.elevation < 58.0)
    owners = ((pixels.elevation[inside] - 10.0) // 3.0).astype(int) * 60 + (
        pixels.azimuth[inside] // 6.0
    ).astype(int)
    index_r, index_c = (i[inside] for i in np.indices(view.shape))
    catalog = load_catalog()
    star_az, star_el = star_positions(catalog, TIME, LON, LAT)
    up = star_el >= 0
    rows = []
    for sigma in sigmas:
        totals = {}
        for normalise in (True, False):
            image = splat_points(pixels, elevation, azimuth, flux, sigma=sigma, normalise=normalise)
            weight = (image[..., 0] * pixels.solid_angle)[inside]
            totals[normalise] = np.bincount(owners, weight, minlength=elevation.size)
        # the renormalised image is the last one made with normalise=True: redo it for moments
        image = splat_points(pixels, elevation, azimuth, flux, sigma=sigma)
        weight = (image[..., 0] * pixels.solid_angle)[inside]
        total = totals[True]
        centre_r = np.bincount(owners, weight * index_r, minlength=elevation.size) / total
        centre_c = np.bincount(owners, weight * index_c, minlength=elevation.size) / total
        centroid = np.hypot(centre_r - rows_true, centre_c - cols_true)
        share = np.zeros(elevation.size)  # the largest share of a star's flux in one pixel
        np.maximum.at(share, owners, weight)
        timing = harness.repeat(
            lambda sigma=sigma: splat_points(
                pixels, star_el[up], star_az[up], np.ones((int(up.sum()), 3)), sigma=sigma
            ),
            3,
        )
        rows.append(
            {
                "sigma_pixels": sigma,
                "max_flux_error_normalised": float(np.max(np.abs(total - 1.0))),
                "mean_flux_error_truncated": float(np.mean(np.abs(totals[False] - 1.0))),
                "mean_centroid_error_pixels": float(np.mean(centroid)),
                "max_centroid_error_pixels": float(np.max(centroid)),
                "peak_share_spread": float(share.max() / share.min() - 1.0),
                "splat_seconds_all_stars": timing.best,
                "stars_splatted": int(up.sum()),
            }
        )
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="3 sizes, 4 sigmas")
    args = harness.parse_args(parser)
    sizes = SIZES[::2] if args.quick else SIZES
    sigmas = SIGMAS[::2] if args.quick else SIGMAS
    moon = moon_state(TIME, LON, LAT)
    result = {
        "scene": (
            f"{TIME}, {LON} E {LAT} N: Moon at {moon.elevation:.1f} deg, "
            f"{100 * moon.illuminated_fraction:.0f} % lit; 64 x 256 artificial panorama; every "
            "catalogue star above the horizon"
        ),
        "target_seconds_2048x1024": 1.0,
        "default_sigma_pixels": PSF_SIGMA,
        "load_average_1min_start": os.getloadavg()[0],
        "picture": picture_rows(panorama()),
        "resolution": resolution_rows(sizes, panorama()),
        "psf": psf_rows(sigmas),
        "note": (
            "Timings from a 2-core machine shared with other jobs (load average recorded), "
            "noisy; best of 3 (picture: best of 5, paths alternating)."
        ),
    }
    harness.write_results(args.out, "sky_render", result, quick=args.quick, plot=plot, dpi=110)


def plot(result: dict):
    plt = harness.pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    equi = [r for r in result["resolution"] if r["projection"] == "equirectangular"]
    other = [r for r in result["resolution"] if r["projection"] != "equirectangular"]
    px = [r["pixels"] for r in equi]
    ax1.loglog(px, [r["render_seconds"] for r in equi], "o-", label="render (linear XYZ)")
    ax1.loglog(px, [r["render_cpu_seconds"] for r in equi], "o:", label="render, CPU time")
    ax1.loglog(px, [r["tone_map_seconds"] for r in equi], "s--", label="tone map (eye, 8-bit)")
    pic = result["picture"]
    pixels = pic["width"] * pic["height"]
    ax1.loglog(pixels, pic["seconds"], "*", ms=12, label="picture: render + tone map + PNG")
    ax1.loglog(pixels, pic["reference_seconds"], "X", ms=9, label="picture, reference path")
    for r in other:
        ax1.loglog(r["pixels"], r["render_seconds"], "^", label=f"render, {r['projection']}")
    for r in equi:
        ax1.annotate(f"{r['width']}x{r['height']}", (r["pixels"], r["render_seconds"]), fontsize=7)
    ax1.axhline(result["target_seconds_2048x1024"], color="grey", lw=0.8, ls=":")
    ax1.set_xlabel("pixels")
    ax1.set_ylabel("time [s], best of 3")
    ax1.set_title(
        f"render time, all catalogue stars (load average {pic['load_average_1min']:.0f})",
        fontsize=10,
    )
    ax1.legend(fontsize=7)
    psf = result["psf"]
    sigma = [r["sigma_pixels"] for r in psf]
    ax2.semilogy(sigma, [r["mean_centroid_error_pixels"] for r in psf], "o-", label="centroid [px]")
    ax2.semilogy(sigma, [r["peak_share_spread"] for r in psf], "s-", label="peak spread [1]")
    ax2.semilogy(
        sigma,
        [max(r["mean_flux_error_truncated"], 1e-17) for r in psf],
        "^--",
        label="flux error, truncated, not renormalised",
    )
    ax2.semilogy(
        sigma,
        [max(r["max_flux_error_normalised"], 1e-17) for r in psf],
        "v:",
        label="flux error, renormalised (renderer)",
    )
    ax2.axvline(result["default_sigma_pixels"], color="grey", lw=0.8, ls=":")
    ax2.set_xlabel("point-spread sigma [pixel]")
    ax2.set_ylabel("error")
    ax2.set_title("star point-spread knob, 2048 x 1024", fontsize=10)
    ax2.legend(fontsize=7)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
