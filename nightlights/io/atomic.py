"""Atomic writes: a temporary file beside the target, renamed into place on success."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

from nightlights.io.outputs import Inputs, OutputSet


@contextlib.contextmanager
def atomic_output(
    path: str | os.PathLike[str], *, overwrite: bool = True, inputs: Inputs | None = None
) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds.

    If the block raises, is interrupted (Ctrl-C) or the process receives ``SIGTERM``, the
    temporary file and the side files a writer left beside it (GDAL's ``.ovr.tmp``,
    ``.aux.xml``) are removed and ``path`` is left as it was, so a crash never leaves a
    half-written output that looks done. This is an :class:`~nightlights.io.OutputSet` of one
    file; use that class for a stage with several outputs.

    Parameters
    ----------
    path
        Final output path.
    overwrite
        Replace an existing file at ``path``. If False an existing file is an error.
    inputs
        The inputs the file is made from, by name; ``path`` must not be one of them
        (:func:`~nightlights.io.outputs.refuse_replacing_inputs`).

    Yields
    ------
    pathlib.Path
        Temporary path with the same suffix as ``path``, in the same directory.

    Raises
    ------
    OutputError
        The folder does not exist or cannot be written to (permission denied, read-only),
        ``path`` is a folder, an input, or exists with ``overwrite=False``, or the block
        wrote no file.
    """
    with OutputSet(path, overwrite=overwrite, inputs=inputs) as outputs:
        yield outputs.temporary(path)
