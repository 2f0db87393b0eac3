"""Nonsense that explore must refuse or name: edits whose flux is not finite or beyond any
city's, a sky that is not finite (no Bortle class, null with its reason), lit cells without
terrain under them.

Each refusal leaves the session as it was: the emission, its edit version and its undo and
redo history.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from starlette.testclient import TestClient

from nightlights._validate import MAX_FLUX_DENSITY
from nightlights.brightness import NON_FINITE_SKY
from nightlights.errors import InputError
from nightlights.explore import _session
from nightlights.explore._app import create_app
from nightlights.explore._session import ExploreSession
from nightlights.io import Raster
from nightlights.sky import Scene

from .conftest import CELL, COLS, CRS, OBSERVER, ROWS
from .conftest import Scene as SceneFiles

X, Y = OBSERVER


def _strict(text: str) -> Any:
    """JSON as a strict parser reads it: NaN and Infinity refused."""

    def refuse(constant: str) -> None:
        raise ValueError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


def _lit_centre(scene: SceneFiles) -> tuple[float, float]:
    row, col = np.argwhere(scene.flux > 0)[0]
    return scene.transform * (col + 0.5, row + 0.5)


#: (edit, value, words of the refusal): each would make a cell's flux infinite or beyond the
#: brightest city cell (1e308 is what the browser sends for a typed 1e308).
BAD_EDITS = [
    ("paint", 1e308, ("paint value: 1 flux density values of 1e+308 lm m-2", "MAX_FLUX_DENSITY")),
    ("paint", 2 * MAX_FLUX_DENSITY, ("paint value: 1 flux density values of 200000 lm m-2",)),
    ("scale", 1e308, ("scale by 1e+308: the edited cells:", "inf lm m-2")),
    ("scale", 1e6, ("scale by 1e+06: the edited cells:", "expected finite values up to 100000")),
]


@pytest.mark.parametrize(
    ("op", "value", "words"), BAD_EDITS, ids=[f"{op}-{value:g}" for op, value, _ in BAD_EDITS]
)
def test_an_edit_beyond_any_citys_flux_is_refused_and_changes_nothing(
    make_session: Callable[..., Any],
    scene: SceneFiles,
    op: str,
    value: float,
    words: tuple[str, ...],
) -> None:
    session: ExploreSession = make_session()
    centre = _lit_centre(scene)
    session.edit("scale", [centre], radius=3 * CELL, value=2.0)
    session.undo()  # a redo is pending: a refused edit must not drop it
    before = session.emission().copy()
    flux, version = session.total_flux, session.edit_version
    with pytest.raises(InputError) as refused:
        session.edit(op, [centre], radius=3 * CELL, value=value)
    for word in words:
        assert word in str(refused.value), (word, str(refused.value))
    np.testing.assert_array_equal(session.emission(), before)
    assert (session.total_flux, session.edit_version) == (flux, version)
    assert session.can_redo and not session.can_undo and session._edits.ops == []
    view = session.panorama(X, Y)
    assert np.isfinite(view.zenith_luminance) and view.bortle in range(1, 10)


def test_the_app_refuses_the_edit_and_keeps_answering_a_finite_sky(
    make_session: Callable[..., Any], scene: SceneFiles, tmp_path: Path
) -> None:
    with TestClient(create_app(make_session(), export_dir=tmp_path)) as client:
        centre = list(_lit_centre(scene))
        response = client.post(
            "/api/edit", json={"op": "paint", "points": [centre], "radius": 50.0, "value": 1e308}
        )
        assert response.status_code == 400, response.text
        assert "MAX_FLUX_DENSITY" in response.json()["error"]
        sky = _strict(client.get("/api/panorama", params={"x": X, "y": Y}).text)
        assert sky["zenith_luminance"] is not None and sky["bortle"] in range(1, 10)


@pytest.fixture
def overflowing(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Panoramas whose sky is not finite, as an overflowing emission would give."""
    real = _session.panorama_pca

    def broken(*args: Any, **kwargs: Any) -> np.ndarray:
        luminance = real(*args, **kwargs)
        luminance[0, 0] = np.inf
        luminance[1, 1] = np.nan
        return luminance

    monkeypatch.setattr(_session, "panorama_pca", broken)
    yield


def test_a_sky_that_is_not_finite_has_no_bortle_class(
    make_session: Callable[..., Any], overflowing: None, tmp_path: Path
) -> None:
    session = make_session()
    view = session.panorama(X, Y)
    assert view.bortle is None and view.bortle_reason == NON_FINITE_SKY
    assert np.isnan(view.zenith_luminance)
    shown = _strict(json.dumps(view.to_dict()))
    assert shown["bortle"] is None and shown["zenith_luminance"] is None
    assert "not a finite number" in shown["bortle_reason"]
    with TestClient(create_app(session, export_dir=tmp_path)) as client:
        sky = _strict(client.get("/api/panorama", params={"x": X, "y": Y}).text)
    assert sky["bortle"] is None and sky["bortle_reason"] == NON_FINITE_SKY


# --- terrain ------------------------------------------------------------------------------


def _dem(scene: SceneFiles, hole: tuple[int, int]) -> Raster:
    heights = np.zeros((1, ROWS, COLS))
    heights[0, hole[0], hole[1]] = np.nan
    return Raster(heights, scene.transform, CRS, ("height",), ("m",))


def test_a_dem_with_a_hole_under_a_lit_cell_is_refused(scene: SceneFiles) -> None:
    row, col = np.argwhere(scene.flux > 0)[0]
    with pytest.raises(InputError, match=r"no terrain height under 1 of \d+ lit emission cells"):
        ExploreSession(
            Scene(scene.emission, kernel=scene.kernel, dem=_dem(scene, (row, col))),
            height=0.0,
            progress=False,
        )


def test_painting_over_a_hole_in_the_dem_is_refused(scene: SceneFiles) -> None:
    dark = np.argwhere(scene.flux == 0)
    hole = next((r, c) for r, c in dark if 3 < r < ROWS - 3 and 3 < c < COLS - 3
                and not scene.flux[r - 2 : r + 3, c - 2 : c + 3].any())  # fmt: skip
    session = ExploreSession(
        Scene(scene.emission, kernel=scene.kernel, dem=_dem(scene, hole)),
        height=0.0,
        progress=False,
    )
    before = session.emission().copy()
    x, y = scene.transform * (hole[1] + 0.5, hole[0] + 0.5)
    with pytest.raises(InputError, match="no terrain height under 1 of 1 lit emission cells"):
        session.edit("paint", [(x, y)], radius=0.4 * CELL, value=3.0)
    np.testing.assert_array_equal(session.emission(), before)
    assert not session.can_undo and session.edit_version == 0
