"""Tests of nightlights._resources: the memory limit, its sources and the refusal message."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from collections.abc import Iterator

import pytest

from nightlights import _resources
from nightlights._resources import (
    ENVIRONMENT_VARIABLE,
    available_memory,
    check_memory,
    format_bytes,
    memory_limit,
    parse_size,
    set_memory_limit,
)
from nightlights.errors import InputError, NightlightsError, ResourceError

GIB = 1024**3


@pytest.fixture(autouse=True)
def no_limit_set(monkeypatch) -> Iterator[None]:
    """Each test starts and ends without an override or environment setting."""
    monkeypatch.delenv(ENVIRONMENT_VARIABLE, raising=False)
    set_memory_limit(None)
    yield
    set_memory_limit(None)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("4096", 4096),
        (4096, 4096),
        ("2e9", 2_000_000_000),
        ("500M", 500 * 1024**2),
        ("8G", 8 * GIB),
        ("8g", 8 * GIB),
        ("8GB", 8 * GIB),
        ("8GiB", 8 * GIB),
        (" 1.5T ", int(1.5 * 1024**4)),
        ("0.5K", 512),
    ],
)
def test_parse_size(text, expected: int) -> None:
    assert parse_size(text) == expected


@pytest.mark.parametrize(
    "text", ["", "lots", "8X", "-1G", "0", "0.1", "nan", "inf", "1e30", "8 G B", True, float("nan")]
)
def test_parse_size_refuses_what_is_not_a_size(text) -> None:
    with pytest.raises(InputError, match=r"memory limit .*expected"):
        parse_size(text, source="memory limit")


@pytest.mark.parametrize(
    ("n", "text"),
    [(0, "0 B"), (1023, "1023 B"), (1024, "1.0 KiB"), (6.9 * GIB, "6.9 GiB"), (2.2e13, "20.0 TiB")],
)
def test_format_bytes(n: float, text: str) -> None:
    assert format_bytes(n) == text


def test_default_is_half_the_available_memory() -> None:
    assert memory_limit() == available_memory() // 2
    assert 0 < available_memory() <= _resources._physical_memory()


def test_environment_then_override(monkeypatch) -> None:
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, "3G")
    assert memory_limit() == 3 * GIB
    set_memory_limit("1G")
    assert memory_limit() == GIB
    set_memory_limit(None)
    assert memory_limit() == 3 * GIB


def test_a_bad_environment_setting_names_the_variable(monkeypatch) -> None:
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, "plenty")
    with pytest.raises(InputError, match="NIGHTLIGHTS_MAX_MEMORY 'plenty': expected a size"):
        memory_limit()


def test_check_memory_states_estimate_limit_and_options() -> None:
    set_memory_limit("4G")
    check_memory(4 * GIB, "exactly the limit")
    with pytest.raises(ResourceError) as info:
        check_memory(7.4e9, "the kernel table of 1000000 distances", option="n_distance=")
    assert str(info.value) == (
        "the kernel table of 1000000 distances needs about 6.9 GiB, more than the 4.0 GiB "
        "allowed; lower n_distance= or raise the limit with NIGHTLIGHTS_MAX_MEMORY"
    )
    assert isinstance(info.value, MemoryError) and isinstance(info.value, NightlightsError)
    with pytest.raises(ResourceError, match="; use a coarser resolution= or raise the limit"):
        check_memory(5 * GIB, "the raster", option="use a coarser resolution=")


@pytest.mark.parametrize("estimate", [float("inf"), float("nan")])
def test_an_unbounded_estimate_is_refused(estimate: float) -> None:
    with pytest.raises(ResourceError, match="needs an unbounded amount of memory"):
        check_memory(estimate, "the grid")


def test_address_space_limit_caps_the_default() -> None:
    script = textwrap.dedent(
        """
        import resource
        resource.setrlimit(resource.RLIMIT_AS, (3 * 1024**3, resource.RLIM_INFINITY))
        from nightlights._resources import memory_limit
        print(memory_limit())
        """
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    )
    assert int(result.stdout) == min(3 * GIB, available_memory()) // 2
