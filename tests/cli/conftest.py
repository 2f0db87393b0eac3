"""Fixtures of the CLI tests: a stand-in for a stage function that records its arguments."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import pytest

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
