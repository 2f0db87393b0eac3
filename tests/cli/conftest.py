"""Fixtures of the CLI tests: a stand-in for a stage function that records its arguments, and
small input layers."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import geopandas as gpd
import pytest
from shapely.geometry import Point

import nightlights


@dataclass
class Recorder:
    """Calls of a stand-in stage: ``args`` and ``kwargs`` of each."""

    result: Any
    calls: list[tuple[tuple[Any, ...], dict[str, Any]]] = field(default_factory=list)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        self.calls.append((args, kwargs))
        return self.result

    @property
    def args(self) -> tuple[Any, ...]:
        """Positional arguments of the only call."""
        assert len(self.calls) == 1, self.calls
        return self.calls[0][0]

    @property
    def kwargs(self) -> dict[str, Any]:
        """Keyword arguments of the only call."""
        assert len(self.calls) == 1, self.calls
        return self.calls[0][1]


@pytest.fixture
def fake_stage(monkeypatch: pytest.MonkeyPatch) -> Callable[[str, Any], Recorder]:
    """Replace ``nightlights.<name>`` (what the commands call) by a recorder returning
    ``result``; the commands' parsing is tested without running the stage."""

    def install(name: str, result: Any) -> Recorder:
        recorder = Recorder(result)
        monkeypatch.setattr(nightlights, name, recorder, raising=False)
        return recorder

    return install


@pytest.fixture
def lights(tmp_path: Path) -> Path:
    """Three street lights of the bundled luminaire database (EPSG:3067)."""
    path = tmp_path / "lights.gpkg"
    gpd.GeoDataFrame(
        {
            "light_id": [1, 2, 3],
            "street_id": ["a", "a", "b"],
            "system_id": ["street_led_medium", "street_led_small", "road_hps"],
            "heading": [90.0, 270.0, 0.0],
            "mounting_height": [10.0, None, 12.0],
            "arm_length": [1.0, 0.5, None],
            "tilt": [0.0, 5.0, 0.0],
            "side": ["left", "right", "center"],
            "arrangement": ["opposite", "opposite", "central"],
        },
        geometry=[Point(385_000, 6_672_000), Point(385_020, 6_672_000), Point(385_010, 6_672_040)],
        crs="EPSG:3067",
    ).to_file(path, layer="lights", driver="GPKG")
    return path
