"""Compare predicted streetlight poles with the lamps mapped in OpenStreetMap (Helsinki).

Runs ``streets normalize -> sample -> place`` on the bundled Helsinki extract and compares
the predicted poles with the 586 mapped ``highway=street_lamp`` nodes:

* lamps per km of vehicular street,
* along-street spacing between consecutive lamps on the same street,
* share of streets lit from one side versus both sides,
* distance from each mapped lamp to the nearest predicted pole.

Writes ``examples/figures/helsinki_comparison.json`` and two PNG figures. Usage::

    python examples/compare_helsinki_lamps.py [--seed 2011] [--out examples/figures]

Data: (c) OpenStreetMap contributors, ODbL 1.0.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import geopandas as gpd
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import shapely
from scipy.spatial import cKDTree

import nightlights as nl
from nightlights.demo import example_path, mapped_street_lamps

VEHICULAR = ("motorway", "arterial", "collector", "local", "service")
#: A lamp counts as standing along a street when it is this close to its centreline [m].
SNAP_DISTANCE = 20.0


def along_street_statistics(points: gpd.GeoSeries, streets: gpd.GeoDataFrame) -> dict:
    """Snap points to their nearest street within SNAP_DISTANCE; spacing and sides per street."""
    tree = shapely.STRtree(streets.geometry.to_numpy())
    point_index, street_index = tree.query_nearest(
        points.to_numpy(), max_distance=SNAP_DISTANCE, all_matches=False
    )
    lines = streets.geometry.to_numpy()[street_index]
    along = shapely.line_locate_point(lines, points.to_numpy()[point_index])
    ahead = shapely.line_interpolate_point(lines, np.minimum(along + 1.0, shapely.length(lines)))
    behind = shapely.line_interpolate_point(lines, np.maximum(along - 1.0, 0.0))
    t = shapely.get_coordinates(ahead) - shapely.get_coordinates(behind)
    p = shapely.get_coordinates(points.to_numpy()[point_index]) - shapely.get_coordinates(behind)
    side = np.sign(t[:, 0] * p[:, 1] - t[:, 1] * p[:, 0])
    table = pd.DataFrame(
        {"street": streets["source_id"].to_numpy()[street_index], "along": along, "side": side}
    )
    spacings = []
    sides = []
    for _, group in table.groupby("street"):
        if len(group) < 2:
            continue
        for _, same_side in group.groupby("side"):
            spacings.extend(np.diff(np.sort(same_side["along"].to_numpy())))
        sides.append("both" if group["side"].nunique() > 1 else "one")
    spacings = np.asarray(spacings)
    return {
        "snapped": len(point_index),
        "per_street": table.groupby("street").size(),
        "spacings": spacings[spacings > 1.0],
        "one_sided_share": float(np.mean(np.array(sides) == "one")) if sides else float("nan"),
        "streets_with_two_or_more": len(sides),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=2011)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "figures")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    streets = nl.normalize(example_path(), mapping="osm").streets
    streets = nl.sample(streets, seed=args.seed).streets
    predicted = nl.place(streets, seed=args.seed).lights
    mapped = mapped_street_lamps(streets.crs)
    poles = predicted.drop_duplicates("pole_id")
    vehicular = streets.loc[streets["street_class"].isin(VEHICULAR)]
    km = vehicular.geometry.length.sum() / 1000.0
    bounds = shapely.box(*mapped.total_bounds).buffer(50)
    study = streets.clip(bounds)
    study_vehicular = study.loc[study["street_class"].isin(VEHICULAR)]
    study_km = study_vehicular.geometry.length.sum() / 1000.0
    poles_in = poles.clip(bounds)

    def near_vehicular(points: gpd.GeoDataFrame) -> int:
        tree = shapely.STRtree(study_vehicular.geometry.to_numpy())
        hit, _ = tree.query_nearest(points.geometry.to_numpy(), max_distance=SNAP_DISTANCE)
        return len(np.unique(hit))

    stats_mapped = along_street_statistics(mapped.geometry, study_vehicular)
    stats_predicted = along_street_statistics(poles_in.geometry, study_vehicular)
    # Mapping is incomplete: most streets have no lamp mapped at all. Where a street has two
    # or more mapped lamps its lamps were probably mapped, so compare densities there too.
    per_street = stats_mapped["per_street"]
    mapped_streets = per_street.index[per_street >= 2]
    street_length = study_vehicular.set_index("source_id").geometry.length
    street_length = street_length.groupby(level=0).sum()
    mapped_km = street_length.loc[mapped_streets].sum() / 1000.0
    predicted_there = stats_predicted["per_street"].reindex(mapped_streets).fillna(0).sum()
    nn_distance, _ = cKDTree(np.column_stack([poles.geometry.x, poles.geometry.y])).query(
        np.column_stack([mapped.geometry.x, mapped.geometry.y])
    )
    result = {
        "seed": args.seed,
        "study_area": "bounding box of the mapped lamps + 50 m",
        "vehicular_km_total": round(km, 3),
        "vehicular_km_study_area": round(study_km, 3),
        "mapped_lamps": len(mapped),
        "predicted_poles_study_area": len(poles_in),
        "predicted_luminaires_total": len(predicted),
        "lamps_per_km_vehicular": {
            "mapped": round(near_vehicular(mapped) / study_km, 2),
            "predicted": round(near_vehicular(poles_in) / study_km, 2),
        },
        "streets_with_2plus_mapped_lamps": {
            "streets": len(mapped_streets),
            "km": round(mapped_km, 3),
            "mapped_per_km": round(per_street.loc[mapped_streets].sum() / mapped_km, 2),
            "predicted_per_km": round(predicted_there / mapped_km, 2),
        },
        "median_spacing_m": {
            "mapped": float(np.median(stats_mapped["spacings"])),
            "predicted": float(np.median(stats_predicted["spacings"])),
        },
        "one_sided_share": {
            "mapped": stats_mapped["one_sided_share"],
            "predicted": stats_predicted["one_sided_share"],
        },
        "nearest_predicted_pole_m": {
            "median": float(np.median(nn_distance)),
            "p90": float(np.percentile(nn_distance, 90)),
            "share_within_10m": float(np.mean(nn_distance <= 10)),
        },
    }
    (args.out / "helsinki_comparison.json").write_text(json.dumps(result, indent=2) + "\n")

    fig, ax = plt.subplots(figsize=(7, 9))
    streets.plot(ax=ax, color="0.75", linewidth=0.6)
    study_vehicular.plot(ax=ax, color="0.35", linewidth=1.0)
    poles.plot(ax=ax, color="tab:orange", markersize=5, label=f"predicted poles ({len(poles)})")
    mapped.plot(
        ax=ax,
        color="tab:blue",
        markersize=5,
        marker="x",
        label=f"mapped street_lamp ({len(mapped)})",
    )
    ax.set_xlim(bounds.bounds[0], bounds.bounds[2])
    ax.set_ylim(bounds.bounds[1], bounds.bounds[3])
    ax.set_title("Helsinki centre: predicted poles vs OSM street lamps")
    ax.set_xlabel(f"easting [m] ({streets.crs.to_string()})")
    ax.set_ylabel("northing [m]")
    ax.legend(loc="lower left")
    ax.text(
        0.99,
        0.01,
        "(c) OpenStreetMap contributors, ODbL",
        transform=ax.transAxes,
        ha="right",
        fontsize=7,
    )
    fig.tight_layout()
    fig.savefig(args.out / "helsinki_map.png", dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    bins = np.arange(0, 81, 4)
    axes[0].hist(stats_mapped["spacings"], bins=bins, alpha=0.6, density=True, label="mapped")
    axes[0].hist(stats_predicted["spacings"], bins=bins, alpha=0.6, density=True, label="predicted")
    axes[0].set_xlabel("along-street spacing, same side [m]")
    axes[0].set_ylabel("density")
    axes[0].legend()
    axes[1].hist(nn_distance, bins=np.arange(0, 61, 2.5), color="tab:green")
    axes[1].set_xlabel("mapped lamp -> nearest predicted pole [m]")
    axes[1].set_ylabel("mapped lamps")
    fig.suptitle("Helsinki: predicted vs mapped street lamps")
    fig.tight_layout()
    fig.savefig(args.out / "helsinki_histograms.png", dpi=110)
    plt.close(fig)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
