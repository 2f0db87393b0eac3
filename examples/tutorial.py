"""Tutorial: the whole pipeline on the bundled Helsinki extract, in memory.

Streets -> predicted streetlights -> light on the ground -> upward emission -> skyglow kernel
-> the artificial night sky over Esplanadi park. Every stage takes and returns in-memory
objects (GeoDataFrames, rasters, xarray datasets); nothing is written except the two pictures
named below, in the current folder. Runs in about a minute (the first run also compiles the
skyglow integrator, about 10 s). Usage::

    python examples/tutorial.py

Data: (c) OpenStreetMap contributors, ODbL 1.0.
"""

# --8<-- [start:imports]
import numpy as np

import nightlights as nl
from nightlights.demo import example_path
from nightlights.maps import plot_raster_map

# --8<-- [end:imports]

SEED = 2011  # one seed for sampling and placement: the same seed gives the same city


def main() -> None:
    # --8<-- [start:normalize]
    # The bundled extract: about 1 x 1.7 km of central Helsinki from OpenStreetMap.
    normalized = nl.normalize(example_path(), mapping="osm")
    streets = normalized.streets  # GeoDataFrame in the local UTM zone (metres)
    print(f"{len(streets)} street segments in {streets.crs.name}")
    # --8<-- [end:normalize]

    # --8<-- [start:sample]
    # Fill the missing street fields and add the lighting fields (arrangement, mounting
    # height, spacing, luminaire type) from the `europe` Bayesian network.
    sampled = nl.sample(streets, network="europe", seed=SEED)
    lit = sampled.streets
    print(lit[["street_class", "arrangement", "mounting_height", "system_id"]].head())
    # --8<-- [end:sample]

    # --8<-- [start:place]
    # Poles along every lit street, in the sampled arrangement and spacing.
    lights = nl.place(lit, seed=SEED).lights
    print(f"{len(lights)} luminaires on {lights['pole_id'].nunique()} poles")
    # --8<-- [end:place]

    # --8<-- [start:irradiance]
    # Ground illuminance [lx] at 1 m from each luminaire's photometry.
    ground = nl.irradiance(lights, resolution=1.0, sensors=("photopic",), progress=False)
    lux = ground.raster
    print(f"illuminance {lux.shape} at {lux.resolution} m, peak {np.nanmax(lux.data):.1f} lx")
    plot_raster_map(
        lux,
        "irradiance.png",
        points=lights.drop_duplicates("pole_id"),
        title="Helsinki: predicted poles and ground illuminance",
        credit="(c) OpenStreetMap contributors, ODbL",
    )
    # --8<-- [end:irradiance]

    # --8<-- [start:emission]
    # Upward flux density [lm m-2] on 50 m cells: reflected (albedo x illuminance) and
    # the luminaires' direct uplight, one band each.
    upward = nl.emission(lux, lights=lights, resolution=50.0, albedo=0.15).raster
    print(f"emission bands {upward.descriptions}, units {upward.units}")
    # --8<-- [end:emission]

    # --8<-- [start:kernel]
    # A small skyglow kernel: 48 distance bins from 10 m to 10 km, a 32 x 128 panorama,
    # an observer's eye 1.7 m above the ground, Lambertian and uplight tables.
    spec = nl.KernelSpec(
        r_min=10.0,
        r_max=10_000.0,
        n_distance=48,
        n_elevation=32,
        n_azimuth=128,
        uplight=True,
        observer_altitudes=(1.7,),
    )
    kernel = nl.build_kernel(spec, progress=False)
    # --8<-- [end:kernel]

    # --8<-- [start:skyglow]
    # The artificial sky over Esplanadi park, as a fisheye picture.
    # The scene: the emission, its atmosphere and the kernel; the observer: where and how high.
    scene = nl.Scene(upward, kernel=kernel)
    esplanadi = nl.Observer.from_lonlat(24.9480, 60.1675, height=1.7, name="Esplanadi")
    sky = nl.skyglow(
        scene,
        esplanadi,
        png="skyglow.png",
        projection="fisheye",
        progress=False,
    )
    print(
        f"zenith {sky.zenith_magnitude:.2f} mag arcsec-2 "
        f"({sky.zenith_luminance * 1e6:.0f} ucd m-2), Bortle class {sky.bortle}"
    )
    # --8<-- [end:skyglow]


if __name__ == "__main__":
    main()
