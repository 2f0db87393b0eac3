"""The demo project end to end: from a fresh install, with the kernel cached, and rerun.

``nightlights demo`` runs the bundled project file ``helsinki.toml`` (eleven stages: streets
normalize, sample, place; irradiance at 1 m; emission at 50 m; skyglow for two observers; the
observers' summary layer; Q, S and a dimming plan). Each run is the command in a subprocess:

1. *fresh install*: an empty kernel cache (``NIGHTLIGHTS_CACHE`` in a temporary folder) and
   an empty output folder: everything, the demo kernel's build included;
2. *kernel cached*: the same cache, a new output folder: every stage, no kernel build;
3. *rerun*: the same command in the folder of (2) with ``--overwrite``: every stage is up to
   date and skipped.

For each: the wall time, the CPU time of the subprocess and the load average before it (the
machine has 2 cores shared with other jobs, so the wall time depends on them; the CPU time
less so); for (1) also each stage's wall time from its cache record. The acceptance target:
(1) within 5 minutes.

Run: ``python benchmarks/bench_demo.py [--quick] [--out DIR]`` (``--quick``: leaves out the
fresh-install run). Writes ``demo.json`` and ``demo.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import _harness as harness

from nightlights.project import STAGES

#: The acceptance target of the fresh-install run [s].
TARGET_SECONDS = 300.0


def _run_demo(out: Path, cache: Path, *extra: str) -> dict[str, Any]:
    """``nightlights demo OUT`` in a subprocess: wall and CPU time, load average before."""
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "nightlights_cli", "demo", str(out), *extra],
        env={**os.environ, "NIGHTLIGHTS_CACHE": str(cache)},
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"nightlights demo failed: {done.stderr[-2000:]}")
    root = str(Path(__file__).resolve().parents[1]) + "/"
    summary = [  # the project file's path relative to the repository, not this machine's
        line.replace(root, "") for line in done.stderr.splitlines() if line.startswith("ran ")
    ]
    return {
        "wall_s": wall,
        "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
        "load_average_before": load,
        "summary": summary[-1] if summary else "",
    }


def _stage_seconds(out: Path) -> dict[str, float]:
    """Each stage's wall time from its cache record [s], in running order."""
    records = sorted((out / ".nightlights").glob("*.json"), key=lambda p: p.stat().st_mtime_ns)
    data = [json.loads(path.read_text()) for path in records]
    return {entry["task"]: float(entry["seconds"]) for entry in data}


def main(argv: list[str] | None = None) -> None:
    parser = harness.argument_parser(__doc__, quick="without the fresh-install run")
    args = harness.parse_args(parser, argv)
    runs: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="bench-demo-") as folder:
        root = Path(folder)
        cache = root / "cache"
        if not args.quick:
            runs["fresh_install"] = _run_demo(root / "fresh", cache)
            runs["fresh_install"]["stages_s"] = _stage_seconds(root / "fresh")
            print(f"fresh install: {runs['fresh_install']['wall_s']:.1f} s", flush=True)
        else:  # the kernel still has to be built once before (2)
            _run_demo(root / "warm-up", cache)
        runs["kernel_cached"] = _run_demo(root / "cached", cache)
        runs["kernel_cached"]["stages_s"] = _stage_seconds(root / "cached")
        print(f"kernel cached: {runs['kernel_cached']['wall_s']:.1f} s", flush=True)
        runs["rerun"] = _run_demo(root / "cached", cache, "--overwrite")
        print(f"rerun: {runs['rerun']['wall_s']:.1f} s", flush=True)
    payload = {
        "target_s": TARGET_SECONDS,
        "runs": runs,
        "note": "wall times on a 2-core machine shared with other jobs (load average recorded)",
    }
    harness.write_results(args.out, "demo", payload, quick=args.quick, plot=_plot)


def _plot(document: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    runs = document["runs"]
    first = runs.get("fresh_install", runs["kernel_cached"])
    stages = first["stages_s"]
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    names = sorted(stages, key=lambda name: (STAGES.index(name.split(":")[0]), name))
    left.barh(names, [stages[name] for name in names], color="#4a6fa5")
    left.invert_yaxis()
    left.set_xlabel("wall time [s]")
    which = "fresh install" if "fresh_install" in runs else "kernel cached"
    left.set_title(f"each stage ({which}; the kernel build is in the first skyglow)")
    labels = [name.replace("_", " ") for name in runs]
    right.bar(labels, [runs[n]["wall_s"] for n in runs], label="wall", color="#4a6fa5")
    right.bar(labels, [runs[n]["cpu_s"] for n in runs], label="CPU", color="#e0a030", width=0.4)
    right.axhline(document["target_s"], color="#b03030", linestyle="--", label="target (5 min)")
    right.set_ylabel("time [s]")
    right.set_title("nightlights demo (shared 2-core machine)")
    right.legend()
    figure.tight_layout()
    return figure


if __name__ == "__main__":
    main()
