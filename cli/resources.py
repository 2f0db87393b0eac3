"""Options about the machine a command runs on: the Dask scheduler and the memory limit.

``--scheduler`` (:class:`SchedulerText`) takes the address of a ``dask.distributed`` scheduler,
or for ``sky observers`` the name of a local scheduler; a malformed value is a usage error
(exit status 2), and whether a scheduler answers there the stage checks before any work.

``--max-memory`` is an option of the ``nightlights`` group (for every command) and, as
:data:`max_memory_option`, of each command that can allocate a lot, so that it may follow the
command's name (``nightlights darkness ... --max-memory 2G``): the limit holds for that
command, in place of the group's; stages refuse an estimate above it before they allocate
(:mod:`nightlights._resources`).
"""

from __future__ import annotations

import functools
from typing import Any

import click

from .library import FromLibrary
from .options import MemorySize


class SchedulerText(click.ParamType):
    """A Dask scheduler: a ``dask.distributed`` scheduler address, or where ``local`` is given
    one of the library's local schedulers, parsed by the library
    (:func:`nightlights._parallel.check_scheduler`). A malformed value is a usage error (exit
    status 2); whether a scheduler answers at the address the stage checks before any work."""

    name = "scheduler"

    def __init__(self, local: FromLibrary | None = None) -> None:
        self.local = local

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from nightlights._parallel import check_scheduler
        from nightlights.errors import InputError

        names = tuple(self.local()) if self.local is not None else ()
        try:
            return check_scheduler(value, local=names, connect=False)
        except InputError as exc:
            # the command line cannot pass a Client
            self.fail(str(exc).removeprefix("scheduler=").replace(" or a Client", ""), param, ctx)


scheduler_option = click.option(
    "--scheduler",
    default=None,
    type=SchedulerText(),
    metavar="ADDRESS",
    help="dask.distributed scheduler address; default: local threads.",
)


def _set_memory_limit(ctx: click.Context, param: click.Parameter, value: int | None) -> None:
    """Set the memory limit for this command when ``--max-memory`` follows it; the previous
    limit (the group's, or none) comes back when the command ends."""
    if value is None:
        return
    from nightlights import _resources

    ctx.call_on_close(functools.partial(_resources.set_memory_limit, _resources._override))
    _resources.set_memory_limit(value)


#: ``--max-memory`` of one command (the group's option, where it may also stand, is in
#: ``nightlights_cli.main``).
max_memory_option = click.option(
    "--max-memory",
    type=MemorySize(),
    default=None,
    metavar="SIZE",
    expose_value=False,
    callback=_set_memory_limit,
    help="Memory this command may use (8G, 500M, 2e9 bytes); a larger estimate is refused "
    "before any work. Default: nightlights --max-memory, else $NIGHTLIGHTS_MAX_MEMORY, else "
    "half the machine's memory.",
)
