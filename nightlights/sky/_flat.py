"""The flat keywords of the sky stages, kept for one release: one decorator turns them into a
:class:`~nightlights.sky.scene.Scene` and :class:`~nightlights.sky.observer.Observer`.

Before the scene and observer objects, every sky stage took the emission first and restated the
scene (``dem``, ``kernel``, ``turbidity``, ``n_elevation``, ``n_azimuth``, ``n_distance``,
``cache_dir``) and the observer (``observer=(x, y)``, ``observer_crs``, ``observer_height``) as
keywords. A call in that form still works, with a :class:`DeprecationWarning`; this module is
the only place that knows those keywords.
"""

from __future__ import annotations

import functools
import os
import warnings
from collections.abc import Callable
from typing import Any, Literal, ParamSpec, TypeVar

import numpy as np

from nightlights.errors import InputError
from nightlights.sky.observer import OBSERVER_HEIGHT, Observer
from nightlights.sky.scene import Scene

__all__ = ["SCENE_KEYWORDS", "flat_keywords"]

P = ParamSpec("P")
R = TypeVar("R")

#: The scene's fields as the flat keywords named them.
SCENE_KEYWORDS = (
    "dem",
    "kernel",
    "turbidity",
    "n_elevation",
    "n_azimuth",
    "n_distance",
    "cache_dir",
)

#: How a stage's flat call named its observers: ``one`` (``observer``, ``observer_crs``,
#: ``observer_height``), ``many`` (``observers`` as (x, y) pairs), ``layer`` (``observers`` as an
#: array, a layer or a file, with ``observers_layer`` and ``names``), ``height`` (only the eye
#: height, as ``height``) or ``none``.
ObserverForm = Literal["one", "many", "layer", "height", "none"]


def flat_keywords(
    *, legacy: tuple[str, ...] = ("output",), observer: ObserverForm = "one"
) -> Callable[[Callable[P, R]], Callable[P, R]]:
    """Accept a stage's former flat call (emission first, scene and observer as keywords).

    Parameters
    ----------
    legacy
        The former positional parameters after the emission, in order.
    observer
        How the former call named its observers (:data:`ObserverForm`).

    Returns
    -------
    callable
        A decorator: calls whose first argument is a :class:`Scene` pass through unchanged.
    """

    def decorate(func: Callable[P, R]) -> Callable[P, R]:
        name = getattr(func, "__qualname__", "stage")

        @functools.wraps(func)
        def stage(*args: Any, **kwargs: Any) -> R:
            first = args[0] if args else kwargs.get("scene")
            if isinstance(first, Scene):
                return func(*args, **kwargs)
            new_args = _flat_call(name, args, kwargs, legacy, observer)
            warnings.warn(
                f"{name}(emission, ..., dem=, kernel=, observer=, ...) with flat keywords is "
                f"deprecated and goes in the next release: call {name}(nightlights.Scene(emission, "
                "...), nightlights.Observer(x, y, ...), ...)",
                DeprecationWarning,
                stacklevel=2,
            )
            return func(*new_args, **kwargs)

        return stage

    return decorate


def _flat_call(
    name: str,
    args: tuple[Any, ...],
    kwargs: dict[str, Any],
    legacy: tuple[str, ...],
    form: ObserverForm,
) -> list[Any]:
    """The new positional arguments (scene, observers) of a flat call; ``kwargs`` is left
    with the stage's own keywords."""
    if args:
        emission, rest = args[0], args[1:]
    elif "emission" in kwargs:
        emission, rest = kwargs.pop("emission"), ()
    else:
        raise TypeError(f"{name}() missing its first argument: a Scene (or an emission)")
    if len(rest) > len(legacy):
        raise TypeError(f"{name}() takes at most {len(legacy) + 1} positional arguments")
    for key, value in zip(legacy, rest, strict=False):
        if key in kwargs:
            raise TypeError(f"{name}() got multiple values for argument {key!r}")
        kwargs[key] = value
    scene = Scene(emission, **{key: kwargs.pop(key) for key in SCENE_KEYWORDS if key in kwargs})
    crs = kwargs.pop("observer_crs", None)
    if form == "height":
        if "observer_height" in kwargs:
            kwargs["height"] = kwargs.pop("observer_height")
        return [scene]
    height = kwargs.pop("observer_height", OBSERVER_HEIGHT)
    if form == "one":
        if "observer" not in kwargs:
            raise TypeError(f"{name}() missing the observer")
        return [scene, Observer.from_point(kwargs.pop("observer"), crs, height=height)]
    if form == "many":
        points = kwargs.pop("observers", ())
        return [scene, tuple(Observer.from_point(p, crs, height=height) for p in points)]
    if form == "layer":
        if "observers" not in kwargs:
            raise TypeError(f"{name}() missing the observers")
        source = kwargs.pop("observers")
        layer = kwargs.pop("observers_layer", None)
        names = kwargs.pop("names", None)
        return [scene, _layer_observers(source, crs, layer, names, height)]
    return [scene]


def _layer_observers(
    source: Any, crs: Any, layer: str | None, names: Any, height: float
) -> tuple[Observer, ...]:
    """Observers of a flat ``observers=`` argument: an (n, 2) array, a layer or a file."""
    import geopandas as gpd

    if isinstance(source, gpd.GeoDataFrame | str | os.PathLike):
        return Observer.from_layer(source, layer_name=layer, crs=crs, height=height, names=names)
    if layer is not None:
        raise InputError(f"observers_layer={layer!r} names a layer of a file of observers")
    points = np.asarray(source, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2:
        raise InputError(f"observers of shape {points.shape}; expected (n, 2) coordinates (x, y)")
    labels = [None] * len(points) if names is None else [str(v) for v in names]
    if len(labels) != len(points):
        raise InputError(f"{len(labels)} names for {len(points)} observers")
    out = []
    for index, (point, label) in enumerate(zip(points, labels, strict=True)):
        try:
            out.append(Observer(point[0], point[1], crs, height, label))
        except InputError as exc:
            raise type(exc)(f"observers: observer {index}: {exc}") from None
    return tuple(out)
