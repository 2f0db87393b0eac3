"""The web server of ``nightlights explore``: a JSON API over one explore session, and the page.

The API (every response JSON unless noted; errors are ``{"error": "<one line>"}``):

==========================  =====================================================================
``GET /``                   the page (``static/index.html``)
``GET /static/<name>``      a file that ships in ``static/`` (a whitelist made at start)
``GET /api/info``           the session: CRS, bounds, shape, lit cells, flux, kernel, edit state
``GET /api/emission.png``   the emission map (``?which=current|original``), legend in ``X-Legend``
``GET /api/lights``         the lights as a GeoJSON FeatureCollection of points (raster CRS)
``GET /api/panorama``       the panorama at ``?x=&y=[&crs=][&height=][&which=]``
``POST /api/influence``     each lit cell's part in the glow (Q or S), as a map image
``POST /api/dim``           dimming by the Q or S map (Dobashi et al. 2023, Eq. 12)
``POST /api/least-dimming`` the least flux removal that meets a sky-brightness target
``GET /api/roads``          the street segments (GeoJSON, raster CRS) with their compliance
                            status at the current emission, and the share of length compliant
``POST /api/road-plan``     solve the least-energy dimming that keeps every road lit under the
                            least-dimming target, and apply it (one edit)
``POST /api/edit``          paint, erase or scale the emission along a brush stroke
``POST /api/undo``, ``redo`` step through the edits
``POST /api/export``        write the emission, a dimming, a panorama or the session file
==========================  =====================================================================

Status codes: 400 a bad request (a missing or malformed field, a non-finite number, a value the
session refuses), 403 a cross-origin request or, on a loopback server, a foreign ``Host`` (a
web page elsewhere must not drive the session: DNS rebinding, forged form posts), 404 an
unknown path, 405 a wrong method, 409 an export that exists without ``overwrite`` or nothing
to undo/redo or a road query without streets, 413 a body over ``max_body``, 422 a dimming
target that cannot be reached, 500 a
fault of the server (logged with its traceback).

A response to a request that made the toolkit warn (an observer above the kernel's levels,
say) carries ``"warnings"``: a list of one-line messages, also logged.

The session is not thread-safe and the page may be open in several tabs: every call into it
holds one lock and runs in a worker thread, so the event loop stays free. Edits are shared by
every tab by design. The server opens no path that came from a request except
``export_dir / name`` for a checked plain file ``name``.

Length: one endpoint per function with its parsing, and the request parsing they share; split,
the handlers would only forward to each other.
"""

from __future__ import annotations

import base64
import contextlib
import dataclasses
import errno
import ipaddress
import json
import logging
import math
import re
import socket
import threading
import warnings
import webbrowser
from collections.abc import Awaitable, Callable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar
from urllib.parse import urlsplit

import numpy as np
import orjson
from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.datastructures import Headers, MutableHeaders
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import Response
from starlette.routing import Route
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from nightlights.errors import InputError, NightlightsError, NightlightsWarning, OutputError
from nightlights.explore._render import raster_png

if TYPE_CHECKING:
    from nightlights.explore._session import DimmingView, ExploreSession

__all__ = ["bind", "browser_url", "create_app", "serve"]

logger = logging.getLogger(__name__)

T = TypeVar("T")

#: Folder of the page's files.
STATIC_DIR = Path(__file__).parent / "static"
#: Content types of the files the page may ship, by suffix.
MEDIA_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".mjs": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".json": "application/json",
    ".svg": "image/svg+xml",
    ".png": "image/png",
    ".ico": "image/x-icon",
    ".woff2": "font/woff2",
}
#: A plain file name: no separator, no leading dot, no ``..`` (checked apart).
FILE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,120}$")
#: Suffixes of the exports, by kind (a panorama's name is a stem, or ends in one of its two).
EXPORT_SUFFIXES = {
    "emission": (".tif",),
    "dimming": (".tif",),
    "panorama": (".nc", ".png"),
    "session": (".json",),
}
#: Most lights ``/api/lights`` sends (more are thinned evenly; the map only shows them) [1].
MAX_LIGHTS = 100_000
#: Most points of one brush stroke [1].
MAX_STROKE_POINTS = 10_000
#: Largest side of the map images [pixel].
MAX_IMAGE_SIZE = 1024
#: Host names a loopback server answers to (anything else may be a DNS-rebinding attack).
LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})
#: Headers of every response: no caching of the session's state, no content sniffing.
SECURITY_HEADERS = {"x-content-type-options": "nosniff", "referrer-policy": "no-referrer"}

_REQUIRED = object()


class ApiError(Exception):
    """A request the API refuses: HTTP ``status`` and a one-line ``message``."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


# --- responses -----------------------------------------------------------------------------


def jsonable(value: Any) -> Any:
    """``value`` with numpy arrays and scalars as lists and numbers, NaN and inf as None.

    Examples
    --------
    >>> jsonable({"luminance": np.array([1.5, np.nan]), "bortle": np.int64(4)})
    {'luminance': [1.5, None], 'bortle': 4}
    """
    kind = type(value)
    # the common plain types first: a panorama is some 16 000 numbers
    if kind is float:
        return value if math.isfinite(value) else None
    if value is None or kind is int or kind is str or kind is bool:
        return value
    if kind is list and all(type(item) is float for item in value):
        return [item if math.isfinite(item) else None for item in value]
    if isinstance(value, Mapping):
        return {str(key): jsonable(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(item) for item in value]
    if isinstance(value, np.ndarray):
        if value.dtype.kind == "f":
            shown = value.astype(object)
            shown[~np.isfinite(value)] = None
            return shown.tolist()
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Path):
        return str(value)
    return value


def json_response(
    data: Any, status: int = 200, headers: Mapping[str, str] | None = None
) -> Response:
    """A JSON response of ``data``: numpy arrays as lists, NaN and inf as null (orjson, some
    ten times faster than :mod:`json` on a panorama's 16 000 numbers)."""
    body = orjson.dumps(data, default=_plain, option=orjson.OPT_SERIALIZE_NUMPY)
    return Response(body, status, headers=dict(headers or {}), media_type="application/json")


def _plain(value: Any) -> Any:
    """What orjson does not write itself, as :func:`jsonable` makes it."""
    if isinstance(value, np.ndarray | np.generic | Path | tuple):
        return jsonable(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def error_response(status: int, message: str, headers: Mapping[str, str] | None = None) -> Response:
    """``{"error": message}`` with ``status``; the message is made one line."""
    line = " ".join(str(message).split())
    return json_response({"error": line}, status, headers)


def noted(data: dict[str, Any], notes: list[str]) -> dict[str, Any]:
    """``data`` with ``"warnings"``: the toolkit's warnings of the request, when there were any."""
    if notes:
        data["warnings"] = notes
    return data


def data_url(png: bytes) -> str:
    """A PNG as a ``data:`` URL."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


# --- request fields ------------------------------------------------------------------------


def _refuse_constant(name: str) -> Any:
    raise ApiError(400, f"{name} in the request body; expected finite numbers")


class Fields:
    """The fields of a request (query parameters or a JSON body), read with checks.

    Every reader raises :class:`ApiError` (400) naming the field, the value and what was
    expected; :meth:`done` refuses fields that no reader asked for (a misspelt name would
    otherwise be silently ignored).
    """

    def __init__(self, values: Mapping[str, Any], *, query: bool = False) -> None:
        self.values = dict(values)
        self.query = query
        self.read: set[str] = set()

    def _get(self, key: str, default: Any, expected: str) -> Any:
        self.read.add(key)
        value = self.values.get(key)
        if value is None:
            if default is _REQUIRED:
                raise ApiError(400, f"{key}: missing; expected {expected}")
            return default
        return value

    def number(self, key: str, default: Any = _REQUIRED, *, unit: str = "") -> Any:
        """A finite number [``unit``] (``default`` when absent; absent and required: 400)."""
        expected = f"a finite number{f' [{unit}]' if unit else ''}"
        value = self._get(key, default, expected)
        if value is default:
            return value
        if self.query and isinstance(value, str):
            try:
                value = float(value)
            except ValueError:
                raise ApiError(400, f"{key}={value!r}: expected {expected}") from None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ApiError(400, f"{key}={json.dumps(value)[:60]}: expected {expected}")
        try:
            number = float(value)
        except OverflowError:  # an integer beyond the largest float (some 309 digits)
            number = math.inf
        if not math.isfinite(number):
            shown = (
                str(value)
                if len(str(value)) <= 60
                else f"{str(value)[:20]}... ({len(str(value))} digits)"
            )
            raise ApiError(400, f"{key}={shown}: expected {expected}")
        return number

    def choice(self, key: str, choices: tuple[str, ...], default: Any = _REQUIRED) -> Any:
        """One of ``choices``."""
        expected = f"one of {', '.join(choices)}"
        value = self._get(key, default, expected)
        if value is default:
            return value
        if value not in choices:
            raise ApiError(400, f"{key}={json.dumps(value)[:60]}: expected {expected}")
        return value

    def text(self, key: str, default: Any = _REQUIRED, *, expected: str = "a string") -> Any:
        """A string."""
        value = self._get(key, default, expected)
        if value is not default and not isinstance(value, str):
            raise ApiError(400, f"{key}={json.dumps(value)[:60]}: expected {expected}")
        return value

    def flag(self, key: str, default: bool) -> bool:
        """A JSON boolean."""
        value = self._get(key, default, "true or false")
        if not isinstance(value, bool):
            raise ApiError(400, f"{key}={json.dumps(value)[:60]}: expected true or false")
        return value

    def pairs(
        self, key: str, default: Any = _REQUIRED, *, fewest: int, most: int, what: str
    ) -> Any:
        """A list of ``[a, b]`` pairs of finite numbers, ``fewest`` to ``most`` of them."""
        expected = f"a list of {fewest} to {most} [{what}] pairs of finite numbers"
        value = self._get(key, default, expected)
        if value is default:
            return value
        if not isinstance(value, list) or not fewest <= len(value) <= most:
            count = f" of {len(value)}" if isinstance(value, list) else ""
            raise ApiError(400, f"{key}: a {type(value).__name__}{count}; expected {expected}")
        pairs = []
        for index, item in enumerate(value):
            if not isinstance(item, list | tuple) or len(item) != 2:
                raise ApiError(400, f"{key}[{index}]={json.dumps(item)[:60]}: expected [{what}]")
            numbers = Fields({"a": item[0], "b": item[1]})
            try:
                pairs.append((numbers.number("a"), numbers.number("b")))
            except ApiError:
                raise ApiError(
                    400, f"{key}[{index}]={json.dumps(item)[:60]}: expected finite [{what}]"
                ) from None
        return pairs

    def region(self) -> list[tuple[float, float]] | None:
        """The optional sky polygon ``region``: [azimuth, elevation] vertices [deg]."""
        return self.pairs("region", None, fewest=3, most=1000, what="azimuth, elevation")

    def observer(self) -> dict[str, Any]:
        """``x``, ``y`` [m, or the units of ``crs``], ``crs`` and ``height`` [m] as keywords."""
        return {
            "x": self.number("x"),
            "y": self.number("y"),
            "crs": self.text("crs", None, expected="a CRS such as EPSG:4326"),
            "height": self.number("height", None, unit="m"),
        }

    def done(self) -> None:
        """Refuse fields that were not read."""
        unknown = sorted(set(self.values) - self.read)
        if unknown:
            raise ApiError(
                400,
                f"unknown field {unknown[0]!r}; expected {', '.join(sorted(self.read)) or 'none'}",
            )


def _observer_call(fields: Fields) -> tuple[float, float, dict[str, Any]]:
    where = fields.observer()
    return where.pop("x"), where.pop("y"), where


# --- the guard: Host and Origin checks, headers --------------------------------------------


def _host_name(host: str) -> str:
    """The name of a ``Host`` header, without the port (and the brackets of IPv6)."""
    if host.startswith("["):
        return host[1:].split("]", 1)[0]
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


class _Guard:
    """Refuse foreign hosts (when ``allowed_hosts`` is set) and cross-origin requests that
    change anything; add :data:`SECURITY_HEADERS` (and ``Cache-Control: no-store`` unless the
    response set its own) to every response."""

    def __init__(self, app: ASGIApp, allowed_hosts: frozenset[str] | None) -> None:
        self.app = app
        self.allowed_hosts = allowed_hosts

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                for name, value in SECURITY_HEADERS.items():
                    headers[name] = value
                if "cache-control" not in headers:
                    headers["cache-control"] = "no-store"
            await send(message)

        headers = Headers(scope=scope)
        host = headers.get("host", "")
        refusal = None
        if self.allowed_hosts is not None and _host_name(host).lower() not in self.allowed_hosts:
            refusal = f"host {host!r} refused; open the page at a loopback address"
        origin = headers.get("origin")
        if scope["method"] not in ("GET", "HEAD") and origin is not None:
            if urlsplit(origin).netloc.lower() != host.lower():
                refusal = f"cross-origin request from {origin!r} refused"
        if refusal is not None:
            await error_response(403, refusal)(scope, receive, send_with_headers)
            return
        await self.app(scope, receive, send_with_headers)


# --- the application -----------------------------------------------------------------------


def _static_files(folder: Path) -> dict[str, tuple[Path, str]]:
    """The whitelist of the page's files: plain files (no links) of known types in ``folder``."""
    if not folder.is_dir():
        return {}
    return {
        entry.name: (entry, MEDIA_TYPES[entry.suffix.lower()])
        for entry in sorted(folder.iterdir())
        if FILE_NAME.fullmatch(entry.name)
        and entry.suffix.lower() in MEDIA_TYPES
        and not entry.is_symlink()
        and entry.is_file()
    }


def _before_json(view: Any) -> dict[str, Any]:
    return {
        "zenith_luminance": view.zenith_luminance,
        "zenith_magnitude": view.zenith_magnitude,
        "bortle": view.bortle,
        "bortle_reason": view.bortle_reason,
    }


class _Explorer:
    """The state of one app: the session, its lock, the export folder and caches."""

    def __init__(
        self,
        session: ExploreSession,
        *,
        export_dir: Path,
        tiles: str | None,
        max_body: int,
        static_dir: Path,
    ) -> None:
        self.session = session
        self.export_dir = export_dir
        self.tiles = tiles
        self.max_body = max_body
        self.static = _static_files(static_dir)
        self.lock = threading.Lock()
        self.emission_images: dict[tuple[str, int], tuple[bytes, dict[str, Any]]] = {}
        self.lights_json: dict[str, Any] | None = None

    # -- plumbing -----------------------------------------------------------------------

    @contextlib.contextmanager
    def engine(self) -> Iterator[list[str]]:
        """Hold the session's lock; the yielded list receives, when the block ends, the
        toolkit's warnings raised in it (also logged), for the page to show."""
        notes: list[str] = []
        with self.lock, warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", NightlightsWarning)
            try:
                yield notes
            finally:
                others = [w for w in caught if not issubclass(w.category, NightlightsWarning)]
                notes.extend(dict.fromkeys(str(w.message) for w in caught if w not in others))
        for note in notes:
            logger.warning("%s", note)
        for w in others:  # not the toolkit's: shown as they would have been
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)

    async def call(self, work: Callable[[], T]) -> tuple[T, list[str]]:
        """Run ``work`` in a worker thread in :meth:`engine`; its result and warnings."""

        def locked() -> tuple[T, list[str]]:
            with self.engine() as notes:
                result = work()
            return result, notes

        return await run_in_threadpool(locked)

    async def body(self, request: Request) -> Fields:
        """The JSON object of the request body (an empty body is an empty object)."""
        length = request.headers.get("content-length")
        if length is not None:
            if not length.isdigit():
                raise ApiError(400, f"Content-Length {length!r}: expected a number of bytes")
            if len(length) > 18 or int(length) > self.max_body:  # int() refuses 4300 digits
                shown = length if len(length) <= 18 else f"{length[:18]}... ({len(length)} digits)"
                raise ApiError(413, f"body of {shown} bytes; at most {self.max_body} taken")
        chunks, size = [], 0
        async for chunk in request.stream():
            size += len(chunk)
            if size > self.max_body:
                raise ApiError(413, f"body over {self.max_body} bytes; at most {self.max_body}")
            chunks.append(chunk)
        if size == 0:
            return Fields({})
        try:
            data = json.loads(b"".join(chunks), parse_constant=_refuse_constant)
        except (ValueError, RecursionError) as exc:  # NaN and Infinity: ApiError above
            raise ApiError(400, f"body is not JSON ({exc})") from None
        if not isinstance(data, dict):
            raise ApiError(400, f"body is a JSON {type(data).__name__}; expected an object")
        return Fields(data)

    def image(self, grid: np.ndarray, **options: Any) -> tuple[bytes, dict[str, Any]]:
        """A map image of a grid of the session's raster, north up."""
        if self.session.transform.e > 0:  # rows run south to north
            grid = grid[::-1]
        return raster_png(grid, max_size=MAX_IMAGE_SIZE, **options)

    def emission_image(self, which: str) -> tuple[bytes, dict[str, Any]]:
        """The emission map (log scale, the original's range for both); call under the lock."""
        key = (which, -1 if which == "original" else self.session.edit_version)
        if key not in self.emission_images:
            if ("original", -1) not in self.emission_images:
                self.emission_images[("original", -1)] = self.image(
                    self.session.emission("original"), scale="log"
                )
            if which == "current":
                legend = self.emission_images[("original", -1)][1]
                limits = {"vmin": legend["vmin"], "vmax": legend["vmax"]}
                for old in [k for k in self.emission_images if k[0] == "current"]:
                    del self.emission_images[old]
                self.emission_images[key] = self.image(
                    self.session.emission("current"), scale="log", **limits
                )
        return self.emission_images[key]

    def dimming_json(self, view: DimmingView, *, image: bool) -> dict[str, Any]:
        result: dict[str, Any] = {
            "panorama": view.panorama.to_dict(),
            "before": _before_json(view.before),
            "flux_removed_lm": view.flux_removed,
            "flux_removed_percent": view.flux_removed_percent,
            "seconds": view.seconds,
            "method": view.method,
            "params": view.params,
        }
        if image:
            png, legend = self.image(
                view.fraction, scale="linear", vmin=0.0, vmax=1.0, cmap="cividis"
            )
            result.update(image=data_url(png), legend=legend)
        return result

    # -- the page -----------------------------------------------------------------------

    def static_response(self, name: str) -> Response:
        entry = self.static.get(name)
        if entry is None:
            if name == "index.html":
                return error_response(404, "the page is not installed (no static/index.html)")
            return error_response(404, f"/static/{name}: no such file")
        path, media_type = entry
        try:
            content = path.read_bytes()
        except OSError:
            return error_response(404, f"/static/{name}: no longer readable")
        return Response(content, media_type=media_type, headers={"cache-control": "no-cache"})

    async def page(self, request: Request) -> Response:
        return self.static_response("index.html")

    async def static_file(self, request: Request) -> Response:
        return self.static_response(request.path_params["name"])

    # -- reading ------------------------------------------------------------------------

    async def info(self, request: Request) -> Response:
        Fields(request.query_params).done()

        def work() -> dict[str, Any]:
            session = self.session
            crs = session.crs
            epsg = crs.to_epsg()
            return {
                "crs": f"EPSG:{epsg}" if epsg is not None else crs.to_wkt(),
                "crs_wkt": crs.to_wkt(),
                "bounds": list(session.bounds),
                "shape": list(session.shape),
                "cell_size": session.cell_size,
                "n_lit": session.n_lit,
                "total_flux_lm": session.total_flux,
                "observer_height": session.observer_height,
                "elevation": session.elevation,
                "azimuth": session.azimuth,
                "kernel": session.kernel_info,
                "has_lights": session.lights is not None,
                "has_streets": session.has_streets,
                "has_dem": session.has_dem,
                "tiles": self.tiles,
                "edit_version": session.edit_version,
                "can_undo": session.can_undo,
                "can_redo": session.can_redo,
                "export_dir": str(self.export_dir),
                "emission_legend": self.emission_image("original")[1],
            }

        return json_response((await self.call(work))[0])

    async def emission_png(self, request: Request) -> Response:
        fields = Fields(request.query_params, query=True)
        which = fields.choice("which", ("current", "original"), "current")
        fields.text("v", None)  # the edit version: only makes the URL change with the map
        fields.done()
        (png, legend), _ = await self.call(lambda: self.emission_image(which))
        headers = {"x-legend": json.dumps(jsonable(legend), allow_nan=False)}
        return Response(png, media_type="image/png", headers=headers)

    async def lights(self, request: Request) -> Response:
        Fields(request.query_params).done()

        def work() -> dict[str, Any]:
            if self.lights_json is None:
                self.lights_json = _lights_geojson(self.session.lights)
            return self.lights_json

        return json_response((await self.call(work))[0])

    async def panorama(self, request: Request) -> Response:
        fields = Fields(request.query_params, query=True)
        x, y, where = _observer_call(fields)
        which = fields.choice("which", ("current", "original"), "current")
        fields.done()
        view, notes = await self.call(lambda: self.session.panorama(x, y, which=which, **where))
        return json_response(noted(view.to_dict(), notes))

    # -- the inverse --------------------------------------------------------------------

    async def influence(self, request: Request) -> Response:
        fields = await self.body(request)
        x, y, where = _observer_call(fields)
        kind = fields.choice("kind", ("q", "s"), "q")
        options = {"metric": fields.text("metric", None), "region": fields.region()}
        fields.done()
        options = {key: value for key, value in options.items() if value is not None}

        def work() -> dict[str, Any]:
            with self.engine() as notes:
                view = self.session.influence(x, y, kind=kind, **options, **where)
            values = np.asarray(view.values, dtype=np.float64)
            shown = values[np.isfinite(values) & (values > 0)]
            # its own colours: the map shows it over the (greyed) emission's magma
            png, legend = self.image(view.grid, scale="log", cmap="viridis")
            result = {
                "kind": view.kind,
                "metric": view.metric,
                "total": view.total,
                "panorama_value": view.panorama_value,
                "unit": view.unit,
                "seconds": view.seconds,
                "n_cells": int(np.isfinite(values).sum()),
                "image": data_url(png),
                "legend": legend,
                "vmin": float(shown.min()) if shown.size else None,
                "vmax": float(shown.max()) if shown.size else None,
            }
            return noted(result, notes)

        return json_response(await run_in_threadpool(work))

    def dim_call(self, fields: Fields) -> Callable[[], DimmingView]:
        """The session call of a dimming request (``/api/dim``, or with ``target`` the least
        dimming); the fields are read here, the call made later under the lock."""
        x, y, where = _observer_call(fields)
        if "target" in fields.values:
            target = fields.choice("target", ("zenith", "region"))
            brightness = fields.number("brightness", unit="mag arcsec-2")
            region = fields.region()
            max_dimming = fields.number("max_dimming", 1.0, unit="1")
            goal = {"target_zenith" if target == "zenith" else "target_region": brightness}
            if target == "region" and region is None:
                raise ApiError(400, "region: missing; target region needs the sky polygon")
            return lambda: self.session.least_dimming(
                x, y, region=region, max_dimming=max_dimming, **goal, **where
            )
        options = {
            "by": fields.choice("by", ("q", "s"), "q"),
            "metric": fields.text("metric", None),
            "region": fields.region(),
            "qa": fields.number("qa"),
            "qb": fields.number("qb"),
            "gamma": fields.number("gamma", unit="1"),
        }
        options = {key: value for key, value in options.items() if value is not None}
        return lambda: self.session.dim(x, y, **options, **where)

    async def dim(self, request: Request) -> Response:
        fields = await self.body(request)
        fields.read.add("target")  # /api/least-dimming takes it
        if "target" in fields.values:
            raise ApiError(400, "target: a least-dimming field; post it to /api/least-dimming")
        return await self._dimming(fields)

    async def least_dimming(self, request: Request) -> Response:
        fields = await self.body(request)
        if fields.values.get("target") is None:
            raise ApiError(400, "target: missing; expected one of zenith, region")
        return await self._dimming(fields)

    async def _dimming(self, fields: Fields) -> Response:
        compute = self.dim_call(fields)
        image = fields.flag("image", True)
        fields.done()

        def work() -> dict[str, Any]:
            with self.engine() as notes:
                view = compute()
            return noted(self.dimming_json(view, image=image), notes)

        return json_response(await run_in_threadpool(work))

    # -- roads --------------------------------------------------------------------------

    def _streets(self) -> None:
        if not self.session.has_streets:
            raise ApiError(
                409, "the session has no street layer; expected a session opened with streets="
            )

    async def roads(self, request: Request) -> Response:
        Fields(request.query_params).done()

        def work() -> dict[str, Any]:
            self._streets()
            return self.session.roads().to_geojson()

        data, notes = await self.call(work)
        return json_response(noted(data, notes))

    async def road_plan(self, request: Request) -> Response:
        fields = await self.body(request)
        options: dict[str, Any] = {
            "objective": fields.choice("objective", ("energy", "flux"), "energy"),
            "min_dimming": fields.number("min_dimming", 0.0, unit="1"),
            "hours": fields.number("hours", math.nan, unit="h"),
            "apply": fields.flag("apply", True),
        }
        target = fields.choice("target", ("zenith", "region", "none"), "none")
        if target != "none":
            x, y, where = _observer_call(fields)
            brightness = fields.number("brightness", unit="mag arcsec-2")
            region = fields.region()
            if target == "region" and region is None:
                raise ApiError(400, "region: missing; target region needs the sky polygon")
            key = "target_zenith" if target == "zenith" else "target_region"
            options.update({key: brightness, "region": region, "x": x, "y": y, **where})
        fields.done()

        def work() -> dict[str, Any]:
            self._streets()
            view = self.session.road_plan(**options)
            result = view.to_dict()
            result["roads"] = view.after.to_geojson()
            session = self.session
            result["edit"] = {
                "edit_version": session.edit_version,
                "n_lit": session.n_lit,
                "total_flux": session.total_flux,
                "can_undo": session.can_undo,
                "can_redo": session.can_redo,
            }
            return result

        data, notes = await self.call(work)
        return json_response(noted(data, notes))

    # -- editing ------------------------------------------------------------------------

    async def edit(self, request: Request) -> Response:
        fields = await self.body(request)
        op = fields.choice("op", ("paint", "erase", "scale"))
        points = fields.pairs("points", fewest=1, most=MAX_STROKE_POINTS, what="x, y")
        radius = fields.number("radius", unit="m")
        value = fields.number("value", None)
        fields.done()
        view, notes = await self.call(
            lambda: self.session.edit(op, points, radius=radius, value=value)
        )
        return json_response(noted(dataclasses.asdict(view), notes))

    async def undo(self, request: Request) -> Response:
        return await self._step("undo")

    async def redo(self, request: Request) -> Response:
        return await self._step("redo")

    async def _step(self, direction: str) -> Response:
        def work() -> Any:
            if not getattr(self.session, f"can_{direction}"):
                raise ApiError(409, f"nothing to {direction}")
            return getattr(self.session, direction)()

        view, notes = await self.call(work)
        return json_response(noted(dataclasses.asdict(view), notes))

    # -- export -------------------------------------------------------------------------

    def export_paths(self, what: str, name: str) -> list[Path]:
        """The checked paths in the export folder that an export named ``name`` writes."""
        if not FILE_NAME.fullmatch(name) or ".." in name:
            raise ApiError(
                400,
                f"name={json.dumps(name)[:80]}: expected a plain file name (letters, digits, "
                "'.', '_', '-'; no folders)",
            )
        suffixes = EXPORT_SUFFIXES[what]
        suffix = Path(name).suffix.lower()
        if what == "panorama" and suffix not in suffixes:
            names = [name + s for s in suffixes]  # a stem: both files
        elif suffix in suffixes:
            names = [name]
        else:
            raise ApiError(400, f"name={name!r}: a {what} export ends in {' or '.join(suffixes)}")
        paths = [self.export_dir / n for n in names]
        for path in paths:
            if path.is_symlink():
                raise ApiError(400, f"{path.name} is a symbolic link in the export folder")
            if path.is_dir():
                raise ApiError(409, f"{path.name} is a folder in the export folder")
        return paths

    async def export(self, request: Request) -> Response:
        fields = await self.body(request)
        what = fields.choice("what", tuple(EXPORT_SUFFIXES))
        name = fields.text("name", expected="a file name")
        overwrite = fields.flag("overwrite", False)
        paths = self.export_paths(what, name)
        session = self.session
        write: Callable[[], Any]
        if what == "emission":
            write = lambda: session.export_emission(paths[0], overwrite=overwrite)  # noqa: E731
        elif what == "dimming":
            compute = self.dim_call(fields)
            write = lambda: session.export_dimming(paths[0], compute(), overwrite=overwrite)  # noqa: E731
        elif what == "panorama":
            x, y, where = _observer_call(fields)
            which = fields.choice("which", ("current", "original"), "current")
            projection = fields.choice("projection", ("equirectangular", "fisheye"), None)
            by_suffix = {path.suffix: path for path in paths}
            extra = {"projection": projection} if projection is not None else {}

            def write() -> Any:
                view = session.panorama(x, y, which=which, **where)
                return session.export_panorama(
                    view,
                    nc=by_suffix.get(".nc"),
                    png=by_suffix.get(".png"),
                    overwrite=overwrite,
                    **extra,
                )

        else:
            observer = None
            if "x" in fields.values or "y" in fields.values:
                x, y, where = _observer_call(fields)
                if where["crs"] is not None:
                    raise ApiError(400, "crs: the session file's observer is in the raster CRS")
                observer = (x, y)
            write = lambda: session.save(paths[0], overwrite=overwrite, observer=observer)  # noqa: E731
        fields.done()

        def work() -> Any:
            existing = [path.name for path in paths if path.exists()]
            if existing and not overwrite:
                raise ApiError(409, f"{existing[0]} exists in the export folder; give overwrite")
            try:
                return write()
            except OutputError:
                if not overwrite and any(path.exists() for path in paths):
                    raise ApiError(409, f"{paths[0].name} exists in the export folder") from None
                raise

        written, notes = await self.call(work)
        files = [written] if isinstance(written, str | Path) else list(written)
        return json_response(noted({"files": [str(Path(p).resolve()) for p in files]}, notes))


def _lights_geojson(lights: Any) -> dict[str, Any]:
    """The lights as a GeoJSON FeatureCollection of points (at most :data:`MAX_LIGHTS`)."""
    collection: dict[str, Any] = {"type": "FeatureCollection", "features": []}
    if lights is None or len(lights) == 0:
        return collection
    import shapely

    total = len(lights)
    step = max(1, math.ceil(total / MAX_LIGHTS))
    points = shapely.get_coordinates(lights.geometry.iloc[::step].representative_point().values)
    collection["features"] = [
        {"type": "Feature", "geometry": {"type": "Point", "coordinates": [x, y]}, "properties": {}}
        for x, y in points.tolist()
    ]
    if step > 1:
        collection.update(truncated=True, total=total)
    return collection


def _endpoint(
    handler: Callable[[Request], Awaitable[Response]],
) -> Callable[[Request], Awaitable[Response]]:
    """``handler`` with its failures as JSON errors (see the module's status codes)."""
    from nightlights.inverse import InfeasibleTargetError

    async def wrapped(request: Request) -> Response:
        try:
            return await handler(request)
        except ApiError as exc:
            return error_response(exc.status, exc.message)
        except InfeasibleTargetError as exc:
            return error_response(422, str(exc))
        except OutputError as exc:
            logger.error("export failed: %s", exc)
            return error_response(500, f"{type(exc).__name__}: {exc}")
        except NightlightsError as exc:
            return error_response(400, str(exc))
        except Exception as exc:
            logger.exception("%s %s failed", request.method, request.url.path)
            return error_response(500, f"internal error: {type(exc).__name__}: {exc}")

    return wrapped


async def _http_error(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, HTTPException)
    path = request.url.path
    if exc.status_code == 404:
        return error_response(404, f"{path}: not found")
    if exc.status_code == 405:
        allowed = (exc.headers or {}).get("Allow", "")
        return error_response(
            405, f"{request.method} {path}: method not allowed; use {allowed}", exc.headers
        )
    return error_response(exc.status_code, f"{path}: {exc.detail}", exc.headers)


def create_app(
    session: ExploreSession,
    *,
    export_dir: str | Path,
    tiles: str | None = None,
    max_body: int = 1 << 20,
    allowed_hosts: frozenset[str] | None = None,
    static_dir: str | Path | None = None,
) -> Starlette:
    """The web app of an explore session (API and page), for uvicorn or a test client.

    Parameters
    ----------
    session
        The session every request works on (shared by all tabs; calls are serialised).
    export_dir
        Folder the exports are written to (the only place the app writes).
    tiles
        URL template of a background map (``https://.../{z}/{x}/{y}.png``), passed to the
        page; None: no background.
    max_body
        Largest request body [B]; larger: 413.
    allowed_hosts
        Host names (``Host`` header without the port) answered; others get 403. None: any
        (:func:`serve` sets :data:`LOOPBACK_NAMES` on a loopback address).
    static_dir
        Folder of the page's files (default: the package's ``static``); its plain files of
        known types at this call are the only files served.

    Returns
    -------
    starlette.applications.Starlette
        The app.
    """
    if isinstance(max_body, bool) or not isinstance(max_body, int) or max_body < 1:
        raise InputError(f"max_body={max_body!r}; expected an integer >= 1 [B]")
    explorer = _Explorer(
        session,
        export_dir=Path(export_dir).resolve(),
        tiles=tiles,
        max_body=max_body,
        static_dir=Path(static_dir) if static_dir is not None else STATIC_DIR,
    )
    routes = [
        Route("/", _endpoint(explorer.page), methods=["GET"]),
        Route("/static/{name:path}", _endpoint(explorer.static_file), methods=["GET"]),
        Route("/api/info", _endpoint(explorer.info), methods=["GET"]),
        Route("/api/emission.png", _endpoint(explorer.emission_png), methods=["GET"]),
        Route("/api/lights", _endpoint(explorer.lights), methods=["GET"]),
        Route("/api/panorama", _endpoint(explorer.panorama), methods=["GET"]),
        Route("/api/influence", _endpoint(explorer.influence), methods=["POST"]),
        Route("/api/dim", _endpoint(explorer.dim), methods=["POST"]),
        Route("/api/least-dimming", _endpoint(explorer.least_dimming), methods=["POST"]),
        Route("/api/roads", _endpoint(explorer.roads), methods=["GET"]),
        Route("/api/road-plan", _endpoint(explorer.road_plan), methods=["POST"]),
        Route("/api/edit", _endpoint(explorer.edit), methods=["POST"]),
        Route("/api/undo", _endpoint(explorer.undo), methods=["POST"]),
        Route("/api/redo", _endpoint(explorer.redo), methods=["POST"]),
        Route("/api/export", _endpoint(explorer.export), methods=["POST"]),
    ]
    app = Starlette(routes=routes, exception_handlers={HTTPException: _http_error})
    app.add_middleware(_Guard, allowed_hosts=allowed_hosts)
    app.state.explorer = explorer
    return app


# --- serving -------------------------------------------------------------------------------


def is_loopback(host: str) -> bool:
    """Whether ``host`` is a loopback address (or ``localhost``)."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def browser_url(host: str, port: int) -> str:
    """The URL a browser on this machine opens for a server on ``host``:``port``.

    Examples
    --------
    >>> browser_url("0.0.0.0", 8765), browser_url("::1", 8765)
    ('http://127.0.0.1:8765/', 'http://[::1]:8765/')
    """
    host = host.strip("[]")
    host = {"": "127.0.0.1", "0.0.0.0": "127.0.0.1", "::": "::1"}.get(host, host)
    return f"http://[{host}]:{port}/" if ":" in host else f"http://{host}:{port}/"


def bind(host: str, port: int) -> socket.socket:
    """A listening socket on ``host``:``port`` (0: a free port).

    Raises
    ------
    InputError
        The port is in use, or ``host`` is not an address of this machine.
    """
    try:
        family, kind, proto, _, address = socket.getaddrinfo(
            host.strip("[]"), port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE
        )[0]
    except (socket.gaierror, UnicodeError) as exc:
        raise InputError(f"host {host!r}: not an address to listen on ({exc})") from None
    sock = socket.socket(family, kind, proto)
    try:
        # a restart right after Ctrl-C may reuse the port (a listener still holds it: EADDRINUSE)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(128)
    except OSError as exc:
        sock.close()
        if exc.errno == errno.EADDRINUSE:
            raise InputError(
                f"port {port} on {host} is in use; choose another port (0 picks a free one)"
            ) from None
        raise InputError(f"cannot listen on {host} port {port}: {exc.strerror or exc}") from None
    return sock


def serve(
    session: ExploreSession,
    *,
    host: str = "127.0.0.1",
    port: int = 8765,
    open_browser: bool = True,
    export_dir: str | Path = ".",
    tiles: str | None = None,
    sock: socket.socket | None = None,
) -> None:
    """Serve the explore app with uvicorn until Ctrl-C, then return.

    Parameters
    ----------
    session
        The session to explore.
    host, port
        Address to listen on; a loopback address answers only loopback ``Host`` names.
    open_browser
        Open the page in the default browser.
    export_dir
        Folder of the exports.
    tiles
        Background map URL template for the page, or None.
    sock
        A socket already listening on ``host``:``port`` (from :func:`bind`); closed on return.

    Raises
    ------
    InputError
        The port is in use or ``host`` cannot be listened on.
    """
    import uvicorn

    listening = sock if sock is not None else bind(host, port)
    try:
        app = create_app(
            session,
            export_dir=export_dir,
            tiles=tiles,
            allowed_hosts=LOOPBACK_NAMES | {host.strip("[]").lower()}
            if is_loopback(host)
            else None,
        )
        config = uvicorn.Config(
            app, log_config=None, log_level="warning", access_log=False, lifespan="off"
        )
        if open_browser:
            webbrowser.open(browser_url(host, listening.getsockname()[1]))
        try:
            uvicorn.Server(config).run(sockets=[listening])
        except KeyboardInterrupt:  # uvicorn stops cleanly, then re-raises the Ctrl-C it caught
            logger.info("stopped")
    finally:
        listening.close()
