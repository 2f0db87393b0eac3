"""Stage caching by content hashes, recorded beside the outputs.

A stage's *key* is the SHA-256 of what it depends on: its name, its options, the observer it
runs for, the seed, and the content hashes of its input files (the project's inputs, or the
outputs of the stages upstream). When a stage finishes, a record is written in
``<output>/.nightlights/<task>.json``: the key, and each output's SHA-256, size and
modification time. A stage is skipped when its record's key equals the new key and every
output is still there with the recorded content (size and modification time unchanged, else
hashed again). A stage that reruns first loses its record and its old outputs; its new outputs
are written into a staging folder and moved into place (with their style sidecars) only when
it has finished, and its record comes last, so an interrupted run (Ctrl-C) leaves no output
that looks complete.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nightlights.io.jsonfile import dumps_json
from nightlights.io.outputs import sidecar_paths

#: Folder of the records and the staging folders, inside the output folder.
RECORD_FOLDER = ".nightlights"
#: Bytes read at a time when hashing a file.
_CHUNK = 1 << 20


def file_hash(path: Path) -> str:
    """SHA-256 of a file's content, or of a folder's files (names and contents, sorted)."""
    digest = hashlib.sha256()
    if path.is_dir():
        for child in sorted(p for p in path.rglob("*") if p.is_file()):
            digest.update(str(child.relative_to(path)).encode())
            digest.update(file_hash(child).encode())
        return digest.hexdigest()
    with path.open("rb") as stream:
        while block := stream.read(_CHUNK):
            digest.update(block)
    return digest.hexdigest()


def stage_key(parts: Mapping[str, Any]) -> str:
    """SHA-256 of a stage's dependencies (JSON with sorted keys; paths as text)."""
    text = json.dumps(parts, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class Record:
    """What a finished stage left: its key, outputs (name -> file state) and facts."""

    key: str
    outputs: dict[str, dict[str, Any]]
    facts: dict[str, Any]
    seconds: float


def _state(path: Path) -> dict[str, Any]:
    stat = path.stat()
    return {
        "file": path.name,
        "sha256": file_hash(path),
        "size": stat.st_size if path.is_file() else None,
        "mtime_ns": stat.st_mtime_ns,
    }


class StageCache:
    """The records of one output folder.

    Parameters
    ----------
    folder
        The project's output folder (created if missing).
    """

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.records = folder / RECORD_FOLDER

    def _ensure(self) -> None:
        self.records.mkdir(parents=True, exist_ok=True)

    def clean(self) -> None:
        """Remove staging folders that a killed run left behind (a run cleans its own)."""
        if self.records.is_dir():
            for folder in self.records.glob("*.partial"):
                shutil.rmtree(folder, ignore_errors=True)

    def _record_path(self, task: str) -> Path:
        return self.records / f"{task.replace(':', '@')}.json"

    def valid(self, task: str, key: str) -> Record | None:
        """The record of ``task`` when its key is ``key`` and its outputs are intact."""
        path = self._record_path(task)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            record = Record(data["key"], data["outputs"], data["facts"], data["seconds"])
        except (OSError, ValueError, KeyError, TypeError):
            return None
        if record.key != key:
            return None
        for state in record.outputs.values():
            if not self._intact(self.folder / state["file"], state):
                return None
        return record

    @staticmethod
    def _intact(path: Path, state: Mapping[str, Any]) -> bool:
        if not path.exists():
            return False
        stat = path.stat()
        if (
            path.is_file()
            and stat.st_size == state["size"]
            and stat.st_mtime_ns == state["mtime_ns"]
        ):
            return True
        return file_hash(path) == state["sha256"]

    def forget(self, task: str, files: list[str]) -> None:
        """Remove the record of ``task`` (first) and its old output files."""
        self._ensure()
        with contextlib.suppress(FileNotFoundError):
            self._record_path(task).unlink()
        for name in files:
            path = self.folder / name
            if path.is_dir():
                shutil.rmtree(path)
                continue
            for file in (path, *sidecar_paths(path)):
                with contextlib.suppress(FileNotFoundError):
                    file.unlink()

    @contextlib.contextmanager
    def staging(self, task: str) -> Iterator[Path]:
        """A fresh staging folder for ``task``'s outputs, removed when the block ends."""
        self._ensure()
        folder = Path(
            tempfile.mkdtemp(
                prefix=f"{task.replace(':', '@')}.", suffix=".partial", dir=self.records
            )
        )
        try:
            yield folder
        finally:
            shutil.rmtree(folder, ignore_errors=True)

    def commit(
        self,
        task: str,
        key: str,
        staged: Mapping[str, Path],
        facts: Mapping[str, Any],
        seconds: float,
    ) -> Record:
        """Move the staged outputs into the output folder, then write the record.

        Parameters
        ----------
        task
            Task name.
        key
            Its key.
        staged
            Output name -> staged path (a file or folder the stage wrote).
        facts
            Figures to keep with the record (JSON-serialisable).
        seconds
            Time the stage took [s].

        Returns
        -------
        Record
            The record written.
        """
        final: dict[str, Path] = {}
        for name, path in staged.items():
            target = self.folder / path.name
            if target.is_dir():
                shutil.rmtree(target)
            for sidecar, destination in zip(
                sidecar_paths(path), sidecar_paths(target), strict=True
            ):
                if sidecar.exists():
                    os.replace(sidecar, destination)
            os.replace(path, target)
            final[name] = target
        states = {name: _state(path) for name, path in final.items()}
        record = {
            "task": task,
            "key": key,
            "outputs": states,
            "facts": dict(facts),
            "seconds": seconds,
        }
        path = self._record_path(task)
        temporary = path.with_name(f".{path.name}.tmp")
        temporary.write_text(dumps_json(record, indent=1, default=str), encoding="utf-8")
        os.replace(temporary, path)
        return Record(key, states, dict(facts), seconds)
