"""Dask helpers shared by the tiled and chunked stages: the scheduler a stage is given, checked
before any work, progress per task, and distributed runs.

A stage that takes ``scheduler=`` checks it with :func:`check_scheduler` before it reads or
computes anything: a local scheduler's name (where the stage has local ones), a
``distributed.Client``, or the address of a ``dask.distributed`` scheduler. An address is
parsed here (``tcp://host:port``, ``tls://``, ``ws://``, ``wss://``, ``inproc://``, ``ucx://``;
a bare ``host:port`` is TCP, as ``distributed`` reads it) and probed: a TCP connection within
:data:`CONNECT_TIMEOUT`, and for ``tcp://`` the first bytes of the scheduler's handshake, which
a dask scheduler sends as soon as it accepts a connection (a web server, such as the
dashboard's port, sends nothing and would make the client wait for ever). A connection refused,
an unknown host, a silent port or a timeout is one :class:`~nightlights.errors.InputError`
within seconds; no half-made ``distributed.Client`` is left to block the process at exit.
"""

from __future__ import annotations

import gc
import ipaddress
import socket
from collections.abc import Callable, Sequence
from typing import Any

from dask.callbacks import Callback

from nightlights.errors import InputError

__all__ = [
    "CONNECT_TIMEOUT",
    "SCHEDULER_TIMEOUT",
    "TaskProgress",
    "check_scheduler",
    "compute_distributed",
    "parse_scheduler_address",
]

#: How long the TCP connection to a scheduler, and its first handshake bytes, may take [s].
CONNECT_TIMEOUT = 5.0
#: How long a ``distributed.Client`` may take to connect once the address answered [s].
SCHEDULER_TIMEOUT = 10.0
#: Address schemes of ``dask.distributed`` whose location is ``host:port``.
NETWORK_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
#: Address schemes without a network location (a scheduler in this process).
LOCAL_SCHEMES = ("inproc",)
#: What an address looks like, for messages.
ADDRESS_EXAMPLE = "tcp://HOST:PORT (e.g. tcp://127.0.0.1:8786)"


class TaskProgress(Callback):
    """A Dask local-scheduler callback that advances a progress bar per finished task.

    Parameters
    ----------
    advance
        Called once per finished task whose key starts with ``prefix``.
    prefix
        Key prefix of the tasks to count.
    """

    def __init__(self, advance: Callable[[], None], prefix: str) -> None:
        super().__init__()
        self._advance = advance
        self._prefix = prefix

    def _posttask(self, key: Any, result: Any, dsk: Any, state: Any, worker_id: Any) -> None:
        name = key[0] if isinstance(key, tuple) else key
        if str(name).startswith(self._prefix):
            self._advance()


# --- the scheduler a stage is given -------------------------------------------------------------


def _expected(local: Sequence[str]) -> str:
    names = f"one of {', '.join(local)}, " if local else ""
    return f"{names}a dask.distributed scheduler address such as {ADDRESS_EXAMPLE} or a Client"


def parse_scheduler_address(address: str) -> tuple[str, str, int | None]:
    """Split a ``dask.distributed`` scheduler address into scheme, host and port.

    Parameters
    ----------
    address
        ``scheme://host:port`` (``tcp``, ``tls``, ``ws``, ``wss``, ``ucx``), ``inproc://...``,
        or ``host:port`` (TCP). An IPv6 host is written in brackets: ``tcp://[::1]:8786``.

    Returns
    -------
    tuple of (str, str, int or None)
        The scheme, the host (the whole location for ``inproc``) and the port (None for
        ``inproc``).

    Raises
    ------
    InputError
        Not an address: an unknown scheme, no host, no port or a port outside 1-65535.

    Examples
    --------
    >>> parse_scheduler_address("tcp://127.0.0.1:8786")
    ('tcp', '127.0.0.1', 8786)
    >>> parse_scheduler_address("[::1]:8786")
    ('tcp', '::1', 8786)
    >>> parse_scheduler_address("garbage")
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: scheduler='garbage': not a scheduler address (no port); \
expected tcp://HOST:PORT (e.g. tcp://127.0.0.1:8786)
    """

    def refuse(why: str) -> InputError:
        return InputError(
            f"scheduler={address!r}: not a scheduler address ({why}); expected {ADDRESS_EXAMPLE}"
        )

    scheme, separator, location = address.strip().rpartition("://")
    scheme = scheme.lower() if separator else "tcp"
    if scheme in LOCAL_SCHEMES:
        if not location:
            raise refuse("nothing after inproc://")
        return scheme, location, None
    if scheme not in NETWORK_SCHEMES:
        known = ", ".join(f"{name}://" for name in (*NETWORK_SCHEMES, *LOCAL_SCHEMES))
        raise refuse(f"unknown scheme {scheme!r}; known: {known}")
    if location.startswith("["):  # IPv6: [host]:port
        host, bracket, tail = location[1:].partition("]")
        port_text = tail[1:] if tail.startswith(":") else None
        if not bracket or (tail and port_text is None):
            raise refuse("an IPv6 host is written [host]:port")
    else:
        host, colon, port_text = location.rpartition(":")
        if not colon:
            host, port_text = location, None
        elif ":" in host:
            raise refuse("an IPv6 host is written in brackets, [host]:port")
    if not host or any(char.isspace() or char in "/?#@" for char in host):
        raise refuse(f"no host name in {location!r}" if not host else f"host {host!r}")
    if not port_text:
        raise refuse("no port")
    if not port_text.isdigit() or not 1 <= int(port_text) <= 65535:
        raise refuse(f"port {port_text!r}; expected 1-65535")
    return scheme, host, int(port_text)


def check_scheduler(
    scheduler: str | Any | None,
    *,
    local: Sequence[str] = (),
    connect: bool = True,
) -> str | Any | None:
    """The scheduler a stage was given, checked before any work.

    Parameters
    ----------
    scheduler
        None (the stage's default), one of ``local`` (a local Dask scheduler), a
        ``distributed.Client``, or a scheduler address (:func:`parse_scheduler_address`).
    local
        The names of the local schedulers the stage accepts (``threads``, ...).
    connect
        Probe an address: a TCP connection within :data:`CONNECT_TIMEOUT` and, for ``tcp://``,
        the first bytes of the scheduler's handshake.

    Returns
    -------
    str, distributed.Client or None
        ``scheduler`` as given (an address stripped of surrounding spaces).

    Raises
    ------
    InputError
        Neither a local name, a Client nor an address; an address that is malformed or where
        no dask scheduler answers (refused, unknown host, silence, timeout).

    Examples
    --------
    >>> check_scheduler("threads", local=("threads", "synchronous"))
    'threads'
    >>> check_scheduler("fast", local=("threads", "synchronous"))
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: scheduler='fast'; expected one of threads, synchronous, a \
dask.distributed scheduler address such as tcp://HOST:PORT (e.g. tcp://127.0.0.1:8786) or a \
Client
    """
    if scheduler is None:
        return None
    if isinstance(scheduler, str):
        if scheduler in local:
            return scheduler
        if local and ":" not in scheduler:  # a local scheduler's name, misspelt
            raise InputError(f"scheduler={scheduler!r}; expected {_expected(local)}")
        try:
            scheme, host, port = parse_scheduler_address(scheduler)
        except InputError as exc:
            message = str(exc)
            if local:
                message = message.replace(
                    f"expected {ADDRESS_EXAMPLE}", f"expected {_expected(local)}"
                )
            raise InputError(message) from None
        address = scheduler.strip()
        if connect and port is not None:
            _probe(address, scheme, host, port)
        return address
    if _is_client(scheduler):
        return scheduler
    raise InputError(f"scheduler of type {type(scheduler).__name__}; expected {_expected(local)}")


def _is_client(value: Any) -> bool:
    """Whether ``value`` is a ``distributed.Client`` (without importing distributed)."""
    return any(
        kind.__name__ == "Client" and kind.__module__.startswith("distributed")
        for kind in type(value).__mro__
    )


def _unreachable(address: str, why: str) -> InputError:
    return InputError(
        f"scheduler={address!r}: cannot connect to a dask scheduler: {why}; expected the "
        "address of a running dask scheduler, tcp://HOST:PORT"
    )


def _probe(address: str, scheme: str, host: str, port: int) -> None:
    """Refuse an address where no dask scheduler answers within :data:`CONNECT_TIMEOUT`."""
    timeout = CONNECT_TIMEOUT
    try:
        connection = socket.create_connection((host, port), timeout=timeout)
    except socket.gaierror:
        raise _unreachable(address, f"unknown host {host!r}") from None
    except ConnectionRefusedError:
        raise _unreachable(address, f"connection refused by {_where(host, port)}") from None
    except TimeoutError:
        raise _unreachable(
            address, f"no answer from {_where(host, port)} in {timeout:g} s"
        ) from None
    except OSError as exc:
        raise _unreachable(address, f"{_where(host, port)}: {exc.strerror or exc}") from None
    with connection:
        if scheme != "tcp":
            return  # TLS and websockets wait for the client to speak first
        try:
            first = connection.recv(1)
        except TimeoutError:
            first = None
        except OSError as exc:
            raise _unreachable(address, f"{_where(host, port)}: {exc.strerror or exc}") from None
    if first is None:
        raise _unreachable(
            address,
            f"{_where(host, port)} accepts connections but sent no dask handshake in "
            f"{timeout:g} s (a dashboard or another service?)",
        )
    if not first:
        raise _unreachable(address, f"{_where(host, port)} closed the connection at once")


def _where(host: str, port: int) -> str:
    try:
        bracket = isinstance(ipaddress.ip_address(host), ipaddress.IPv6Address)
    except ValueError:
        bracket = False
    return f"[{host}]:{port}" if bracket else f"{host}:{port}"


# --- distributed runs --------------------------------------------------------------------------


def compute_distributed(
    tasks: list[Any],
    scheduler: str | Any,
    advance: Callable[[], None],
    consume: Callable[[int, Any], Any] | None = None,
) -> list[Any]:
    """Compute Dask tasks on a ``dask.distributed`` cluster, in order, with progress.

    Parameters
    ----------
    tasks
        Dask collections or delayed objects.
    scheduler
        A scheduler address (``tcp://...``) or a ``distributed.Client``; a client made from
        an address is closed afterwards. An address is checked (:func:`check_scheduler`) and
        the client given :data:`SCHEDULER_TIMEOUT` to connect.
    advance
        Called once per finished task.
    consume
        Called in this process as ``consume(index, result)`` as each result arrives; its
        return value is kept in place of the result (which is then released).

    Returns
    -------
    list
        The results (or what ``consume`` returned) in the order of ``tasks``; on the first
        failure the rest are cancelled and the exception re-raised.

    Raises
    ------
    InputError
        ``scheduler`` is an address that is malformed or where no scheduler answers in time.
    """
    from distributed import Client, as_completed

    own_client = not isinstance(scheduler, Client)
    client = _connect(scheduler) if own_client else scheduler
    assert isinstance(client, Client)
    try:
        futures = client.compute(tasks)
        position = {future.key: index for index, future in enumerate(futures)}
        results: list[Any] = [None] * len(futures)
        try:
            for future in as_completed(futures, loop=client.loop):
                index = position[future.key]
                result = future.result()
                future.release()
                results[index] = result if consume is None else consume(index, result)
                advance()
        except BaseException:
            client.cancel(futures)
            raise
        return results
    finally:
        if own_client:
            client.close()


def _connect(address: Any) -> Any:
    """A ``distributed.Client`` of the scheduler at ``address``, or an InputError.

    A client whose start failed is collected here, while its event loop still runs: left to
    the end of the process, closing it waits for a loop that is gone (a minute's hang).
    """
    from distributed import Client

    checked = check_scheduler(address)
    if not isinstance(checked, str):
        raise InputError(f"scheduler of type {type(address).__name__}; expected {_expected(())}")
    try:
        return Client(checked, set_as_default=False, timeout=SCHEDULER_TIMEOUT)
    except Exception as exc:  # any failure to start is the address's: refused, timeout, garbage
        reason = " ".join(str(exc).split()) or type(exc).__name__
    gc.collect()  # the half-made client (held by the traceback until now) closes now
    raise _unreachable(checked, reason)
