"""The emission-function vocabulary is a leaf: the ground's emission stages load no sky module,
and the sky package's earlier paths hand on the same objects (one registry of shapes)."""

from __future__ import annotations

import subprocess
import sys

import nightlights.sky.emission_shapes as sky_shapes
import nightlights.sky.spec as spec
from nightlights import emission_functions


def test_the_ground_writes_the_tag_without_loading_the_sky() -> None:
    code = (
        "import sys, nightlights.ground.upward; "
        "print(sorted(m for m in sys.modules if m.startswith('nightlights.sky')))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "[]"


def test_the_sky_packages_paths_hand_on_the_same_objects() -> None:
    for name in sky_shapes.__all__:
        assert getattr(sky_shapes, name) is getattr(emission_functions, name), name
    for name in ("DEFAULT_EMISSION_FUNCTION", "EMISSION_FUNCTION_TAG", "EmissionFunction"):
        assert getattr(spec, name) is getattr(emission_functions, name), name
    assert set(sky_shapes.__all__) | {
        "DEFAULT_EMISSION_FUNCTION",
        "EMISSION_FUNCTION_TAG",
        "EmissionFunction",
    } == set(emission_functions.__all__)
