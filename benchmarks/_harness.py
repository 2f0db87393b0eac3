"""Shared harness of the benchmark scripts: timing, machine description, arguments, results.

Every ``bench_*.py`` script sweeps one knob, measures time and error against a converged
reference, and writes ``<name>.json`` and ``<name>.png`` through :func:`write_results`.

Where results go:

* a full run (no ``--quick``) writes to ``benchmarks/results/``: these files are checked in
  and shown in the README;
* a ``--quick`` run writes to ``benchmarks/results/quick/`` (ignored by git), so that a quick
  check never overwrites the full-run results;
* ``--out DIR`` writes to ``DIR`` instead, for either kind of run.

Every JSON carries the machine description (:func:`machine`: CPU model, cores, memory, numpy,
numba and BLAS) under ``"machine"`` and the kind of run under ``"quick"``. Timings come from
``time.perf_counter``; the development machine has 2 cores shared with other jobs, so they
are noisy and best-of or median figures are used where a call is cheap enough to repeat.

Run any script as ``python benchmarks/bench_<name>.py [--quick] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from types import TracebackType
from typing import Any, Generic, TypeVar

T = TypeVar("T")

#: Folder of the checked-in full-run results.
RESULTS = Path(__file__).resolve().parent / "results"
#: Default folder of ``--quick`` runs (git-ignored).
QUICK_RESULTS = RESULTS / "quick"


# --------------------------------------------------------------------------------------------
# Timing


class Stopwatch:
    """Wall time of a ``with`` block [s], from ``time.perf_counter``.

    Examples
    --------
    >>> with Stopwatch() as watch:
    ...     _ = sum(range(1000))
    >>> watch.seconds >= 0
    True
    """

    seconds: float

    def __enter__(self) -> Stopwatch:
        self.seconds = float("nan")
        self._start = time.perf_counter()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.seconds = time.perf_counter() - self._start


def timed(function: Callable[[], T]) -> tuple[T, float]:
    """Call ``function`` once; return its value and the wall time of the call [s]."""
    start = time.perf_counter()
    value = function()
    return value, time.perf_counter() - start


@dataclass(frozen=True)
class Timing(Generic[T]):
    """Wall times of repeated calls [s] and the value of the last call."""

    value: T
    times: tuple[float, ...]

    @property
    def best(self) -> float:
        """Shortest time [s]: the usual figure on a shared machine."""
        return min(self.times)

    @property
    def median(self) -> float:
        """Median time [s]: for very short calls, where the minimum is a lucky outlier."""
        return float(statistics.median(self.times))


def repeat(function: Callable[[], T], repeats: int = 3) -> Timing[T]:
    """Call ``function`` ``repeats`` times and time each call.

    Examples
    --------
    >>> timing = repeat(lambda: 2 + 2, repeats=5)
    >>> timing.value, len(timing.times), timing.best <= timing.median
    (4, 5, True)
    """
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats}")
    times = []
    value: T
    for _ in range(repeats):
        value, seconds = timed(function)
        times.append(seconds)
    return Timing(value, tuple(times))


# --------------------------------------------------------------------------------------------
# Machine description


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _memory_gib() -> float | None:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError, AttributeError):
        return None


def _version(package: str) -> str | None:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return None


def _blas() -> list[dict[str, Any]]:
    import numpy  # noqa: F401  (loads the BLAS that threadpoolctl reports)

    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        return []
    keys = ("user_api", "internal_api", "version", "num_threads", "threading_layer")
    return [{key: pool.get(key) for key in keys} for pool in threadpool_info()]


def _numba_threads() -> int | None:
    numba = sys.modules.get("numba")  # only where the benchmark uses it: importing is slow
    return None if numba is None else int(numba.config.NUMBA_NUM_THREADS)


def machine() -> dict[str, Any]:
    """Description of the machine and the numerical stack that ran a benchmark."""
    affinity = getattr(os, "sched_getaffinity", None)
    return {
        "cpu": _cpu_model(),
        "architecture": platform.machine(),
        "logical_cores": os.cpu_count(),
        "usable_cores": len(affinity(0)) if affinity else os.cpu_count(),
        "memory_gib": None if (gib := _memory_gib()) is None else round(gib, 1),
        "system": platform.platform(),
        "python": platform.python_version(),
        "numpy": _version("numpy"),
        "numba": _version("numba"),
        "numba_threads": _numba_threads(),
        "blas": _blas(),
    }


# --------------------------------------------------------------------------------------------
# Arguments


def argument_parser(doc: str | None, *, quick: str) -> argparse.ArgumentParser:
    """Parser with ``--quick`` (help text ``quick``: what it leaves out) and ``--out``.

    ``doc`` is the script's module docstring; its first line describes the script.
    Add the script's own options, then call :func:`parse_args`.
    """
    parser = argparse.ArgumentParser(
        description=(doc or "").strip().splitlines()[0] if doc else None,
        epilog="Results: benchmarks/results/ (full run) or benchmarks/results/quick/ (--quick).",
    )
    parser.add_argument("--quick", action="store_true", help=f"quick run: {quick}")
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        help="results folder (default benchmarks/results, or benchmarks/results/quick "
        "with --quick)",
    )
    return parser


def parse_args(
    parser: argparse.ArgumentParser, argv: list[str] | None = None
) -> argparse.Namespace:
    """Parse the arguments; ``args.out`` is set to the results folder of this kind of run."""
    args = parser.parse_args(argv)
    if args.out is None:
        args.out = QUICK_RESULTS if args.quick else RESULTS
    return args


# --------------------------------------------------------------------------------------------
# Results


def previous_results(name: str, out: Path) -> dict[str, Any] | None:
    """The last ``<name>.json`` in ``out``, else the checked-in full run's, else None.

    For figures a run keeps from an earlier, longer measurement (clearly dated or labelled in
    the JSON) instead of repeating it.
    """
    for folder in (out, RESULTS):
        path = folder / f"{name}.json"
        if path.is_file():
            return json.loads(path.read_text())
    return None


def write_results(
    out: Path,
    name: str,
    payload: dict[str, Any],
    *,
    quick: bool,
    plot: Callable[[dict[str, Any]], Any] | None = None,
    dpi: int = 110,
) -> Path:
    """Write ``<out>/<name>.json`` (payload + machine description) and ``<out>/<name>.png``.

    Parameters
    ----------
    out
        Results folder (created if missing).
    name
        File stem, the benchmark's name.
    payload
        The figures; ``"benchmark"``, ``"quick"`` and ``"machine"`` keys are added.
    quick
        Whether this was a ``--quick`` run.
    plot
        Function of the written payload that returns a matplotlib ``Figure``; saved as PNG.
    dpi
        Resolution of the PNG.

    Returns
    -------
    pathlib.Path
        The JSON file.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    document = {"benchmark": name, **payload, "quick": quick, "machine": machine()}
    path = out / f"{name}.json"
    path.write_text(json.dumps(document, indent=2) + "\n")
    if plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        figure = plot(document)
        figure.savefig(out / f"{name}.png", dpi=dpi)
        plt.close(figure)
    print(f"wrote {path}", flush=True)
    return path


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
