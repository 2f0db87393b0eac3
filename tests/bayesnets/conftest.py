"""Small networks shared by the bayesnets tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from bayesnets import BayesNet, build_network, parse_table, read_network

#: A four-variable network: A -> B, (A, B) -> C, C -> D. Weights are chosen so that
#: evidence on D has hidden ancestors (A, B, C) and some combinations are impossible.
TOY_TABLES = {
    "A.csv": "A,weight\na0,5\na1,3\na2,2\n",
    "B.csv": "B,A,weight\nb0,a0,4\nb1,a0,1\nb0,a1,1\nb1,a1,1\nb0,a2,1\nb1,a2,4\n",
    "C.csv": (
        "C,A,B,weight\n"
        "c0,a0,b0,6\nc1,a0,b0,3\nc2,a0,b0,1\n"
        "c0,a0,b1,1\nc1,a0,b1,1\nc2,a0,b1,8\n"
        "c0,a1,b0,2\nc1,a1,b0,6\nc2,a1,b0,2\n"
        "c0,a1,b1,3\nc1,a1,b1,3\nc2,a1,b1,4\n"
        "c0,a2,b0,0\nc1,a2,b0,1\nc2,a2,b0,9\n"
        "c0,a2,b1,5\nc1,a2,b1,0\nc2,a2,b1,5\n"
    ),
    "D.csv": "D,C,weight\nT,c0,9\nF,c0,1\nT,c1,5\nF,c1,5\nT,c2,0\nF,c2,1\n",
}

TOY_CONFIG = """
name = "toy"
description = "test network"

[variables.A]
field = "a"
kind = "category"

[variables.C]
field = "c"
kind = "category"

[variables.D]
field = "d"
kind = "bool"
"""


def write_folder(folder: Path, tables: dict[str, str], config: str | None = None) -> Path:
    """Write CSV tables (and network.toml) into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in tables.items():
        (folder / name).write_text(text)
    if config is not None:
        (folder / "network.toml").write_text(config)
    return folder


@pytest.fixture
def toy_folder(tmp_path: Path) -> Path:
    return write_folder(tmp_path / "toy", TOY_TABLES, TOY_CONFIG)


@pytest.fixture
def toy(toy_folder: Path) -> BayesNet:
    return read_network(toy_folder)


def toy_network() -> BayesNet:
    """The toy network without files (for hypothesis tests)."""
    import tomllib

    return build_network(
        [parse_table(text, source=name) for name, text in TOY_TABLES.items()],
        tomllib.loads(TOY_CONFIG),
    )
