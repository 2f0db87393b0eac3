"""Property-based fuzzing of the photometry readers: mutated real files raise only
:class:`~ies.errors.PhotometryError` (any other exception is a reader bug)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ies.errors import PhotometryError
from ies.eulumdat import parse_ldt
from ies.lm63 import parse_ies
from ies.reader import parse_photometry

LIBRARY = Path(__file__).resolve().parents[2] / "ies" / "library"
FILES = {path.name: path.read_text(encoding="latin-1") for path in sorted(LIBRARY.glob("*.*"))}
PHOTOMETRIC = sorted(name for name in FILES if name.endswith((".ies", ".ldt")))

#: Replacement tokens: non-numbers, non-finite, huge, tiny, negative, fractional counts.
NASTY = [
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e9",
    "1e-320",
    "-1",
    "0",
    "0.5",
    "2.5",
    "",
    "abc",
    "1,5",
    "TILT=INCLUDE",
    "\x00",
    "99999999999999999999999",
]


def _mutate(text: str, operations: list[tuple[str, int, str]]) -> str:
    lines = text.splitlines()
    for kind, where, token in operations:
        if not lines:
            break
        k = where % len(lines)
        if kind == "replace_token":
            words = lines[k].split()
            if words:
                words[where % len(words)] = token
                lines[k] = " ".join(words)
            else:
                lines[k] = token
        elif kind == "replace_line":
            lines[k] = token
        elif kind == "delete_line":
            del lines[k]
        elif kind == "duplicate_line":
            lines.insert(k, lines[k])
        else:  # truncate
            lines = lines[: k + 1]
    return "\n".join(lines) + "\n"


operations = st.lists(
    st.tuples(
        st.sampled_from(
            [
                "replace_token",
                "replace_token",
                "replace_line",
                "delete_line",
                "duplicate_line",
                "truncate",
            ]
        ),
        st.integers(min_value=0, max_value=10_000),
        st.one_of(st.sampled_from(NASTY), st.text(max_size=8)),
    ),
    min_size=1,
    max_size=4,
)


def _parse_quietly(name: str, text: str) -> None:
    reader = parse_ies if name.endswith(".ies") else parse_ldt
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for parse in (reader, parse_photometry):
            try:
                photometry = parse(text, source=name)
            except PhotometryError as exc:
                assert name in str(exc) and "\n" not in str(exc).strip()
                continue
            # What parses is a usable table: finite candela and flux.
            assert np.isfinite(photometry.candela).all()
            assert np.isfinite(photometry.luminous_flux())


@pytest.mark.parametrize("name", PHOTOMETRIC)
def test_bundled_files_parse(name: str) -> None:
    _parse_quietly(name, FILES[name])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(PHOTOMETRIC), ops=operations)
def test_mutated_files_raise_only_photometry_errors(name: str, ops) -> None:
    _parse_quietly(name, _mutate(FILES[name], ops))


@settings(max_examples=60, deadline=None)
@given(text=st.text(max_size=300))
def test_arbitrary_text_raises_only_photometry_errors(text: str) -> None:
    _parse_quietly("garbage.ies", text)
    _parse_quietly("garbage.ldt", text)


@pytest.mark.parametrize(
    ("name", "token", "expected"),
    [
        ("aec_maxwell_8_t4.ies", "1e308", "luminous flux would not be a finite"),
        ("aec_maxwell_8_t4.ies", "inf", "must be finite"),
        ("road_luminaire_son_tpp_250w.ldt", "1e308", "not a finite number"),
        ("road_luminaire_son_tpp_250w.ldt", "nan", "must be finite"),
    ],
)
def test_huge_or_non_finite_candela_is_one_line_naming_file_and_line(
    name: str, token: str, expected: str
) -> None:
    lines = FILES[name].splitlines()
    last = len(lines) - 1
    while not lines[last].strip():
        last -= 1
    words = lines[last].split()
    words[0] = token  # a candela value: the tables end every file
    lines[last] = " ".join(words)
    reader = parse_ies if name.endswith(".ies") else parse_ldt
    with pytest.raises(PhotometryError, match=expected) as info:
        reader("\n".join(lines) + "\n", source=name)
    assert f"{name}, line {last + 1}" in str(info.value)


def test_implausible_flux_is_a_warning() -> None:
    text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 10\n0 180\n0\n1e8 1\n"
    with pytest.warns(UserWarning, match="implausible for one luminaire"):
        photometry = parse_ies(text, source="bright.ies")
    assert photometry.luminous_flux() > 1e8
