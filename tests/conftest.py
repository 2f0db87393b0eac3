"""Shared fixtures."""

from __future__ import annotations

import contextlib
import os
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

DATA = Path(__file__).parent / "data"


@pytest.fixture
def data_dir() -> Path:
    """The folder of test data files (see tests/data/README.md)."""
    return DATA


@contextlib.contextmanager
def _read_only(folder: Path) -> Iterator[Path]:
    """Make ``folder`` unwritable for this process (chmod, or ``chattr +i`` for root)."""
    folder.mkdir(exist_ok=True)
    folder.chmod(0o555)
    immutable = False
    try:
        if os.access(folder, os.W_OK):  # root ignores the mode bits
            done = subprocess.run(["chattr", "+i", str(folder)], capture_output=True)
            immutable = done.returncode == 0
        try:
            (folder / ".probe").write_text("")
        except OSError:
            yield folder
        else:
            (folder / ".probe").unlink()
            pytest.skip("cannot make a folder read-only here")
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(folder)], check=True)
        folder.chmod(0o755)


@pytest.fixture
def read_only() -> Callable[[Path], contextlib.AbstractContextManager[Path]]:
    """A context manager that makes a folder unwritable for this process (skips if it cannot)."""
    return _read_only
