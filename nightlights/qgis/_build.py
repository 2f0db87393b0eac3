"""Build the QGIS plugin zip: the plugin's sources, the path of this toolkit's command and the
description of the stage commands the plugin makes its algorithms from."""

from __future__ import annotations

import os
import shutil
import sysconfig
import zipfile
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from nightlights.errors import InputError
from nightlights.io.atomic import atomic_output
from nightlights.io.jsonfile import dumps_json
from nightlights.qgis.plugin.runner import TOOLKIT_FILE
from nightlights.qgis.plugin.stages import STAGES_FILE

#: Folder (and Python package) name of the plugin inside the zip and in QGIS's plugin folder.
PLUGIN_FOLDER = "nightlights_processing"
#: The plugin's files, from the ``nightlights.qgis.plugin`` package (nothing else is zipped).
PLUGIN_FILES = (
    "__init__.py",
    "plugin.py",
    "provider.py",
    "base.py",
    "algorithms.py",
    "runner.py",
    "messages.py",
    "stages.py",
    "metadata.txt",
)


def toolkit_command() -> Path:
    """The ``nightlights`` executable of this Python environment.

    The console script in the environment's scripts folder (a virtual environment's ``bin``),
    else the first on ``PATH``.

    Raises
    ------
    InputError
        No ``nightlights`` command is installed (the toolkit was not installed with pip).
    """
    name = "nightlights.exe" if os.name == "nt" else "nightlights"
    script = Path(sysconfig.get_path("scripts")) / name
    if script.is_file():
        return script
    found = shutil.which("nightlights")
    if found:
        return Path(found)
    raise InputError(
        f"no nightlights command in {script.parent} or on PATH; install the toolkit with pip "
        "(pip install .) so that the plugin has a command to run, or give command="
    )


def plugin_command(command: str | os.PathLike[str] | None = None) -> Path:
    """The absolute path of the executable the plugin is to run.

    Parameters
    ----------
    command
        A path (relative to the working folder or absolute) or, without a folder part, a
        command name looked up on ``PATH``; None: :func:`toolkit_command`.

    Returns
    -------
    pathlib.Path
        The absolute path (QGIS starts the plugin's command from its own working folder, where
        a relative path means nothing).

    Raises
    ------
    InputError
        ``command`` is not an existing file, or not executable.
    """
    if command is None:
        return Path(os.path.abspath(toolkit_command()))
    given = Path(command).expanduser()
    if not given.exists() and len(given.parts) == 1:
        found = shutil.which(str(given))
        given = Path(found) if found else given
    executable = Path(os.path.abspath(given))
    if not executable.is_file():
        raise InputError(
            f"command {str(command)!r} ({executable}) is not a file; expected the nightlights "
            "executable"
        )
    if not os.access(executable, os.X_OK):
        raise InputError(
            f"command {str(command)!r} ({executable}) is not executable (no execute "
            "permission); expected the nightlights executable"
        )
    return executable


def plugin_metadata(version: str) -> str:
    """The plugin's ``metadata.txt`` with its ``version`` line set to ``version``.

    Parameters
    ----------
    version
        The toolkit's version (the plugin is built for it).
    """
    source = resources.files("nightlights.qgis.plugin") / "metadata.txt"
    lines = source.read_text(encoding="utf-8").splitlines()
    return "\n".join(
        f"version={version}" if line.startswith("version=") else line for line in lines
    )


def build_plugin(
    output: str | os.PathLike[str],
    stages: Sequence[Mapping[str, Any]],
    *,
    command: str | os.PathLike[str] | None = None,
    overwrite: bool = False,
) -> Path:
    """Write the QGIS plugin zip (QGIS: Plugins > Install from ZIP).

    The zip holds one folder, :data:`PLUGIN_FOLDER`, with the plugin's sources,
    ``toolkit.json``, which records ``command``: the plugin's algorithms run it in a
    subprocess (QGIS's Python does not import the toolkit), and ``stages.json``, the
    description of the stage commands that the plugin makes one algorithm of each. A
    ``nightlights`` command set in QGIS (Processing > Options > Providers > nightlights) or in
    ``$NIGHTLIGHTS_COMMAND`` takes precedence over the recorded one.

    Parameters
    ----------
    output
        Path of the zip.
    stages
        The description of the stage commands, JSON-ready (what
        ``nightlights_cli.describe.describe_stages`` gives for the ``nightlights`` command).
    command
        The ``nightlights`` executable to record, as an absolute path
        (:func:`plugin_command`; default: :func:`toolkit_command`).
    overwrite
        Replace an existing zip.

    Returns
    -------
    pathlib.Path
        ``output``.

    Raises
    ------
    InputError
        ``command`` is not an existing executable file, or no command is installed.
    OutputError
        ``output`` exists and ``overwrite`` is False, or cannot be written.
    """
    from nightlights import __version__

    executable = plugin_command(command)
    record = {"command": str(executable), "version": __version__}
    description = dumps_json({"version": __version__, "stages": list(stages)}, indent=1)
    package = resources.files("nightlights.qgis.plugin")
    with atomic_output(output, overwrite=overwrite, inputs={"command": executable}) as temporary:
        with zipfile.ZipFile(temporary, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            for name in PLUGIN_FILES:
                text = (
                    plugin_metadata(__version__)
                    if name == "metadata.txt"
                    else (package / name).read_text(encoding="utf-8")
                )
                archive.writestr(f"{PLUGIN_FOLDER}/{name}", text)
            archive.writestr(f"{PLUGIN_FOLDER}/{TOOLKIT_FILE}", dumps_json(record, indent=2) + "\n")
            archive.writestr(f"{PLUGIN_FOLDER}/{STAGES_FILE}", description + "\n")
    return Path(output)
