"""Bad ``--scheduler`` values of ``darkness``, ``irradiance`` and ``sky observers``, table-driven.

A scheduler is checked before any work, whether the stage would use it or not (a raster within
one chunk): a malformed address is a usage error (exit status 2), an address where no dask
scheduler answers (refused, unknown host, a silent port, a port that speaks something else) is
one ``InputError`` line within seconds (exit status 1); no traceback, no output, and no
half-made ``distributed.Client`` left to block the process at exit.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

import geopandas as gpd
import numpy as np
import pytest
from affine import Affine
from click.testing import CliRunner
from shapely.geometry import Point

from nightlights import _parallel
from nightlights._parallel import check_scheduler, compute_distributed, parse_scheduler_address
from nightlights.errors import InputError
from nightlights.io import RasterBand, write_cog
from nightlights.sky import KernelSpec, build_kernel
from nightlights_cli.main import cli

TRANSFORM = Affine(100, 0, 500_000, 0, -100, 6_700_000)
#: Seconds a refusal may take at most (a loose bound: the old code waited 30 s, then 60 s more
#: at exit; the probe answers in milliseconds, a silent port in CONNECT_TIMEOUT).
QUICK = 15.0


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> SimpleNamespace:
    folder = tmp_path_factory.mktemp("scheduler_inputs")
    values = np.zeros((80, 80), np.float32)
    values[30:34, 40:44] = 1.0
    emission = folder / "emission.tif"
    write_cog(emission, [RasterBand(values, "reflected", "lm m-2")], transform=TRANSFORM,
              crs="EPSG:32635")  # fmt: skip
    kernel = folder / "kernel.nc"
    spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    build_kernel(spec, kernel, progress=False)
    lights = folder / "lights.gpkg"
    gpd.GeoDataFrame(
        {"system_id": ["street_led_small"] * 2, "heading": [0.0, 180.0]},
        geometry=[Point(385_000, 6_672_000), Point(385_020, 6_672_010)],
        crs="EPSG:3067",
    ).to_file(lights, driver="GPKG")
    observers = folder / "observers.gpkg"
    gpd.GeoDataFrame(geometry=[Point(503_000, 6_696_500)], crs="EPSG:32635").to_file(observers)
    return SimpleNamespace(emission=emission, kernel=kernel, lights=lights, observers=observers)


@pytest.fixture(scope="module")
def silent_port() -> Iterator[str]:
    """A port that accepts connections and never speaks (a web server waits so)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(16)
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    server.close()


@pytest.fixture(scope="module")
def babbling_port() -> Iterator[str]:
    """A port that answers every connection with bytes that are no dask handshake."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(16)

    def serve() -> None:
        while True:
            try:
                connection, _ = server.accept()
            except OSError:
                return
            connection.sendall(b"\x00garbage")
            time.sleep(0.2)
            connection.close()

    threading.Thread(target=serve, daemon=True).start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    server.close()


def _refused_port() -> str:
    """A local port nothing listens on."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return f"tcp://127.0.0.1:{probe.getsockname()[1]}"


COMMANDS = {
    # 80 x 80 cells, stencil radius 30: one chunk by default, four with --chunk-size 64
    "darkness one chunk": "darkness {emission} {out} --kernel {kernel}",
    "darkness chunked": "darkness {emission} {out} --kernel {kernel} --chunk-size 64",
    "irradiance": "irradiance {lights} {out} --resolution 4",
    "observers": "sky observers {emission} {observers} {out} --kernel {kernel}",
}
#: (name, address or a fixture's name, exit status, key words of the message)
ADDRESSES = [
    ("no port", "garbage", 2, ["'garbage'", "expected", "tcp://HOST:PORT"]),
    ("bad scheme", "http://127.0.0.1:8786", 2, ["unknown scheme 'http'"]),
    ("port out of range", "tcp://127.0.0.1:70000", 2, ["port '70000'", "1-65535"]),
    ("no host", "tcp://:8786", 2, ["no host name"]),
    ("refused", "refused", 1, ["InputError", "--scheduler=", "connection refused by 127.0.0.1"]),
    ("unknown host", "tcp://no-such-host.invalid:8786", 1, ["unknown host 'no-such-host.invalid'"]),
    ("silent port", "silent_port", 1, ["accepts connections but sent no dask handshake"]),
]


@pytest.mark.parametrize("command", list(COMMANDS))
@pytest.mark.parametrize(
    ("name", "address", "code", "words"), ADDRESSES, ids=[a[0] for a in ADDRESSES]
)
def test_a_bad_scheduler_is_refused_before_any_work(
    inputs: SimpleNamespace,
    tmp_path: Path,
    request: pytest.FixtureRequest,
    monkeypatch: pytest.MonkeyPatch,
    command: str,
    name: str,
    address: str,
    code: int,
    words: list[str],
) -> None:
    monkeypatch.setattr(_parallel, "CONNECT_TIMEOUT", 1.0)
    if address == "refused":
        address = _refused_port()
    elif address == "silent_port":
        address = request.getfixturevalue("silent_port")
    out = tmp_path / ("out.gpkg" if command == "observers" else "out.tif")
    values = {"out": out, **vars(inputs)}
    args = [*COMMANDS[command].format(**values).split(), "--scheduler", address]
    start = time.perf_counter()
    result = CliRunner().invoke(cli, args)
    seconds = time.perf_counter() - start
    assert result.exit_code == code, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.output
    for word in words:
        assert word in errors[0], (word, errors[0])
    assert seconds < QUICK, seconds
    assert list(tmp_path.iterdir()) == []


def test_a_port_that_speaks_no_dask_is_refused_and_the_process_exits_at_once(
    inputs: SimpleNamespace, babbling_port: str
) -> None:
    """The probe sees bytes, the client's start fails: the half-made client is closed at once,
    not at the end of the process (where closing it waited a minute)."""
    script = (
        "import dask, sys\n"
        "from nightlights._parallel import compute_distributed\n"
        "from nightlights.errors import InputError\n"
        "try:\n"
        f"    compute_distributed([dask.delayed(sum)([1, 2])], {babbling_port!r}, lambda: None)\n"
        "except InputError as exc:\n"
        "    print(exc)\n"
        "    sys.exit(3)\n"
    )
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    seconds = time.perf_counter() - start
    assert done.returncode == 3, done.stderr
    assert "cannot connect to a dask scheduler" in done.stdout
    assert "Exception ignored" not in done.stderr and "Traceback" not in done.stderr
    assert seconds < 30.0, seconds


def test_an_address_by_itself_runs_without_a_default_client(inputs: SimpleNamespace) -> None:
    """An address and no ``distributed.Client`` in the process (the command line's case)."""
    import dask
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        address = cluster.scheduler_address
        assert check_scheduler(address) == address
        assert compute_distributed([dask.delayed(sum)([1, 2])], address, lambda: None) == [3]


@pytest.mark.parametrize(
    ("address", "expected"),
    [
        ("tcp://127.0.0.1:8786", ("tcp", "127.0.0.1", 8786)),
        ("127.0.0.1:8786", ("tcp", "127.0.0.1", 8786)),
        ("tls://scheduler.example:8786", ("tls", "scheduler.example", 8786)),
        ("tcp://[::1]:8786", ("tcp", "::1", 8786)),
        ("inproc://10.0.0.1/123/1", ("inproc", "10.0.0.1/123/1", None)),
    ],
)
def test_addresses_that_parse(address: str, expected: tuple) -> None:
    assert parse_scheduler_address(address) == expected


@pytest.mark.parametrize(
    ("scheduler", "local", "message"),
    [
        ("fast", ("threads",), "scheduler='fast'; expected one of threads, a dask.distributed"),
        ("tcp://::1:8786", (), "IPv6 host is written in brackets"),
        ("tcp://host:port", (), "port 'port'"),
        (8786, (), "scheduler of type int; expected a dask.distributed scheduler address"),
    ],
)
def test_the_library_names_the_bad_scheduler(scheduler, local, message: str) -> None:
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        check_scheduler(scheduler, local=local)
