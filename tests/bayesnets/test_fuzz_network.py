"""Property-based fuzzing of network folders: a mutated catalogue network (``network.toml``
and a CSV table) loads or raises a :class:`~bayesnets.errors.BayesNetError`, nothing else."""

from __future__ import annotations

import shutil
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bayesnets.catalog import catalog_path
from bayesnets.errors import BayesNetError
from bayesnets.network import read_network

SOURCE = catalog_path("europe")
TEXTS = {path.name: path.read_text() for path in SOURCE.iterdir() if path.is_file()}
NASTY = ["", "nan", "inf", "-1", "1e308", "x", "[metadata]", "metadata = 3", "kind = 3", ",,,"]

edits = st.lists(
    st.tuples(
        st.sampled_from(["network.toml", "network.toml", "TILT.csv", "SYSTEM.csv"]),
        st.sampled_from(["delete", "replace", "value"]),
        st.integers(0, 10_000),
        st.one_of(st.sampled_from(NASTY), st.text(max_size=6)),
    ),
    min_size=1,
    max_size=3,
)


def _mutated(folder: Path, changes) -> Path:
    for name, text in TEXTS.items():
        (folder / name).write_text(text)
    for name, kind, where, token in changes:
        lines = (folder / name).read_text().splitlines()
        k = where % len(lines)
        if kind == "delete":
            del lines[k]
        elif kind == "replace":
            lines[k] = token
        else:  # keep the key (TOML) or the first cells (CSV), change the value
            separator = "=" if name.endswith(".toml") else ","
            head, _, _ = lines[k].rpartition(separator)
            lines[k] = f"{head}{separator}{token}" if head else token
        (folder / name).write_text("\n".join(lines) + "\n")
    return folder


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(changes=edits)
def test_mutated_networks_raise_only_bayesnet_errors(changes, tmp_path_factory) -> None:
    folder = _mutated(tmp_path_factory.mktemp("net"), changes)
    try:
        network = read_network(folder)
    except BayesNetError as exc:
        assert "\n" not in str(exc).strip()
    else:
        assert network.variables
    finally:
        shutil.rmtree(folder)


def test_unmutated_copy_loads(tmp_path: Path) -> None:
    assert read_network(_mutated(tmp_path, [])).name == "europe"
