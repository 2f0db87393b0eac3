"""Dimming schedules: a level per local clock time, part-night switch-off as level 0.

A :class:`DimmingSchedule` is a list of steps ``(clock time, level)`` in the local time of a
zone: the level of a step holds from its clock time until the next step's, round the clock
(the last step of the night holds until the first of the next). A level is the fraction of
the luminaire's full power (0 to 1; 0 is a part-night switch-off); it applies only while the
photocell has the lights on (:mod:`nightlights.roads._burning`). The steps are written in the
order of a night, from evening to morning (``22:00=0.5,05:00=1``): their clock times must
increase, wrapping past midnight at most once, and differ.

The zone is an IANA name read by :mod:`zoneinfo` (the steps follow daylight saving time: a
clock time on the day of a change maps to UTC with the offset :mod:`datetime` gives it,
``fold=0``) or a fixed offset (``UTC``, ``+01:00``, ``-05:30``). The level is piecewise
constant in UTC between the step instants, so its integral over an interval is exact
(:func:`scheduled_hours`).
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass
from datetime import UTC, date, datetime, time, timedelta
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.errors import InputError

__all__ = ["DimmingSchedule", "parse_schedule", "schedule_level", "scheduled_hours"]

#: A fixed UTC offset: ``UTC``, ``Z``, ``+01:00``, ``UTC-05:30``, ``+2``.
_OFFSET = re.compile(r"^(?:UTC|GMT)?\s*(?:(?P<sign>[+-])(?P<h>\d{1,2})(?::?(?P<m>\d{2}))?)?$")
#: One step of the schedule syntax: ``HH:MM=level`` or ``HH:MM:SS=level``.
_STEP = re.compile(r"^(?P<h>\d{1,2}):(?P<m>\d{2})(?::(?P<s>\d{2}))?=(?P<level>[^=]+)$")
#: Days of steps laid before and after a span, so that a UTC offset of up to 14 h (and a day
#: wrapped by the night's order) still finds the level in force [d].
_MARGIN_DAYS = 2


def _seconds_of_day(clock: time) -> float:
    return clock.hour * 3600.0 + clock.minute * 60.0 + clock.second + clock.microsecond / 1e6


def _zone(zone: str) -> ZoneInfo | timedelta:
    """The zone of a schedule: a ZoneInfo or a fixed offset east of UTC."""
    if not isinstance(zone, str) or not zone.strip():
        raise InputError(f"zone={zone!r}; expected an IANA zone name or a UTC offset like +01:00")
    match = _OFFSET.match(zone.strip().upper())
    if match:
        if match["sign"] is None:
            return timedelta(0)
        hours, minutes = int(match["h"]), int(match["m"] or 0)
        if hours > 14 or minutes >= 60:
            raise InputError(f"zone={zone!r}; a UTC offset is -14:00 to +14:00")
        offset = timedelta(hours=hours, minutes=minutes)
        return offset if match["sign"] == "+" else -offset
    try:
        return ZoneInfo(zone.strip())
    except (ZoneInfoNotFoundError, ValueError):
        raise InputError(
            f"zone={zone!r} is no IANA time zone; expected a name like 'Europe/Berlin' "
            "or a UTC offset like +01:00"
        ) from None


@dataclass(frozen=True)
class DimmingSchedule:
    """Dimming levels by local clock time.

    Parameters
    ----------
    steps : sequence of (datetime.time, float)
        Clock time from which a level holds and the level [1] (0 to 1 of full power), in the
        order of a night (times increasing, wrapping past midnight at most once).
    zone : str
        IANA zone name (``'Europe/Berlin'``) or fixed UTC offset (``'+01:00'``, ``'UTC'``).

    Raises
    ------
    InputError
        No steps, a level outside 0 to 1, a time that is not a naive clock time, repeated or
        unordered times, an unknown zone.

    Examples
    --------
    >>> s = DimmingSchedule(((time(22), 0.5), (time(5), 1.0)), "+01:00")
    >>> s.level_at(time(23)), s.level_at(time(12))
    (0.5, 1.0)
    """

    steps: tuple[tuple[time, float], ...]
    zone: str

    def __post_init__(self) -> None:
        steps = tuple((clock, level) for clock, level in self.steps)
        if not steps:
            raise InputError("steps=(); expected at least one (time, level) step")
        for clock, level in steps:
            if not isinstance(clock, time) or clock.tzinfo is not None:
                raise InputError(
                    f"steps: {clock!r} is no clock time; expected a naive datetime.time "
                    "(the zone is given by zone=)"
                )
            if isinstance(level, bool) or not isinstance(level, (int, float, np.number)):
                raise InputError(f"steps: level {level!r} at {clock}; expected a number")
            if not (math.isfinite(float(level)) and 0.0 <= float(level) <= 1.0):
                raise InputError(
                    f"steps: level {level!r} at {clock}; expected 0 to 1 of full power "
                    "(0 switches off)"
                )
        seconds = [_seconds_of_day(clock) for clock, _ in steps]
        if len(set(seconds)) < len(seconds):
            raise InputError(f"steps: times {[str(c) for c, _ in steps]} repeat a time")
        descents = sum(b < a for a, b in itertools.pairwise(seconds))
        if descents > 1 or (descents == 1 and seconds[-1] >= seconds[0]):
            raise InputError(
                f"steps: times {[str(c) for c, _ in steps]} are not in the order of a night; "
                "expected increasing times, wrapping past midnight at most once"
            )
        _zone(self.zone)
        object.__setattr__(self, "steps", tuple((c, float(v)) for c, v in steps))

    def level_at(self, clock: time) -> float:
        """The level at a local clock time [1]."""
        order = sorted(self.steps, key=lambda step: _seconds_of_day(step[0]))
        now = _seconds_of_day(clock)
        level = order[-1][1]
        for start, value in order:
            if _seconds_of_day(start) <= now:
                level = value
        return level


def parse_schedule(text: str, zone: str) -> DimmingSchedule:
    """A schedule from its short form ``"22:00=0.5,05:00=1"``.

    Parameters
    ----------
    text : str
        Comma-separated ``HH:MM=level`` (or ``HH:MM:SS=level``) steps in the order of a night;
        a level of 0 is a part-night switch-off. Spaces are ignored.
    zone : str
        IANA zone name or fixed UTC offset of the clock times.

    Returns
    -------
    DimmingSchedule

    Raises
    ------
    InputError
        Bad syntax, a level outside 0 to 1, repeated or unordered times, an unknown zone.

    Examples
    --------
    >>> parse_schedule("23:00=0, 05:30=1", "Europe/Berlin").steps
    ((datetime.time(23, 0), 0.0), (datetime.time(5, 30), 1.0))
    """
    if not isinstance(text, str) or not text.strip():
        raise InputError(f"schedule={text!r}; expected steps like '22:00=0.5,05:00=1'")
    steps: list[tuple[time, float]] = []
    for part in text.replace(" ", "").split(","):
        match = _STEP.match(part)
        if match is None:
            raise InputError(
                f"schedule={text!r}: {part!r} is no step; expected HH:MM=level, "
                "like '22:00=0.5,05:00=1'"
            )
        hour, minute, second = int(match["h"]), int(match["m"]), int(match["s"] or 0)
        if hour > 23 or minute > 59 or second > 59:
            raise InputError(f"schedule={text!r}: {part!r} is no clock time (00:00 to 23:59)")
        try:
            level = float(match["level"])
        except ValueError:
            raise InputError(
                f"schedule={text!r}: level {match['level']!r} is no number; expected 0 to 1"
            ) from None
        steps.append((time(hour, minute, second), level))
    return DimmingSchedule(tuple(steps), zone)


def _breakpoints(
    schedule: DimmingSchedule, first: float, last: float
) -> tuple[FloatArray, FloatArray]:
    """UTC instants [Unix s] at which the schedule's steps start, covering [first, last], and
    the level from each."""
    zone = _zone(schedule.zone)
    day0 = datetime.fromtimestamp(first, UTC).date() - timedelta(days=_MARGIN_DAYS)
    day1 = datetime.fromtimestamp(last, UTC).date() + timedelta(days=_MARGIN_DAYS)
    days = (day1 - day0).days + 1
    clocks = [clock for clock, _ in schedule.steps]
    levels = np.array([level for _, level in schedule.steps])
    if isinstance(zone, timedelta):
        base = (
            np.datetime64(day0.isoformat(), "s").astype(np.int64)
            + 86400.0 * np.arange(days)[:, None]
        )
        at = base + np.array([_seconds_of_day(c) for c in clocks]) - zone.total_seconds()
    else:
        at = np.array(
            [
                [
                    datetime.combine(date.fromordinal(day0.toordinal() + d), c, tzinfo=zone)
                    .astimezone(UTC)
                    .timestamp()
                    for c in clocks
                ]
                for d in range(days)
            ]
        )
    flat = at.ravel()
    order = np.argsort(flat, kind="stable")
    return flat[order], np.tile(levels, days)[order]


def _instants(instants: ArrayLike, name: str) -> FloatArray:
    try:
        times = np.asarray(instants, dtype="datetime64[us]")
    except (TypeError, ValueError):
        raise InputError(
            f"{name} are not UTC instants; expected numpy.datetime64 or ISO 8601 strings"
        ) from None
    if np.isnat(times).any():
        raise InputError(f"{name} hold NaT; expected UTC instants")
    return times.astype(np.int64) / 1e6


def schedule_level(schedule: DimmingSchedule | None, instants: ArrayLike) -> FloatArray:
    """The level in force at UTC instants.

    Parameters
    ----------
    schedule : DimmingSchedule or None
        The schedule; None is full power throughout.
    instants : array_like of datetime64
        UTC instants.

    Returns
    -------
    ndarray
        Level [1], the shape of ``instants``.

    Examples
    --------
    >>> s = parse_schedule("22:00=0.5,05:00=1", "+02:00")
    >>> at = np.array(["2024-06-01T21:00", "2024-06-02T02:59"], "datetime64[m]")
    >>> schedule_level(s, at).tolist()
    [0.5, 0.5]
    """
    seconds = _instants(instants, "instants")
    if schedule is None or seconds.size == 0:
        return np.ones_like(seconds)
    at, levels = _breakpoints(schedule, float(seconds.min()), float(seconds.max()))
    index = np.searchsorted(at, seconds, side="right") - 1
    return np.asarray(levels[index], dtype=float)


def scheduled_hours(
    schedule: DimmingSchedule | None,
    on: ArrayLike,
    off: ArrayLike,
) -> FloatArray:
    """Integral of the level over intervals: full-power equivalent hours, exactly.

    Parameters
    ----------
    schedule : DimmingSchedule or None
        The schedule; None is full power throughout.
    on, off : array_like of datetime64
        Starts and ends of the intervals (UTC), ``off >= on``.

    Returns
    -------
    ndarray
        :math:`\\int_{on}^{off} L(t)\\,dt` of each interval [h]; with no schedule, its length.

    Examples
    --------
    >>> s = parse_schedule("00:00=0,05:00=1", "UTC")
    >>> on = np.array(["2024-01-01T17:00"], "datetime64[m]")
    >>> off = np.array(["2024-01-02T07:00"], "datetime64[m]")
    >>> scheduled_hours(s, on, off).tolist()  # 17-24 h and 5-7 h burn, 0-5 h off
    [9.0]
    """
    start, end = _instants(on, "on"), _instants(off, "off")
    if start.shape != end.shape:
        raise InputError(f"on and off have shapes {start.shape} and {end.shape}; expected one")
    if (end < start).any():
        raise InputError("off precedes on in some intervals; expected off >= on")
    if schedule is None or start.size == 0:
        return (end - start) / 3600.0
    at, levels = _breakpoints(schedule, float(start.min()), float(end.max()))
    cumulative = np.concatenate([[0.0], np.cumsum(levels[:-1] * np.diff(at))])

    def integral(t: FloatArray) -> FloatArray:
        k = np.searchsorted(at, t, side="right") - 1
        return np.asarray(cumulative[k] + levels[k] * (t - at[k]), dtype=float)

    return (integral(end) - integral(start)) / 3600.0
