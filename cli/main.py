"""Entry point of the ``nightlights`` command.

One module per command, named after it, each exposing ``commands`` (click commands or groups);
this module only builds the group, sets up logging and the memory limit, and reports failures
in one line on stderr instead of a traceback:

- usage errors (a bad option value, a missing input): click's message, exit status 2;
- errors of the toolkit (``NightlightsError``, ``BayesNetError``, ``PhotometryError``), their
  Python parameters written as the command's flags (:mod:`nightlights_cli._messages`), and the
  user's mistakes that surface as other libraries' exceptions (a file or folder that cannot be
  read or written, an unknown CRS, too little memory, a dask scheduler that cannot be reached):
  ``Kind: message``, exit status 1;
- anything else (a bug): the same line with "run with -v for the traceback", exit status 1.

With ``-v`` the traceback is printed before the line. The command modules import only click at
import time, so that ``nightlights --help`` does not load the library.
"""

from __future__ import annotations

import functools
import importlib
import logging
import sys
import warnings
from typing import Any

import click

from nightlights import __version__

from ._messages import to_flags
from .options import MemorySize, require_finite_floats

#: Modules of this package that each expose ``commands``: a list of click commands or groups.
COMMAND_MODULES = (
    ".streets",
    ".irradiance",
    ".emission",
    ".obstacles",
    ".kernel",
    ".skyglow",
    ".inverse",
    ".darkness",
    ".photometry",
    ".demo",
    ".run",
    ".init",
    ".explore",
    ".sky",
    ".validate",
    ".qgis",
)


def domain_errors() -> tuple[type[Exception], ...]:
    """The exception roots of the project's packages (reported in one line)."""
    from bayesnets.errors import BayesNetError
    from ies.errors import PhotometryError
    from nightlights.errors import NightlightsError

    return (NightlightsError, BayesNetError, PhotometryError)


def _crs_errors() -> tuple[type[Exception], ...]:
    """CRS errors of pyproj and rasterio (a garbage ``--crs``), when they are loaded."""
    found: list[type[Exception]] = []
    for module_name in ("pyproj.exceptions", "rasterio.errors"):
        module = sys.modules.get(module_name)
        error = getattr(module, "CRSError", None)
        if isinstance(error, type) and issubclass(error, Exception):
            found.append(error)
    return tuple(found)


MEMORY_HINT = (
    "ask for less (a coarser --resolution, smaller grids, fewer candidates) or set "
    "--max-memory / NIGHTLIGHTS_MAX_MEMORY below the free memory so that stages refuse such "
    "requests up front"
)


def one_line(text: str) -> str:
    """``text`` with its lines joined by spaces (messages of other libraries may span lines)."""
    return " ".join(part.strip() for part in str(text).splitlines() if part.strip())


def describe(exc: BaseException, command: click.Command | None = None) -> str:
    """The one-line report of ``exc`` (a bug's report asks for ``-v``); the toolkit's messages
    name the flags of ``command`` (and of the others) where the library names its parameters.

    Examples
    --------
    >>> describe(FileNotFoundError(2, "No such file or directory", "in.tif"))
    "FileNotFoundError: [Errno 2] No such file or directory: 'in.tif'"
    >>> describe(ZeroDivisionError("division by zero"))
    'ZeroDivisionError: division by zero (unexpected error; run with -v for the traceback)'
    """
    kind = type(exc).__name__
    if isinstance(exc, domain_errors()):
        return f"{kind}: {to_flags(str(exc), cli, command)}"
    crs_errors = _crs_errors()
    if crs_errors and isinstance(exc, crs_errors):
        return f"CRSError: {one_line(str(exc))}; expected e.g. EPSG:3067 or a WKT/PROJ string"
    if isinstance(exc, MemoryError):
        detail = one_line(str(exc)) or "out of memory"
        return f"MemoryError: {detail}; {MEMORY_HINT}"
    if isinstance(exc, OSError):
        return f"{kind}: {one_line(str(exc)) or 'input/output error'}"
    detail = one_line(str(exc))
    return (
        f"{kind}: {detail}{' ' if detail else ''}(unexpected error; run with -v for the traceback)"
    )


#: Key of ``ctx.meta`` (shared by every context of one run) naming the command that runs.
RUNNING = "nightlights.command"


class NightlightsContext(click.Context):
    """A context that records its command in ``meta`` (shared by the whole run), so that the
    group's error report knows the innermost command that ran."""

    def __init__(self, command: click.Command, *args: Any, **kwargs: Any) -> None:
        super().__init__(command, *args, **kwargs)
        self.meta[RUNNING] = command


def use_context(command: click.Command) -> None:
    """Give ``command`` and every command under it a :class:`NightlightsContext`."""
    command.context_class = NightlightsContext
    if isinstance(command, click.Group):
        for sub in command.commands.values():
            use_context(sub)


def running_command() -> click.Command | None:
    """The innermost command of the current run, if one runs."""
    ctx = click.get_current_context(silent=True)
    return None if ctx is None else ctx.meta.get(RUNNING)


class NightlightsGroup(click.Group):
    """A click group that reports errors in one line (a traceback too with ``-v``)."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except (click.exceptions.ClickException, click.exceptions.Exit, click.exceptions.Abort):
            raise
        except Exception as exc:
            message = describe(exc, ctx.meta.get(RUNNING))
            if ctx.params.get("verbose"):
                import traceback

                click.echo("".join(traceback.format_exception(exc)).rstrip(), err=True)
            raise click.ClickException(message) from exc


def _log_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: Any = None,
    line: str | None = None,
) -> None:
    """Show a warning as one log line, ``Category: message``, the library's parameters written
    as flags."""
    text = to_flags(str(message), cli, running_command())
    logging.getLogger("py.warnings").warning("%s: %s", category.__name__, text)


@click.group(cls=NightlightsGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="nightlights")
@click.option("-v", "--verbose", count=True, help="More detail (repeat for debug); tracebacks.")
@click.option("-q", "--quiet", is_flag=True, help="Only errors.")
@click.option(
    "--max-memory",
    type=MemorySize(),
    default=None,
    metavar="SIZE",
    help="Memory a stage may use (8G, 500M, 2e9 bytes); a stage whose estimate is larger "
    "refuses to start. Default: $NIGHTLIGHTS_MAX_MEMORY, else half the machine's memory.",
)
@click.pass_context
def cli(ctx: click.Context, verbose: int, quiet: bool, max_memory: int | None) -> None:
    """Night-time lighting: streetlights, irradiance, emission and skyglow.

    Commands that write a product take INPUT... OUTPUT (or -o/--output OUTPUT) and refuse to
    replace an existing output unless --overwrite is given. Errors are one line on stderr with
    exit status 1 (2 for usage errors); -v adds the traceback.
    """
    from nightlights import _resources

    level = (
        logging.ERROR if quiet else (logging.WARNING, logging.INFO, logging.DEBUG)[min(verbose, 2)]
    )
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    # warning filters and display hold for this command only (restored when it closes)
    ctx.with_resource(warnings.catch_warnings())
    if verbose:
        logging.captureWarnings(True)
    else:
        warnings.showwarning = _log_warning
    if quiet:
        warnings.simplefilter("ignore")
    # --max-memory holds for this command only (the group may run again in the same process)
    ctx.call_on_close(functools.partial(_resources.set_memory_limit, _resources._override))
    _resources.set_memory_limit(max_memory)
    _resources.memory_limit()  # a malformed NIGHTLIGHTS_MAX_MEMORY is reported before any work


for _module_name in COMMAND_MODULES:
    for _command in importlib.import_module(_module_name, __package__).commands:
        cli.add_command(_command)
require_finite_floats(cli)
use_context(cli)


def main() -> None:
    """Console-script entry point."""
    sys.exit(cli.main(standalone_mode=True))
