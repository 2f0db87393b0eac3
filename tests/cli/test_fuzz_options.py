"""Property-based fuzzing of the option parsers: any text gives a value or a clean error.

A parser of command-line text may refuse a value only with a click error (a usage error, exit
status 2) or, where the value is refused like the library's own range checks (``nan``, an
unknown CRS), a ``NightlightsError`` (one line, exit status 1); never with a ``ValueError``,
an ``IndexError`` or another exception that the CLI would report as a bug. What it accepts
must be what it promises (two finite floats, a positive byte count, ...).
"""

from __future__ import annotations

import math
from pathlib import Path

import click
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from nightlights._resources import format_bytes, parse_size
from nightlights.errors import InputError, NightlightsError
from nightlights.inverse import SkyRegion
from nightlights_cli.emission import parse_albedo
from nightlights_cli.inverse import _max_dimming, _region_target
from nightlights_cli.irradiance import parse_bounds
from nightlights_cli.options import (
    CRSText,
    FiniteFloat,
    FiniteFloatRange,
    MemorySize,
    one_of,
    parse_pair,
    resolve_inout,
)

FUZZ = settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])

#: Text that looks like what users type: numbers, separators, units, words, odd characters.
number_text = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(min_value=-(10**30), max_value=10**30).map(str),
    st.sampled_from(["nan", "inf", "-inf", "1e308", "1e309", "-0", "0x10", "1_000", "٣", "½"]),
)
option_text = st.one_of(
    st.text(max_size=40),
    st.lists(number_text, max_size=5).map(",".join),
    st.lists(number_text, max_size=5).map(" ".join),
    st.tuples(st.text(max_size=10), number_text).map(":".join),
    st.tuples(
        number_text, st.sampled_from(["", "K", "M", "G", "T", "P", "E", "GB", "GiB", "b"])
    ).map("".join),
)

CLICK_ERRORS = (click.ClickException,)


def _accepts(parser, text, *errors: type[BaseException]):
    """``parser(text)``, or None when it refuses with one of ``errors`` (with a message)."""
    try:
        return parser(text)
    except errors as exc:
        assert str(exc.format_message() if isinstance(exc, click.ClickException) else exc)
        return None


@FUZZ
@given(option_text)
def test_parse_pair(text: str) -> None:
    value = _accepts(parse_pair, text, *CLICK_ERRORS)
    if value is not None:
        assert len(value) == 2 and all(isinstance(v, float) for v in value)


@FUZZ
@given(st.one_of(st.none(), option_text))
def test_parse_bounds(text: str | None) -> None:
    value = _accepts(parse_bounds, text, *CLICK_ERRORS)
    if value is not None:
        assert len(value) == 4 and all(isinstance(v, float) for v in value)


@FUZZ
@given(option_text)
def test_parse_albedo(text: str) -> None:
    value = _accepts(parse_albedo, text, *CLICK_ERRORS)
    assert value is None or isinstance(value, float) or Path(value).exists()


@FUZZ
@given(option_text)
def test_region_target(text: str) -> None:
    value = _accepts(_region_target, text, *CLICK_ERRORS)
    if value is not None:
        region, magnitude = value
        assert region.strip() and isinstance(magnitude, float)


@FUZZ
@given(st.one_of(st.none(), option_text))
def test_max_dimming(text: str | None) -> None:
    value = _accepts(_max_dimming, text, *CLICK_ERRORS)
    assert value is None or isinstance(value, float) or Path(value).is_file()


@FUZZ
@given(option_text)
def test_sky_region_text(text: str) -> None:
    region = _accepts(SkyRegion.parse, text, InputError)
    assert region is None or isinstance(region, SkyRegion)


@FUZZ
@given(st.one_of(option_text, st.integers(), st.floats()))
def test_memory_size(text) -> None:
    value = _accepts(lambda t: MemorySize().convert(t, None, None), text, *CLICK_ERRORS)
    if value is not None:
        assert isinstance(value, int) and 1 <= value < 2**63


@FUZZ
@given(st.floats(min_value=1, max_value=2.0**62))
def test_memory_size_reads_what_format_bytes_writes(size: float) -> None:
    """A size written for a message reads back within the rounding of its one decimal."""
    text = format_bytes(size).replace(" ", "").replace("iB", "")
    assert math.isclose(parse_size(text), size, rel_tol=0.05, abs_tol=1)


@FUZZ
@given(option_text)
def test_finite_floats(text: str) -> None:
    for kind in (FiniteFloat(), FiniteFloatRange(0, 1)):
        convert = kind.convert
        value = _accepts(lambda t, c=convert: c(t, None, None), text, *CLICK_ERRORS, InputError)
        assert value is None or math.isfinite(value)


@settings(max_examples=10, deadline=None)  # pyproj takes a while to refuse some texts
@given(option_text)
@example("EPSG:3067")
@example("garbage")
@example("+proj=utm +zone=35 +datum=WGS84")
def test_crs_text(text: str) -> None:
    """A CRS option is passed on unchanged or refused with a CRSError (a NightlightsError)."""
    value = _accepts(lambda t: CRSText().convert(t, None, None), text, NightlightsError)
    assert value is None or value == text


@FUZZ
@given(
    st.lists(st.sampled_from(["in.tif", "other.tif", "", "-", "x/y.tif"]), max_size=4),
    st.one_of(st.none(), st.sampled_from(["out.tif", "", "in.tif"])),
    st.sampled_from([1, 2, (1, 2), (0, 3)]),
)
def test_resolve_inout(paths: list[str], output: str | None, inputs) -> None:
    value = _accepts(
        lambda _: resolve_inout(
            paths, output, inputs=inputs, usage="INPUT OUTPUT", overwrite=False
        ),
        None,
        *CLICK_ERRORS,
    )
    if value is not None:
        found, out = value
        assert all(Path(p).exists() for p in found) and isinstance(out, str)


@FUZZ
@given(st.dictionaries(st.sampled_from(["--a", "--b", "--c"]), st.one_of(st.none(), st.text())))
def test_one_of(values: dict) -> None:
    ctx = click.Context(click.Command("x"))
    given_values = [v for v in values.values() if v is not None]
    if len(given_values) > 1:
        with pytest.raises(click.UsageError):
            one_of(ctx, **values)
    else:
        assert one_of(ctx, **values) == (given_values[0] if given_values else None)
