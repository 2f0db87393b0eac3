"""Catalogue of geo-typical street-lighting networks shipped with the package.

Each sub-folder is a network (CSV tables + ``network.toml``); ``README.md`` gives the
source of every number. Chuang 2011 (Sec. 3.3) envisions such a catalogue of networks
"that can be selected by users at run-time".
"""

from __future__ import annotations

import os
import tomllib
from importlib import resources
from pathlib import Path

from bayesnets.errors import CatalogError
from bayesnets.network import CONFIG_NAME, BayesNet, read_network


def _root() -> Path:
    return Path(str(resources.files("bayesnets.catalog")))


def catalog_names() -> list[str]:
    """Names of the catalogue networks, sorted."""
    return sorted(
        entry.name
        for entry in _root().iterdir()
        if entry.is_dir() and (entry / CONFIG_NAME).exists()
    )


def default_network_name() -> str:
    """Name of the catalogue network whose ``network.toml`` says ``default = true``."""
    for name in catalog_names():
        config = tomllib.loads((_root() / name / CONFIG_NAME).read_text(encoding="utf-8"))
        if config.get("default"):
            return name
    raise CatalogError(f"no catalogue network is marked default in {_root()}")


def catalog_path(name: str) -> Path:
    """Folder of the catalogue network ``name``.

    Raises
    ------
    CatalogError
        ``name`` is not in the catalogue (the message lists the names).
    """
    if name not in catalog_names():
        raise CatalogError(
            f"unknown network {name!r}; catalogue networks: {', '.join(catalog_names())} "
            "(or give a network folder)"
        )
    return _root() / name


def load_network(network: str | os.PathLike[str] | None = None) -> BayesNet:
    """Load a catalogue network by name, or a network folder by path.

    Parameters
    ----------
    network
        Catalogue name (e.g. ``"europe"``), a folder path, or None for the default.

    Raises
    ------
    CatalogError
        A name that is neither a catalogue network nor an existing folder.
    """
    if network is None:
        return read_network(catalog_path(default_network_name()))
    if isinstance(network, str) and network in catalog_names():
        return read_network(catalog_path(network))
    folder = Path(network)
    if folder.is_dir():
        return read_network(folder)
    raise CatalogError(
        f"unknown network {str(network)!r}: neither a catalogue network "
        f"({', '.join(catalog_names())}) nor a network folder"
    )
