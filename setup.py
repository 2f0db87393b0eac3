"""Packages of the distribution ``nightlights-gis`` (its metadata: ``pyproject.toml``).

setuptools' ``packages.find`` does not rename a folder, so the packages are listed here: those
found under ``nightlights/``, ``bayesnets/`` and ``ies/``, and the command-line package
``nightlights_cli``, which ``[tool.setuptools.package-dir]`` maps to the folder ``cli/`` (so no
top-level module named ``cli`` is installed).
"""

from setuptools import find_namespace_packages, setup

TOP_LEVEL = ("nightlights", "bayesnets", "ies")

setup(
    packages=[
        *find_namespace_packages(
            include=[f"{name}{tail}" for name in TOP_LEVEL for tail in ("", ".*")]
        ),
        "nightlights_cli",
    ]
)
