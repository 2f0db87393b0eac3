"""The progress bars of long loops: what they show, the same for every stage.

A bar shows its description, the bar, ``done/total``, the elapsed time and, for loops whose
steps cost about the same (tiles, chunks, windows), the estimated time left after ``eta``.
The QGIS plugin reads both from the command's redraws
(:func:`nightlights.qgis.plugin.runner.parse_progress` and
:func:`~nightlights.qgis.plugin.runner.parse_remaining`), so the columns' form is part of the
interface: ``M/N H:MM:SS`` then ``eta H:MM:SS`` (``-:--:--`` until it is known).
"""

from __future__ import annotations

from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

__all__ = ["progress_bar"]


def progress_bar(enabled: bool, *, eta: bool = True) -> Progress:
    """A transient rich progress bar, disabled when ``enabled`` is False.

    Parameters
    ----------
    enabled
        Draw the bar (False: a silent ``Progress`` that counts nothing on screen).
    eta
        Add the estimated time left (``eta H:MM:SS``) after the elapsed time.

    Examples
    --------
    >>> with progress_bar(False) as bar:
    ...     task = bar.add_task("tiles", total=4)
    ...     bar.advance(task)
    >>> int(bar.tasks[0].completed)
    1
    """
    columns = [
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    ]
    if eta:
        columns += [TextColumn("eta"), TimeRemainingColumn()]
    return Progress(*columns, transient=True, disable=not enabled)
