"""Two dimming policies for an observatory: dim every light alike, or dim the lights that matter.

On the bundled Helsinki scene, Suomenlinna (3 km south of the centre) stands in for an
observatory. Policy A dims every light by the same fraction (40 %). Policy B asks for the same
artificial zenith sky brightness at the observatory and removes the least flux that reaches it
(``nl.least_dimming``: skyglow is linear in the emission, each cell's part of the zenith is
``nl.inverse_q`` with ``metric="zenith"``, and the cheapest cells to dim are the ones with the
most zenith light per lumen). Prints the sky before and after and the flux each policy removes.
Writes nothing. Usage::

    python examples/compare_dimming_policies.py [--seed 2011] [--dimming 0.4]

Data: (c) OpenStreetMap contributors, ODbL 1.0.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import nightlights as nl
from nightlights.demo import example_path

#: The observatory (lon, lat) [deg]: Suomenlinna sea fortress.
OBSERVATORY = (24.9880, 60.1455)
#: Luminance of 0 mag arcsec-2 [cd m-2] (Cinzano 2005; the DESIGN's magnitude scale).
ZERO_POINT = 1.08e5


def magnitude(luminance: float) -> float:
    """Sky brightness [mag arcsec-2] of a luminance [cd m-2]."""
    return -2.5 * math.log10(luminance / ZERO_POINT)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=2011, help="sampling and placement seed")
    parser.add_argument("--dimming", type=float, default=0.4, help="policy A's dimming [0-1]")
    args = parser.parse_args()

    streets = nl.normalize(example_path(), mapping="osm").streets
    lit = nl.sample(streets, network="europe", seed=args.seed).streets
    lights = nl.place(lit, seed=args.seed).lights
    lux = nl.irradiance(lights, resolution=2.0, progress=False).raster
    upward = nl.emission(lux, lights=lights, resolution=50.0, albedo=0.15).raster
    lit_cells = int(np.sum(np.nansum(upward.data, axis=0) > 0))

    # each lit cell's part of the observatory's zenith luminance; the parts add up to it
    scene = nl.Scene(upward)
    observatory = nl.Observer.from_lonlat(*OBSERVATORY, name="observatory")
    parts = nl.inverse_q(scene, observatory, metric="zenith", progress=False).raster
    before = float(np.nansum(parts.data[0]))  # [cd m-2]

    # A: every light dimmed alike; the zenith falls in proportion (skyglow is linear)
    after_a = (1.0 - args.dimming) * before
    # B: the same zenith at the observatory, the least flux removed
    plan = nl.least_dimming(scene, [observatory], target_zenith=magnitude(after_a), progress=False)
    after_b = plan.summary["observers"][0]["zenith"]["after_mag_arcsec2"]
    removed_b = plan.summary["flux_removed_percent"]

    print(f"observatory zenith before: {magnitude(before):.2f} mag arcsec-2 (artificial)")
    print(f"{'policy':30s} {'zenith after':>13s} {'flux removed':>13s} {'cells dimmed':>13s}")
    print(
        f"{f'A: every light {100 * args.dimming:.0f} % dimmer':30s} "
        f"{magnitude(after_a):13.2f} {100 * args.dimming:12.1f}% {lit_cells:13d}"
    )
    print(
        f"{'B: least flux, same zenith':30s} {after_b:13.2f} {removed_b:12.1f}% "
        f"{int(np.sum(plan.dimming.data[0] > 0)):13d}"
    )
    print(
        f"policy B keeps {100 * args.dimming - removed_b:.1f} percentage points more of the upward "
        "flux for the same sky at the observatory"
    )


if __name__ == "__main__":
    main()
