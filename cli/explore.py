"""``nightlights explore``: the forward and inverse tools in the browser, on a local server."""

from __future__ import annotations

import click

from .options import (
    dem_option,
    kernel_option,
    observer_height_option,
    one_of,
    scene_of,
    turbidity_option,
)
from .resources import max_memory_option

#: Options that a session file (``--session``) fixes.
SESSION_FIXES = ("lights", "streets", "kernel", "dem", "observer_height", "turbidity")


@click.command("explore")
@click.argument("emission", required=False, type=click.Path(exists=True, dir_okay=False))
@click.option(
    "--lights",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="The light points (nightlights streets place) to show on the map.",
)
@click.option(
    "--streets",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="The street layer the --lights light: its segments' compliance with their lighting "
    "classes on the map, and a plan that keeps them lit (needs --lights).",
)
@kernel_option
@dem_option
@observer_height_option
@turbidity_option
@click.option(
    "--session",
    "session_file",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Open a saved session (written by the page's export); it names the emission.",
)
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on.")
@click.option(
    "--port",
    type=click.IntRange(0, 65535),
    default=8765,
    show_default=True,
    help="Port to listen on (0: a free one).",
)
@click.option("--no-browser", is_flag=True, help="Do not open the page in a browser.")
@click.option(
    "--tiles",
    default=None,
    metavar="URL",
    help="Background map tiles for the page, e.g. https://tile.openstreetmap.org/{z}/{x}/{y}.png "
    "(default: none, nothing is fetched from the internet).",
)
@click.option(
    "--export-dir",
    type=click.Path(exists=True, file_okay=False, writable=True),
    default=".",
    show_default=True,
    help="Folder the page's exports are written to (the only place it writes).",
)
@click.pass_context
@max_memory_option
def explore(
    ctx: click.Context,
    emission: str | None,
    lights: str | None,
    streets: str | None,
    kernel: str | None,
    dem: str | None,
    observer_height: float,
    turbidity: float | None,
    session_file: str | None,
    host: str,
    port: int,
    no_browser: bool,
    tiles: str | None,
    export_dir: str,
) -> None:
    """Explore EMISSION [lm m-2] in the browser: panoramas, Q/S maps, dimming, edits; with
    --streets, road compliance and a dimming plan that keeps the roads lit.

    Serves the page on HOST:PORT until Ctrl-C. The server holds one shared session: every tab
    sees the same edits. On an address other than loopback anyone who reaches it can edit the
    session and write files into --export-dir.
    """
    from nightlights.errors import InputError
    from nightlights.explore import _app
    from nightlights.explore._session import ExploreSession

    if one_of(ctx, EMISSION=emission, **{"--session": session_file}) is None:
        raise click.UsageError("give EMISSION or --session FILE", ctx)
    if session_file is not None:
        fixed = [
            f"--{name.replace('_', '-')}"
            for name in SESSION_FIXES
            if ctx.get_parameter_source(name) is not click.core.ParameterSource.DEFAULT
        ]
        if fixed:
            raise click.UsageError(f"{', '.join(fixed)}: the session file fixes these", ctx)
    if tiles is not None and not tiles.startswith(("https://", "http://")):
        raise InputError(f"--tiles {tiles!r}: expected an http(s) URL with {{z}}, {{x}}, {{y}}")
    # listen first: a port in use is refused before the session is loaded (which may take long)
    sock = _app.bind(host, port)
    try:
        if session_file is not None:
            session = ExploreSession.open(session_file)
        else:
            assert emission is not None  # one of the two, checked above
            session = ExploreSession(
                scene_of(emission, dem=dem, kernel=kernel, turbidity=turbidity),
                lights=lights,
                streets=streets,
                height=observer_height,
            )
        url = _app.browser_url(host, sock.getsockname()[1])
        if not _app.is_loopback(host):
            click.echo(
                f"Warning: listening on {host}, not loopback: anyone who can reach this machine "
                f"can edit the session and write files into {export_dir}",
                err=True,
            )
        click.echo(f"nightlights explore: {url} (Ctrl-C to stop)")
        _app.serve(
            session,
            host=host,
            port=sock.getsockname()[1],
            open_browser=not no_browser,
            export_dir=export_dir,
            tiles=tiles,
            sock=sock,
        )
    finally:
        sock.close()


commands = [explore]
