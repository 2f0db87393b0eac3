"""Shared fixtures for the ies tests: paths to the bundled real photometric files."""

from __future__ import annotations

from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "data" / "ies"
ALL_FILES = sorted(p for p in DATA.rglob("*") if p.suffix.lower() in (".ies", ".ldt"))


def data_file(name: str) -> Path:
    """The unique bundled file with this name."""
    matches = [p for p in ALL_FILES if p.name == name]
    assert len(matches) == 1, f"{name}: {matches}"
    return matches[0]


@pytest.fixture
def ies_text() -> str:
    """A small, consistent LM-63-2002 file: rotationally symmetric, 0-180 deg, 1 cd."""
    return (
        "IESNA:LM-63-2002\n[TEST] unit\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 10\n"
        "0 90 180\n0\n1 1 1\n"
    )
