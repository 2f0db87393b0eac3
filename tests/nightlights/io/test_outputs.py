"""Tests of nightlights.io.outputs: all-or-nothing outputs, up-front checks, SIGTERM clean-up."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from nightlights.errors import OutputError
from nightlights.io import OutputSet, Terminated, atomic_output
from nightlights.io import outputs as outputs_module
from nightlights.io.outputs import refuse_replacing_inputs, replaced_input


def listing(folder: Path) -> dict[str, bytes | None]:
    """File names and contents of ``folder`` (sub-folders as None)."""
    return {p.name: None if p.is_dir() else p.read_bytes() for p in folder.iterdir()}


@pytest.fixture
def previous(tmp_path: Path) -> Path:
    """Two previous outputs, ``a.txt`` and ``b.txt``."""
    (tmp_path / "a.txt").write_text("old a")
    (tmp_path / "b.txt").write_text("old b")
    return tmp_path


def test_outputs_appear_together(tmp_path: Path) -> None:
    a, b = tmp_path / "a.nc", tmp_path / "b.png"
    with OutputSet(a, None, b) as outputs:
        outputs.temporary(a).write_text("A")
        assert not a.exists()
        outputs.temporary(b).write_text("B")
        assert outputs.temporary(b).suffix == ".png"
        assert outputs.temporary(b).parent == tmp_path
    assert listing(tmp_path) == {"a.nc": b"A", "b.png": b"B"}


def test_failure_leaves_previous_outputs_and_no_temporaries(previous: Path) -> None:
    before = listing(previous)
    with pytest.raises(RuntimeError, match="mid-write"):
        with OutputSet(previous / "a.txt", previous / "b.txt") as outputs:
            outputs.temporary(previous / "a.txt").write_text("new a")
            temporary = outputs.temporary(previous / "b.txt")
            temporary.write_text("half")
            Path(f"{temporary}.ovr.tmp").write_text("gdal overview")
            Path(f"{temporary}.aux.xml").write_text("gdal side file")
            raise RuntimeError("crash mid-write")
    assert listing(previous) == before


@pytest.mark.parametrize(
    ("make_paths", "words"),
    [
        (lambda d: [d / "a.txt", d / "nodir" / "p.png"], ["nodir", "does not exist"]),
        (lambda d: [d / "a.txt", d / "a.txt"], ["a.txt", "twice"]),
        (lambda d: [d / "a.txt", d / "sub" / ".." / "a.txt"], ["twice"]),
        (lambda d: [d / "a.txt", d], ["is a folder"]),
        (lambda d: [d / "a.txt" / "x.png"], ["a.txt", "not a folder"]),
    ],
    ids=["missing-folder", "duplicate", "duplicate-spelled-apart", "folder", "file-as-folder"],
)
def test_bad_locations_are_refused_before_anything_is_written(
    previous: Path, make_paths, words: list[str]
) -> None:
    (previous / "sub").mkdir()
    before = listing(previous / "sub"), listing(previous)
    with pytest.raises(OutputError) as info:
        OutputSet(*make_paths(previous))
    for word in words:
        assert word in str(info.value)
    assert (listing(previous / "sub"), listing(previous)) == before


def test_existing_output_without_overwrite_is_refused(previous: Path) -> None:
    with pytest.raises(OutputError, match=r"a\.txt: exists and overwrite is off"):
        OutputSet(previous / "new.txt", previous / "a.txt", overwrite=False)


def test_read_only_folder_is_refused_with_its_path(tmp_path: Path, read_only) -> None:
    folder = tmp_path / "ro"
    folder.mkdir()
    with read_only(folder):
        with pytest.raises(OutputError, match=r"out\.tif: cannot write to folder .*ro"):
            OutputSet(folder / "out.tif")
        with pytest.raises(OutputError, match=r"permission denied|read-only"):
            with atomic_output(folder / "out.tif"):
                pass  # pragma: no cover - refused on entry
        assert list(folder.iterdir()) == []


def test_permission_error_becomes_output_error(tmp_path: Path, monkeypatch) -> None:
    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(outputs_module.tempfile, "mkstemp", refuse)
    with pytest.raises(OutputError, match=r"p\.png: cannot write to folder .*: permission denied"):
        OutputSet(tmp_path / "p.png")


def test_too_little_disk_space_is_refused(tmp_path: Path) -> None:
    with pytest.raises(
        OutputError, match=r"a\.tif: the outputs need about 4\.0 EiB of disk space, only"
    ):
        OutputSet(tmp_path / "a.tif", free_bytes=2.0**62)


def test_an_output_the_block_did_not_write_is_an_error(previous: Path) -> None:
    before = listing(previous)
    with pytest.raises(OutputError, match=r"b\.txt: the writer produced no file"):
        with OutputSet(previous / "a.txt", previous / "b.txt") as outputs:
            outputs.temporary(previous / "a.txt").write_text("new a")
    assert listing(previous) == before


def test_a_failed_rename_restores_the_outputs_renamed_before(previous: Path, monkeypatch) -> None:
    before = listing(previous)
    real_replace = os.replace

    def replace(source, target):
        if Path(target).name == "b.txt":
            raise PermissionError(13, "Permission denied")
        real_replace(source, target)

    monkeypatch.setattr(outputs_module.os, "replace", replace)
    with pytest.raises(OutputError, match=r"b\.txt: cannot write: permission denied"):
        with OutputSet(previous / "a.txt", previous / "b.txt", previous / "c.txt") as outputs:
            for name in ("a.txt", "b.txt", "c.txt"):
                outputs.temporary(previous / name).write_text("new")
    monkeypatch.undo()
    assert listing(previous) == before


def test_temporary_of_another_path_is_a_key_error(tmp_path: Path) -> None:
    with OutputSet(tmp_path / "a.txt") as outputs:
        outputs.temporary(tmp_path / "a.txt").write_text("a")
        with pytest.raises(KeyError, match="not an output"):
            outputs.temporary(tmp_path / "b.txt")


def test_atomic_output_keeps_its_signature(tmp_path: Path) -> None:
    target = tmp_path / "x.tif"
    with atomic_output(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".tif" and not tmp.exists()
        tmp.write_text("x")
    assert listing(tmp_path) == {"x.tif": b"x"}
    with pytest.raises(OutputError, match="exists and overwrite is off"):
        with atomic_output(target, overwrite=False):
            pass  # pragma: no cover - refused on entry


# --- SIGTERM -------------------------------------------------------------------------------


@pytest.fixture
def recorded_sigterm() -> Iterator[list[int]]:
    """A Python SIGTERM handler that records signals (so the test process survives)."""
    received: list[int] = []
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: received.append(signum))
    try:
        yield received
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_sigterm_removes_temporaries_and_is_delivered_again(
    previous: Path, recorded_sigterm: list[int]
) -> None:
    before = listing(previous)
    handler = signal.getsignal(signal.SIGTERM)
    with pytest.raises(Terminated):
        with OutputSet(previous / "a.txt", previous / "b.txt") as outputs:
            assert signal.getsignal(signal.SIGTERM) is not handler
            with atomic_output(outputs.temporary(previous / "a.txt")) as inner:
                inner.write_text("new a")
                Path(f"{inner}.ovr.tmp").write_text("overview")
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(5)  # interrupted by the handler
    assert listing(previous) == before
    assert signal.getsignal(signal.SIGTERM) is handler
    assert recorded_sigterm == [signal.SIGTERM]


def test_sigterm_during_the_commit_is_held_until_it_is_done(
    previous: Path, recorded_sigterm: list[int], monkeypatch
) -> None:
    real_replace = os.replace

    def replace(source, target):
        real_replace(source, target)
        if Path(target).name == "a.txt":
            os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(outputs_module.os, "replace", replace)
    with OutputSet(previous / "a.txt", previous / "b.txt") as outputs:
        outputs.temporary(previous / "a.txt").write_text("new a")
        outputs.temporary(previous / "b.txt").write_text("new b")
    assert listing(previous) == {"a.txt": b"new a", "b.txt": b"new b"}
    assert recorded_sigterm == [signal.SIGTERM]


def test_outputs_in_a_worker_thread_leave_signal_handlers_alone(tmp_path: Path) -> None:
    handler = signal.getsignal(signal.SIGTERM)
    seen: list[object] = []

    def write() -> None:
        with atomic_output(tmp_path / "t.txt") as tmp:
            seen.append(signal.getsignal(signal.SIGTERM))
            tmp.write_text("t")

    thread = threading.Thread(target=write)
    thread.start()
    thread.join()
    assert seen == [handler]
    assert listing(tmp_path) == {"t.txt": b"t"}


WRITER = textwrap.dedent(
    """
    import sys
    import numpy as np
    from affine import Affine
    from nightlights.io import RasterBand, write_cog

    data = np.random.default_rng(0).random((4000, 4000), dtype=np.float32)
    write_cog(sys.argv[1], [RasterBand(data, "noise", "1")], transform=Affine(10, 0, 0, 0, -10, 0),
              crs="EPSG:3067", blocksize=256)
    """
)


def test_sigterm_during_a_cog_write_leaves_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "out.tif"
    target.write_bytes(b"previous output")
    process = subprocess.Popen([sys.executable, "-c", WRITER, str(target)])
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob(".out.tif.*.tmp.tif*")):  # GDAL is writing
        assert process.poll() is None, "the writer ended before it wrote"
        assert time.monotonic() < deadline
        time.sleep(0.005)
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=60) == -signal.SIGTERM  # 143 from a shell
    assert listing(tmp_path) == {"out.tif": b"previous output"}


# --- no output replaces an input ------------------------------------------------------------


def _same_path(folder: Path, source: Path) -> Path:
    return source


def _relative(folder: Path, source: Path) -> Path:
    return Path(os.path.relpath(source))


def _through_dotdot(folder: Path, source: Path) -> Path:
    (folder / "sub").mkdir(exist_ok=True)
    return folder / "sub" / ".." / source.name


def _symlink(folder: Path, source: Path) -> Path:
    link = folder / "link.tif"
    link.symlink_to(source)
    return link


def _linked_folder(folder: Path, source: Path) -> Path:
    link = folder / "linked"
    link.symlink_to(folder, target_is_directory=True)
    return link / source.name


def _hard_link(folder: Path, source: Path) -> Path:
    link = folder / "hard.tif"
    os.link(source, link)
    return link


def _other_case(folder: Path, source: Path) -> Path:
    other = source.with_name(source.name.upper())
    if not other.exists():
        pytest.skip("the disk tells names apart by case")
    return other


#: Ways to name the input ``e.tif`` as an output (the output path, built in the folder).
SAME_FILE = {
    "same path": _same_path,
    "relative path": _relative,
    "through ..": _through_dotdot,
    "symbolic link": _symlink,
    "through a linked folder": _linked_folder,
    "hard link": _hard_link,
    "other case": _other_case,
}


@pytest.mark.parametrize("overwrite", [True, False], ids=["overwrite", "no-overwrite"])
@pytest.mark.parametrize("name", list(SAME_FILE))
def test_an_output_that_is_an_input_is_refused(
    tmp_path: Path, monkeypatch, name: str, overwrite: bool
) -> None:
    monkeypatch.chdir(tmp_path)
    source = tmp_path / "e.tif"
    source.write_bytes(b"emission")
    output = SAME_FILE[name](tmp_path, source)
    with pytest.raises(OutputError) as error:
        OutputSet(tmp_path / "q.png", output, overwrite=overwrite, inputs={"emission": source})
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(f"{output}: is the input emission ({source})"), message
    assert "an output never replaces an input" in message
    with pytest.raises(OutputError, match="is the input emission"):
        with atomic_output(output, inputs={"emission": source}):
            pass  # pragma: no cover - refused on entry
    assert source.read_bytes() == b"emission"
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_inputs_that_are_no_files_are_skipped(tmp_path: Path) -> None:
    output = tmp_path / "osm"
    output.write_text("previous")
    inputs = {"mapping": "osm", "raster": object(), "dem": None, "albedo": 0.1}
    with OutputSet(output, inputs={**inputs, "missing": tmp_path / "missing.tif"}) as outputs:
        outputs.temporary(output).write_text("new")
    assert output.read_text() == "new"


def test_an_output_in_an_input_folder_or_holding_an_input_is_refused(tmp_path: Path) -> None:
    catalog = tmp_path / "catalog"
    catalog.mkdir()
    (catalog / "lights.csv").write_text("table")
    with pytest.raises(OutputError, match=r"lies in the input folder catalog .* its files"):
        OutputSet(catalog / "lights.csv", inputs={"catalog": catalog})
    OutputSet(catalog / "new.gpkg", inputs={"catalog": catalog})  # adds a file, replaces none
    streets = catalog / "streets.gpkg"
    streets.write_text("streets")
    with pytest.raises(OutputError, match=r"holds the input streets .* would replace it"):
        refuse_replacing_inputs([catalog], {"streets": streets})
    with pytest.raises(OutputError, match=r"catalog: is the input network"):
        refuse_replacing_inputs([catalog], {"network": str(catalog)})
    assert (catalog / "lights.csv").read_text() == "table"
    assert replaced_input(tmp_path / "elsewhere.tif", {"catalog": catalog}) is None


# --- SIGTERM between two outputs of a block (terminate_cleanly) -----------------------------

STAGED = textwrap.dedent(
    """
    import shutil, sys, tempfile, time
    from pathlib import Path
    from nightlights.io import atomic_output
    from nightlights.io.outputs import terminate_cleanly

    folder = Path(sys.argv[1])
    guarded = sys.argv[2] == "guarded"
    def stage():
        staging = Path(tempfile.mkdtemp(suffix=".partial", dir=folder))
        try:
            with atomic_output(staging / "first.tif") as tmp:
                tmp.write_text("first")
            print("between", flush=True)
            time.sleep(30)  # no output open: SIGTERM arrives here
            with atomic_output(staging / "second.png") as tmp:
                tmp.write_text("second")
        finally:
            shutil.rmtree(staging)
    if guarded:
        with terminate_cleanly():
            stage()
    else:
        stage()
    """
)


@pytest.mark.parametrize("guarded", [True, False], ids=["terminate_cleanly", "unguarded"])
def test_sigterm_between_two_outputs_cleans_up_under_terminate_cleanly(
    tmp_path: Path, guarded: bool
) -> None:
    process = subprocess.Popen(
        [sys.executable, "-c", STAGED, str(tmp_path), "guarded" if guarded else "plain"],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    assert process.stdout.readline().strip() == "between"
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=60) == -signal.SIGTERM  # ends as terminated either way
    left = [p.name for p in tmp_path.iterdir()]
    # only the guarded block removes its staging folder; without it SIGTERM ends the process
    # at once (what a project stage did before it ran under terminate_cleanly)
    assert (left == []) is guarded, left
