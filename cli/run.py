"""``nightlights run``: every stage of a project file, skipping those already up to date."""

from __future__ import annotations

from typing import Any

import click

from .kinds import FOLDER, file_kind
from .options import PROJECT_STAGES, LibraryHelpOption, files_argument, output_option, resolve_inout
from .resources import max_memory_option


@click.command("run")
@files_argument("PROJECT.toml [OUTPUT]", file_kind("toml"), FOLDER)
@output_option
@click.option(
    "--force",
    cls=LibraryHelpOption,
    multiple=True,
    metavar="STAGE",
    help="Rerun STAGE and every stage downstream of it even if up to date (repeat). "
    "Stages: {stages}.",
    help_values={"stages": PROJECT_STAGES},
)
@click.option(
    "--check",
    "check_only",
    is_flag=True,
    help="Check the project file and list which stages would run; run nothing.",
)
@max_memory_option
def run_command(
    files: tuple[str, ...], output: str | None, force: tuple[str, ...], check_only: bool
) -> None:
    """Run the stages of PROJECT.toml (nightlights init writes a commented template) into the
    folder OUTPUT (default: the project's [project] output, relative to the file).

    The whole file is checked before any stage runs. A stage whose outputs exist and whose
    inputs and options are unchanged since it last ran (content hashes recorded beside the
    outputs) is skipped; an interrupted run leaves no output that looks complete.
    """
    from rich.console import Console
    from rich.markup import escape

    from nightlights.project import check, run

    usage = "PROJECT.toml [OUTPUT]"
    if output is None and len(files) == 1:
        project = files[0]
    else:
        inputs, output = resolve_inout(files, output, inputs=1, usage=usage, overwrite=True)
        project = inputs[0]
    console = Console(stderr=True, emoji=False, highlight=False, soft_wrap=True)
    if check_only:
        plan = check(project, output, force=force)
        for name, up_to_date in plan:
            console.print(f"  {'up to date' if up_to_date else 'runs':>10}  {name}", markup=False)
        runs = sum(not up for _, up in plan)
        console.print(f"{project}: valid; {runs} of {len(plan)} stages would run", markup=False)
        return

    def on_task(name: str, event: str, seconds: float) -> None:
        if name == "kernel" and event == "start":
            console.print("  [bold]kernel[/] ... (built once, then read from the cache)")
        elif event == "start":
            console.print(f"  [bold]{escape(name)}[/] ...")
        elif event == "ran":
            console.print(f"  {name}: {seconds:.1f} s", markup=False)
        else:
            console.print(f"  {name}: up to date", markup=False)

    result = run(project, output, force=force, on_task=on_task)
    print_outputs(console, result)
    console.print(
        f"ran {len(result.ran)}, up to date {len(result.cached)} in {result.seconds:.1f} s; "
        f"outputs in {result.folder}",
        markup=False,
    )


def print_outputs(console: Any, result: Any) -> None:
    """The outputs, zenith figures and findings of a project run, one line each."""
    width = max((len(name) for name in result.outputs), default=0)
    for name, path in result.outputs.items():
        console.print(f"  {name:>{width}}: {path}", soft_wrap=True, markup=False)
    for name, (magnitude, bortle) in result.zenith.items():
        console.print(
            f"  zenith sky at {name}: {magnitude:.2f} mag arcsec-2 from the artificial light "
            f"alone (Bortle {bortle})",
            soft_wrap=True,
            markup=False,
        )
    for line in result.findings:
        console.print(f"  {line}", soft_wrap=True, markup=False)


commands = [run_command]
