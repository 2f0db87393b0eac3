"""Options, arguments and helpers shared by the commands, in the manner of rasterio's ``rio``.

Every command that writes a product takes its paths as positional ``INPUT... OUTPUT``; the
output may be given with ``-o/--output`` instead, and then every positional path is an input.
An existing output is never replaced unless ``--overwrite`` is given, and an output that is one
of the command's inputs (a positional input or the file of any other option: ``--dem``,
``--kernel``, ``--by``...; by any path, link or spelling) is refused with or without it
(:func:`refuse_replacing_inputs`): the options that name outputs are listed once, in
:data:`OUTPUT_PARAMETERS`.

Option values are checked here as far as their type allows, before any work starts: a value
of the wrong form (not a number, a negative ``--seed``, a malformed ``--max-memory`` size,
:class:`MemorySize`, a malformed ``--scheduler`` address,
:class:`~nightlights_cli.resources.SchedulerText`) is a usage error (exit status 2); ``nan``
or ``inf`` for any float option (:func:`require_finite_floats`, applied to every command by
``nightlights_cli.main``) and a ``--crs`` or ``--target-crs`` that pyproj cannot read
(:class:`CRSText`) are refused like the library's range checks, with an
``InputError``/``CRSError`` line and exit status 1.

Length: a little over 600 lines, because every option that two commands share is declared here
once (the scene and observer options with the helpers that turn them into a ``Scene`` and an
``Observer``, the streets, kernel and scheduler options), so that no command restates one.

This module imports only click, so that ``nightlights --help`` stays fast. The choices and
defaults that are the library's (a stage's modes, a dataclass's default) are not repeated here:
:class:`~nightlights_cli.library.FromLibrary` names the library's constant, which is read when
a command's help or arguments first need it (``tests/cli/test_options.py`` reads every one).
Each option is declared once, below, with its library parameter's name: the flag is the
parameter with dashes (``observer_crs=`` is ``--observer-crs``), a repeatable option takes the
singular of its list parameter (``--sensor`` for ``sensors=``); an older spelling stays as a
hidden :class:`DeprecatedOption` for one release. Each path says what it names (a raster, a
vector layer, a file, a folder: :mod:`~nightlights_cli.kinds`), for the QGIS plugin.

Length: the options shared by the commands are declared here once each, with the library's
constants they read re-exported one import per name (as the formatter writes them).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import click

from .kinds import NETCDF, RASTER, FilesArgument, KindPath, PathKind
from .library import (
    BUILTIN_MAPPINGS as BUILTIN_MAPPINGS,
)
from .library import (
    DEFAULT_ACROSS_JITTER as DEFAULT_ACROSS_JITTER,
)
from .library import (
    DEFAULT_ALONG_JITTER as DEFAULT_ALONG_JITTER,
)
from .library import (
    DEFAULT_AREA_HEIGHT as DEFAULT_AREA_HEIGHT,
)
from .library import (
    DEFAULT_CANDIDATES as DEFAULT_CANDIDATES,
)
from .library import (
    DEFAULT_CLOUD_OPTICAL_DEPTH as DEFAULT_CLOUD_OPTICAL_DEPTH,
)
from .library import (
    DEFAULT_MAX_DISTANCE as DEFAULT_MAX_DISTANCE,
)
from .library import (
    DEFAULT_MAX_RADIUS as DEFAULT_MAX_RADIUS,
)
from .library import (
    DEFAULT_MERGE_FRACTION as DEFAULT_MERGE_FRACTION,
)
from .library import (
    DEFAULT_SPECTRUM as DEFAULT_SPECTRUM,
)
from .library import (
    DEFAULT_VIIRS_SPECTRUM as DEFAULT_VIIRS_SPECTRUM,
)
from .library import (
    INSTRUMENT_NAMES as INSTRUMENT_NAMES,
)
from .library import (
    IRRADIANCE_BACKENDS as IRRADIANCE_BACKENDS,
)
from .library import (
    KERNEL_BACKENDS as KERNEL_BACKENDS,
)
from .library import (
    KERNEL_PRECISIONS as KERNEL_PRECISIONS,
)
from .library import (
    MULTIPLE_SCATTERING_MODELS as MULTIPLE_SCATTERING_MODELS,
)
from .library import (
    NETWORK_CATALOG as NETWORK_CATALOG,
)
from .library import (
    OBSERVER_SCHEDULERS as OBSERVER_SCHEDULERS,
)
from .library import (
    ON_CONFLICT as ON_CONFLICT,
)
from .library import (
    PLAN_OBJECTIVES as PLAN_OBJECTIVES,
)
from .library import (
    PROJECT_STAGES as PROJECT_STAGES,
)
from .library import (
    PROJECTIONS as PROJECTIONS,
)
from .library import (
    Q_METRICS as Q_METRICS,
)
from .library import (
    S_METHODS as S_METHODS,
)
from .library import (
    S_WEIGHTS as S_WEIGHTS,
)
from .library import (
    SKY_PROJECTIONS as SKY_PROJECTIONS,
)
from .library import (
    SKYGLOW_MODES as SKYGLOW_MODES,
)
from .library import (
    SPECTRA as SPECTRA,
)
from .library import (
    TONE_MODES as TONE_MODES,
)
from .library import (
    FromLibrary as FromLibrary,
)
from .library import (
    LibraryChoice as LibraryChoice,
)
from .library import (
    LibraryHelpOption as LibraryHelpOption,
)
from .library import (
    atmosphere_default as atmosphere_default,
)
from .library import (
    kernel_default as kernel_default,
)

F = TypeVar("F", bound=Callable[..., Any])


class OutputExistsError(click.ClickException):
    """An output exists and ``--overwrite`` was not given (exit status 1)."""

    def __init__(self, path: str) -> None:
        super().__init__(f"{path}: exists; give --overwrite to replace it")


# --- positional INPUT... OUTPUT, -o/--output, --overwrite -------------------------------------


def files_argument(metavar: str, *kinds: PathKind) -> Callable[[F], F]:
    """Positional paths ``INPUT... OUTPUT`` (the output may come from ``-o/--output``), with
    what each word of ``metavar`` names (``kinds``, one per word)."""
    return click.argument(
        "files", nargs=-1, type=click.Path(), metavar=metavar, cls=FilesArgument, kinds=kinds
    )


output_option = click.option(
    "-o",
    "--output",
    default=None,
    type=click.Path(),
    help="Output path (an alternative to the last positional path; then every positional "
    "path is an input).",
)
overwrite_option = click.option(
    "--overwrite", is_flag=True, default=False, help="Replace an existing output."
)


#: Parameters of the commands that name outputs; the path in any other parameter is an input.
OUTPUT_PARAMETERS = frozenset(
    {
        "output",
        "old_out",
        "png",
        "polar_output",
        "old_polar_out",
        "dimming_output",
        "old_dimming_out",
        "summary_output",
        "summary_json",
        "old_summary",
        "plot_path",
        "panoramas",
        "export_dir",
    }
)
#: Sources of a parameter's value that are not the user's (no input file comes from them).
_NOT_GIVEN = (click.core.ParameterSource.DEFAULT, click.core.ParameterSource.DEFAULT_MAP, None)
#: Where :func:`resolve_inout` leaves the positional inputs for :func:`check_outputs`.
_POSITIONAL_INPUTS = "nightlights_cli.positional_inputs"


def _flag(param: click.Parameter) -> str:
    """How the command line spells ``param``: its long flag, or an argument's metavar."""
    if isinstance(param, click.Option):
        long = [name for name in param.opts if name.startswith("--")]
        return (long or param.opts)[-1]
    return param.human_readable_name.upper()


def command_inputs(ctx: click.Context | None = None) -> dict[str, list[str]]:
    """The input paths of the running command, by the flag or argument that gave them.

    The positional inputs that :func:`resolve_inout` found, and the value of every other
    parameter given that is not an output (:data:`OUTPUT_PARAMETERS`): a value that names no
    file (``--mapping osm``, ``--albedo 0.1``) is no input and is skipped when checked.
    """
    ctx = ctx if ctx is not None else click.get_current_context(silent=True)
    if ctx is None:
        return {}
    inputs: dict[str, list[str]] = {
        name: [path] for name, path in ctx.meta.get(_POSITIONAL_INPUTS, {}).items()
    }
    for param in ctx.command.params:
        if param.name is None or param.name in OUTPUT_PARAMETERS or param.name == "files":
            continue
        if ctx.get_parameter_source(param.name) in _NOT_GIVEN:
            continue  # a default (``--mapping osm``) names no file of the user's
        value = ctx.params.get(param.name)
        values = value if isinstance(value, tuple | list) else (value,)
        paths = [v for v in values if isinstance(v, str)]
        if paths:
            inputs[_flag(param)] = paths
    return inputs


def refuse_replacing_inputs(outputs: Sequence[str | None]) -> None:
    """Refuse an output that is one of the running command's inputs (:func:`command_inputs`).

    Raises
    ------
    nightlights.errors.OutputError
        Naming the output and the input, with or without ``--overwrite``.
    """
    from nightlights.io.outputs import refuse_replacing_inputs as refuse

    refuse(outputs, command_inputs())


def resolve_inout(
    files: Sequence[str],
    output: str | None,
    *,
    inputs: int | tuple[int, int],
    usage: str,
    overwrite: bool,
    existing_inputs: bool = True,
) -> tuple[list[str], str]:
    """Split positional ``files`` and ``-o/--output`` into inputs and the output.

    Parameters
    ----------
    files
        Positional paths: inputs then the output, or only inputs when ``output`` is given.
    output
        The ``-o/--output`` value, or None.
    inputs
        Number of inputs expected, or ``(fewest, most)``.
    usage
        The positional paths as the help shows them, for the error message.
    overwrite
        Whether an existing output may be replaced.
    existing_inputs
        Refuse inputs that do not exist (usage error, exit status 2).

    Returns
    -------
    tuple of (list of str, str)
        The input paths and the output path.

    Raises
    ------
    click.UsageError
        Wrong number of paths, or a missing input.
    nightlights.errors.OutputError
        The output is one of the command's inputs (:func:`refuse_replacing_inputs`).
    OutputExistsError
        The output exists and ``overwrite`` is False.
    """
    paths = list(files)
    if output is None:
        if not paths:
            raise click.UsageError(f"missing OUTPUT; expected {usage} (or -o/--output OUTPUT)")
        output = paths.pop()
    fewest, most = (inputs, inputs) if isinstance(inputs, int) else inputs
    if not fewest <= len(paths) <= most:
        given = ", ".join(paths) if paths else "none"
        raise click.UsageError(f"expected {usage}; inputs given: {given}")
    if existing_inputs:
        for path in paths:
            if not Path(path).exists():
                raise click.UsageError(f"input {path!r} does not exist")
    ctx = click.get_current_context(silent=True)
    if ctx is not None:
        names = [name.strip("[]") for name in usage.split()]
        ctx.meta[_POSITIONAL_INPUTS] = {
            names[i] if i < len(names) - 1 else f"INPUT {i + 1}": path
            for i, path in enumerate(paths)
        }
    check_outputs([output], overwrite=overwrite)
    return paths, output


def check_outputs(paths: Sequence[str | None], *, overwrite: bool) -> None:
    """Refuse an output that is one of the command's inputs (:func:`refuse_replacing_inputs`),
    then the first path that exists unless ``overwrite``; None entries are skipped."""
    refuse_replacing_inputs(paths)
    if overwrite:
        return
    for path in paths:
        if path is not None and Path(path).exists():
            raise OutputExistsError(path)


# --- value types ---------------------------------------------------------------------------------


def _refuse_non_finite(number: float, value: Any, param: click.Parameter | None) -> float:
    """``number``, or an InputError naming the option when it is ``nan`` or infinite."""
    if math.isfinite(number):
        return number
    from nightlights.errors import InputError

    option = param.opts[-1] if param is not None and param.opts else "value"
    raise InputError(f"{option}={value}: expected a finite number")


class FiniteFloat(click.types.FloatParamType):
    """A float option that refuses ``nan`` and ``inf`` (an InputError: one line, exit status 1,
    as the library's own range checks)."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return _refuse_non_finite(super().convert(value, param, ctx), value, param)


class FiniteFloatRange(click.FloatRange):
    """A :class:`click.FloatRange` that also refuses ``nan`` (which passes every comparison)."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return _refuse_non_finite(super().convert(value, param, ctx), value, param)


def require_finite_floats(command: click.Command) -> None:
    """Make every float option of ``command`` and its subcommands refuse ``nan`` and ``inf``.

    No option of the toolkit means anything with a non-finite value; a ``nan`` that passed
    would disable the checks that compare it (``nan < 0`` is false) and spread through the
    results.
    """
    for param in command.params:
        kind = type(param.type)
        if kind is click.types.FloatParamType:
            param.type = FiniteFloat()
        elif kind is click.FloatRange:
            old = param.type
            assert isinstance(old, click.FloatRange)
            param.type = FiniteFloatRange(
                old.min, old.max, min_open=old.min_open, max_open=old.max_open, clamp=old.clamp
            )
    if isinstance(command, click.Group):
        for sub in command.commands.values():
            require_finite_floats(sub)


class CRSText(click.ParamType):
    """A CRS as text (``EPSG:3067``, WKT, PROJ), checked with pyproj and passed on unchanged.

    A value pyproj cannot read is a :class:`~nightlights.errors.CRSError` (one line, exit
    status 1, as for a CRS the library refuses), even where the input has a CRS of its own and
    the option would not be used.
    """

    name = "crs"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        import pyproj

        from nightlights.errors import CRSError

        try:
            pyproj.CRS.from_user_input(value)
        except pyproj.exceptions.CRSError as exc:
            option = param.opts[-1] if param is not None and param.opts else "CRS"
            raise CRSError(
                f"{option}={value!r} is not a coordinate reference system; expected e.g. "
                "EPSG:3067, a WKT or a PROJ string"
            ) from exc
        return value


class MemorySize(click.ParamType):
    """A memory size such as ``8G``, ``500M`` or ``2e9`` (bytes), converted to ``int`` [B]."""

    name = "size"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> int:
        from nightlights._resources import parse_size
        from nightlights.errors import InputError

        try:
            return parse_size(value, source=repr(value))
        except InputError:
            self.fail(f"{value!r}; expected a size such as 8G, 500M or 2e9 (bytes)", param, ctx)


# --- deprecated spellings -----------------------------------------------------------------------


def warn_deprecated(ctx: click.Context, message: str) -> None:
    """Print a one-line deprecation warning on stderr (silenced by ``nightlights -q``)."""
    if ctx.find_root().params.get("quiet"):
        return
    click.echo(f"DeprecationWarning: {message}", err=True)


class DeprecatedOption(click.Option):
    """A hidden option kept for one release; using it prints a warning naming ``replacement``.

    ``replacement`` is the spelling to use instead; the command reference lists both.
    """

    def __init__(self, *args: Any, replacement: str, **kwargs: Any) -> None:
        kwargs.setdefault("hidden", True)
        super().__init__(*args, **kwargs)
        self.replacement = replacement

    def handle_parse_result(
        self, ctx: click.Context, opts: Any, args: list[str]
    ) -> tuple[Any, list[str]]:
        if self.name in opts:
            warn_deprecated(ctx, f"{self.opts[0]} is deprecated; use {self.replacement}.")
        return super().handle_parse_result(ctx, opts, args)


def deprecated_option(*decls: str, replacement: str, **kwargs: Any) -> Callable[[F], F]:
    """A :class:`DeprecatedOption` decorator."""
    return click.option(*decls, cls=DeprecatedOption, replacement=replacement, **kwargs)


class DeprecatedCommand(click.Command):
    """A hidden command kept for one release; the command reference names ``replacement``
    (its callback prints the deprecation note, as it knows which command it runs instead)."""

    def __init__(self, *args: Any, replacement: str, **kwargs: Any) -> None:
        kwargs.setdefault("hidden", True)
        super().__init__(*args, **kwargs)
        self.replacement = replacement


class DefaultCommandGroup(click.Group):
    """A group that runs ``default_command`` when the first argument names no subcommand.

    It also rewrites deprecated spellings of the group (``deprecated_spellings``: old option
    -> subcommand that replaces it, the option's value becoming the subcommand's first path).
    """

    def __init__(
        self,
        *args: Any,
        default_command: str,
        deprecated_spellings: dict[str, str] | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(*args, **kwargs)
        self.default_command = default_command
        self.deprecated_spellings = dict(deprecated_spellings or {})

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        args = self._rewrite_deprecated(ctx, list(args))
        if args and args[0] not in self.commands and args[0] not in ctx.help_option_names:
            args.insert(0, self.default_command)
        return super().parse_args(ctx, args)

    def _rewrite_deprecated(self, ctx: click.Context, args: list[str]) -> list[str]:
        for old, command in self.deprecated_spellings.items():
            for i, arg in enumerate(args):
                if arg == "--":
                    break
                if arg == old and i + 1 < len(args):
                    value, rest = args[i + 1], args[:i] + args[i + 2 :]
                elif arg.startswith(old + "="):
                    value, rest = arg[len(old) + 1 :], args[:i] + args[i + 1 :]
                else:
                    continue
                warn_deprecated(
                    ctx,
                    f"{ctx.command_path} {old} INPUT OUTPUT is deprecated; use "
                    f"{ctx.command_path} {command} INPUT OUTPUT.",
                )
                return [command, value, *rest]
        return args


def given(ctx: click.Context, name: str) -> Any:
    """The value of option ``name`` when given on the command line, else None."""
    source = ctx.get_parameter_source(name)
    return ctx.params[name] if source is click.core.ParameterSource.COMMANDLINE else None


def one_of(ctx: click.Context, **values: Any) -> Any:
    """The one value given among ``values`` (keyword = option as typed); both given: error."""
    given = {name: value for name, value in values.items() if value is not None}
    if len(given) > 1:
        raise click.UsageError(f"give only one of {' and '.join(given)}", ctx)
    return next(iter(given.values()), None)


# --- options of several commands --------------------------------------------------------------


def options(*decorators: Callable[[F], F]) -> Callable[[F], F]:
    """Several option decorators as one, applied in the order given (the help lists them so)."""

    def apply(function: F) -> F:
        for decorator in reversed(decorators):
            function = decorator(function)
        return function

    return apply


SEED_HELP = "Random seed; the same seed gives the same output."
#: Seeds of numpy's random generators are non-negative integers.
SEED_TYPE = click.IntRange(min=0)
seed_option = click.option("--seed", type=SEED_TYPE, default=None, help=SEED_HELP)
catalog_option = click.option(
    "--catalog",
    default=None,
    type=click.Path(exists=True, file_okay=False),
    help="Luminaire database folder (default: the bundled one).",
)
skip_unknown_option = click.option(
    "--skip-unknown", is_flag=True, help="Drop lights with unknown system ids (with a warning)."
)
crs_option = click.option(
    "--crs",
    default=None,
    type=CRSText(),
    metavar="CRS",
    help="CRS of an input that has none (e.g. EPSG:3067).",
)
target_crs_option = click.option(
    "--target-crs",
    default=None,
    type=CRSText(),
    metavar="CRS",
    help="Projected output CRS in metres. Default: the input's CRS if projected; a geographic "
    "input goes to its local UTM zone in streets normalize, keeps its grid in darkness, and in "
    "emission viirs keeps it only when wider than one UTM zone (6 deg).",
)
dem_option = click.option(
    "--dem",
    type=KindPath(RASTER, exists=True, dir_okay=False),
    default=None,
    help="Terrain heights above sea level [m] (raster): the ground under each light or lit "
    "cell, the observers' altitude and their horizon.",
)
prior_option = click.option(
    "--prior",
    default=1.0,
    show_default=True,
    type=click.FloatRange(min=0),
    help="Pseudo-observations per parent combination from the base network (0: maximum "
    "likelihood).",
)


# --- the scene and its observers (skyglow, inverse, darkness, sky observers, explore) ----------


def parse_pair(text: str, option: str = "--observer") -> tuple[float, float]:
    """``X,Y`` -> two floats."""
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise click.BadParameter(f"{text!r}; expected X,Y", param_hint=option) from None
    return x, y


def scene_of(
    emission: str,
    *,
    dem: str | None = None,
    kernel: str | None = None,
    turbidity: float | None = None,
    n_elevation: int | None = None,
    n_azimuth: int | None = None,
    n_distance: int | None = None,
    obstacles: str | None = None,
    clouds: Any = None,
) -> Any:
    """The ``nightlights.Scene`` of a sky command's scene options."""
    from nightlights.sky import Scene

    return Scene(
        emission,
        dem=dem,
        kernel=kernel,
        turbidity=turbidity,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        n_distance=n_distance,
        obstacles=obstacles,
        clouds=clouds,
    )


def clouds_of(base_height: float | None, optical_depth: float, cover: float) -> Any:
    """The ``CloudLayer`` of ``--cloud-base``, ``--cloud-optical-depth`` and
    ``--cloud-cover``; None (a clear sky) without ``--cloud-base``."""
    if base_height is None:
        return None
    from nightlights.sky.clouds import CloudLayer

    return CloudLayer(base_height, optical_depth=optical_depth, cover=cover)


def clouds_options(function: F) -> F:
    """A cloud deck over the scene (``clouds=CloudLayer(...)``): its base, optical depth and
    cover."""
    options = (
        click.option(
            "--cloud-base",
            "base_height",
            type=float,
            default=None,
            metavar="METRES",
            help="Height of a cloud deck's base above the ground [m]; default: a clear sky.",
        ),
        click.option(
            "--cloud-optical-depth",
            "optical_depth",
            type=float,
            default=DEFAULT_CLOUD_OPTICAL_DEPTH,
            show_default=True,
            help="Optical depth of the cloud deck (sets its reflectance by the two-stream "
            "relation).",
        ),
        click.option(
            "--cloud-cover",
            "cover",
            type=float,
            default=1.0,
            show_default=True,
            help="Share of the sky the deck covers, 0-1.",
        ),
    )
    for option in reversed(options):
        function = option(function)
    return function


def observer_of(text: str, crs: str | None, height: float) -> Any:
    """The ``nightlights.Observer`` of ``--observer X,Y``, ``--observer-crs`` and
    ``--observer-height``."""
    from nightlights.sky import Observer

    x, y = parse_pair(text)
    return Observer(x, y, crs, height)


#: One observer's place (the sky commands of one observer).
observer_option = click.option(
    "--observer", required=True, metavar="X,Y", help="Observer X,Y (in --observer-crs)."
)
#: Several observers (``observers=``), each given with its own ``--observer``.
observers_option = click.option(
    "--observer",
    "observers",
    multiple=True,
    metavar="X,Y",
    help="Observer X,Y (in --observer-crs); repeat for several.",
)
observer_crs_option = click.option(
    "--observer-crs",
    default=None,
    metavar="CRS",
    help="CRS of the observers' coordinates (default: the emission raster's).",
)
#: Eye height of a standing person; the sky stages' default (``observer_height=``).
DEFAULT_OBSERVER_HEIGHT = 1.7
observer_height_option = click.option(
    "--observer-height",
    type=float,
    default=DEFAULT_OBSERVER_HEIGHT,
    show_default=True,
    help="Above ground [m].",
)
#: Obstacles around the lit ground (``obstacles=`` of the scene).
obstacles_option = click.option(
    "--obstacles",
    type=KindPath(RASTER, exists=True, dir_okay=False),
    default=None,
    help="Obstacle raster on the emission's grid (nightlights obstacles: height, spacing, "
    "filling); default: open ground.",
)
kernel_option = click.option(
    "--kernel",
    type=KindPath(NETCDF, exists=True, dir_okay=False),
    default=None,
    help="Precomputed kernel (nightlights kernel build); default: a cached scene kernel that "
    "covers the scene's distances and altitudes.",
)
turbidity_option = click.option(
    "--turbidity",
    cls=LibraryHelpOption,
    type=float,
    default=None,
    help="Turbidity T (default {turbidity}; a given --kernel fixes it).",
    help_values={"turbidity": atmosphere_default("turbidity")},
)
scene_grid_options = options(
    click.option(
        "--n-azimuth",
        cls=LibraryHelpOption,
        type=int,
        default=None,
        help="Panorama columns of the scene kernel (default {n}; a given --kernel fixes it).",
        help_values={"n": kernel_default("n_azimuth")},
    ),
    click.option(
        "--n-elevation",
        cls=LibraryHelpOption,
        type=int,
        default=None,
        help="Panorama rows of the scene kernel (default {n}; a given --kernel fixes it).",
        help_values={"n": kernel_default("n_elevation")},
    ),
    click.option(
        "--n-distance",
        cls=LibraryHelpOption,
        type=int,
        default=None,
        help="Distance bins of the scene kernel (default {n}; a given --kernel fixes it).",
        help_values={"n": kernel_default("n_distance")},
    ),
)
#: The scene of one observer's sky: ``skyglow``, ``inverse q`` and ``inverse s``.
scene_options = options(
    observer_option,
    observer_crs_option,
    observer_height_option,
    dem_option,
    kernel_option,
    turbidity_option,
    scene_grid_options,
)
#: What an instrument reads (``instrument=``, ``spectrum=``): ``darkness``, ``skyglow`` and
#: ``sky observers``.
instrument_option = click.option(
    "--instrument",
    type=LibraryChoice(INSTRUMENT_NAMES),
    default=None,
    help="Also report what this instrument reads pointing at the zenith: its angular response "
    "and band, with a moonless natural sky (default: none, the zenith luminance alone).",
)
#: The natural sky of a given night in an instrument's reading (``natural_luminance=``).
night_option = click.option(
    "--night",
    default=None,
    metavar="TIME",
    help="With --instrument: add the moonless natural sky of this UTC instant "
    "(2026-01-18T21:00Z; the Milky Way and the airglow where they stand then) in place of a "
    "typical moonless night.",
)


def natural_of(
    instrument: str | None, night: str | None, xy: tuple[float, float], crs: Any
) -> float | None:
    """The natural sky an instrument reads at ``night`` over the point ``xy`` (in ``crs``)
    [cd m-2]: ``natural_luminance=`` of ``--night`` (None without it)."""
    if night is None:
        return None
    if instrument is None:
        raise click.UsageError(
            "--night gives the natural sky of an --instrument reading; add --instrument"
        )
    import pandas as pd
    from pyproj import Transformer

    try:
        when = pd.Timestamp(night)
    except ValueError:
        raise click.BadParameter(
            f"{night!r}; expected an ISO time such as 2026-01-18T21:00Z", param_hint="--night"
        ) from None
    when = when.tz_localize("UTC") if when.tzinfo is None else when.tz_convert("UTC")
    lon, lat = Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(*xy)
    from nightlights.meter import natural_reading

    return natural_reading(instrument, when, float(lon), float(lat))


spectrum_option = click.option(
    "--spectrum",
    cls=LibraryHelpOption,
    type=LibraryChoice(SPECTRA),
    default=None,
    help="Spectrum of the artificial light: the colour term of --instrument (and the colours "
    "of skyglow --bands RGB); default: the emission raster's spectrum tag, else {default}.",
    help_values={"default": DEFAULT_SPECTRUM},
)
components_option = click.option(
    "--components",
    type=int,
    default=None,
    help="PCA bases to use at run time, the first of those the kernel stores (default: all).",
)
num_workers_option = options(
    click.option(
        "--num-workers",
        type=click.IntRange(min=1),
        default=None,
        help="Workers of the local threads or processes scheduler (default: one per core).",
    ),
    deprecated_option(
        "--workers",
        "old_workers",
        type=click.IntRange(min=1),
        default=None,
        replacement="--num-workers",
    ),
)
