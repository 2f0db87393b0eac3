"""What the paths of the commands name: a raster, a vector layer (of which geometry), a file (of
which extensions) or a folder.

Each path says it once, where it is declared: the positional ``INPUT... OUTPUT`` paths in
:func:`~nightlights_cli.options.files_argument` (one kind per word of the usage), a path option
in its type (:class:`KindPath`). The commands' own parsing does not read it; the description
of the commands that the QGIS plugin is built from (:mod:`nightlights_cli.describe`) does, to
offer a raster layer, a vector layer, a file or a folder for each path.

This module imports only click (``nightlights --help`` stays fast).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import click

Kind = Literal["raster", "vector", "file", "folder"]
Geometry = Literal["point", "line", "polygon"]


@dataclass(frozen=True)
class PathKind:
    """What a path names.

    Parameters
    ----------
    kind
        ``raster`` (a GDAL raster; written as a GeoTIFF), ``vector`` (a GIS vector layer;
        written as a GeoPackage), ``file`` (any other file) or ``folder``.
    geometry
        The geometry of a vector layer's features (None: any).
    extensions
        The extensions a file takes, without the dot (empty: any).
    """

    kind: Kind
    geometry: Geometry | None = None
    extensions: tuple[str, ...] = ()


RASTER = PathKind("raster")
LINES = PathKind("vector", "line")
POINTS = PathKind("vector", "point")
POLYGONS = PathKind("vector", "polygon")
FOLDER = PathKind("folder")


def file_kind(*extensions: str) -> PathKind:
    """A file with one of ``extensions`` (without the dot)."""
    return PathKind("file", extensions=tuple(extensions))


#: A kernel or panorama NetCDF, a PNG picture, a JSON summary.
NETCDF = file_kind("nc")
PNG = file_kind("png")
JSON = file_kind("json")


class KindPath(click.Path):
    """A :class:`click.Path` option type that says what the path names (``kind``); the other
    arguments are :class:`click.Path`'s (``exists=True``: an input, else an output)."""

    def __init__(self, kind: PathKind, **options: Any) -> None:
        super().__init__(**options)
        self.kind = kind


@dataclass(frozen=True)
class FileSlot:
    """One positional path: its name in the usage, whether it may be left out, what it names."""

    name: str
    optional: bool
    kind: PathKind

    @classmethod
    def of(cls, word: str, kind: PathKind) -> FileSlot:
        """The slot of one word of a usage (``[LIGHTS]``: optional; ``PROJECT.toml``: PROJECT).

        Examples
        --------
        >>> FileSlot.of("[LIGHTS]", POINTS).name, FileSlot.of("PROJECT.toml", FOLDER).name
        ('LIGHTS', 'PROJECT')
        """
        optional = word.startswith("[") and word.endswith("]")
        name = word.strip("[]").split(".")[0]
        return cls(name, optional, kind)


class FilesArgument(click.Argument):
    """The positional paths ``INPUT... OUTPUT`` of a command (``nargs=-1``) with what each word
    of the usage names (``kinds``, one per word; the last word is the output)."""

    def __init__(self, *args: Any, kinds: Sequence[PathKind], **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        words = (self.metavar or "").split()
        if len(words) != len(kinds):
            raise ValueError(f"usage {self.metavar!r}: {len(kinds)} kinds for {len(words)} paths")
        self.slots = tuple(FileSlot.of(word, kind) for word, kind in zip(words, kinds, strict=True))
