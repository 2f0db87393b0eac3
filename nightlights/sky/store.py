"""Kernel files: NetCDF write and read, the kernel cache, and the kernel a stage was given.

Kernels are written as NetCDF (h5netcdf) atomically, with every model parameter in the
attributes (:meth:`~nightlights.sky.spec.KernelSpec.to_attrs`). The cache keeps one file per
content hash under :func:`default_cache_dir`; a kernel is reused when its hash matches.

The compact layout (the default) stores only what cannot be derived: the bases' spectra
(``basis_fft_real``, ``basis_fft_imag``) are recomputed on reading (the rfft of the stored
bases), a basis shared by every observer altitude is stored once (``basis`` without the
``observer_altitude`` axis), float32 kernels store bases and coefficients as float32, and
every variable is deflate-compressed in chunks (with byte shuffling). Reading restores the
layout of :mod:`nightlights.sky.build` in memory, so the runtime sees the same dataset either
way. ``compact=False`` writes the dataset as it is in memory (the original layout).
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from nightlights._typing import PathLike
from nightlights.errors import InputError
from nightlights.io.atomic import atomic_output
from nightlights.sky.build import compute_kernel
from nightlights.sky.spec import KernelSpec

__all__ = [
    "KernelResult",
    "default_cache_dir",
    "get_or_build_kernel",
    "kernel_cache_path",
    "load_kernel",
    "read_kernel",
    "write_kernel",
]

log = logging.getLogger(__name__)

_REQUIRED_VARIABLES = ("basis", "coefficient", "distance_edges")

#: Deflate level of the compact layout, with byte shuffling [1] (a middle zlib level: the
#: sizes and load times it gives are in ``benchmarks/bench_sky_kernel_storage.py``).
COMPRESSION_LEVEL = 4

_SPECTRA = ("basis_fft_real", "basis_fft_imag")
_PCA_VARIABLES = ("basis", "coefficient")


@dataclass(frozen=True)
class KernelResult:
    """A skyglow kernel in memory, what it was built from and where it was written.

    Attributes
    ----------
    kernel
        Kernel dataset (layout in :mod:`nightlights.sky.build`) [cd m-2 lm-1].
    spec
        Its specification.
    path
        The NetCDF file written, or None when nothing was written.
    """

    kernel: xr.Dataset
    spec: KernelSpec
    path: Path | None = None


def write_kernel(ds: xr.Dataset, path: PathLike, *, compact: bool = True) -> Path:
    """Write a kernel dataset to NetCDF (h5netcdf) atomically.

    Parameters
    ----------
    ds
        Kernel dataset.
    path
        Output path.
    compact
        Write the compact layout (module docstring); False writes every variable as it is in
        memory, uncompressed.

    Returns
    -------
    pathlib.Path
        The written path.
    """
    target = Path(path)
    disk, encoding = _compact_layout(ds) if compact else (ds, None)
    with atomic_output(target) as tmp:
        disk.to_netcdf(tmp, engine="h5netcdf", encoding=encoding)
    return target


def _compact_layout(ds: xr.Dataset) -> tuple[xr.Dataset, dict[str, dict[str, object]]]:
    """The dataset without derived variables, and its encoding (dtype, deflate, chunks)."""
    disk = ds.drop_vars([name for name in _SPECTRA if name in ds])
    if int(ds.attrs.get("shared_bases", 0)) and "observer_altitude" in ds["basis"].dims:
        disk["basis"] = ds["basis"].isel(observer_altitude=0, drop=True)
    float32 = str(ds.attrs.get("precision", "float64")) == "float32"
    encoding: dict[str, dict[str, object]] = {}
    for name, variable in disk.data_vars.items():
        if variable.ndim == 0 or variable.size < 64:
            continue
        entry: dict[str, object] = {"zlib": True, "complevel": COMPRESSION_LEVEL, "shuffle": True}
        if float32 and str(name).startswith(_PCA_VARIABLES) and variable.dtype == np.float64:
            entry["dtype"] = "float32"
        # one chunk per altitude level (all its images, bases or coefficients)
        entry["chunksizes"] = tuple(
            1 if dim in ("observer_altitude", "source_altitude") else size
            for dim, size in variable.sizes.items()
        )
        encoding[str(name)] = entry
    return disk, encoding


def _memory_layout(ds: xr.Dataset) -> xr.Dataset:
    """The in-memory layout of a compact file: float64 PCA tables, a shared basis broadcast
    over the observer levels, and the bases' spectra."""
    for name in list(ds.data_vars):
        if str(name).startswith(_PCA_VARIABLES) and ds[name].dtype == np.float32:
            ds[name] = ds[name].astype(np.float64)
    stored_once = "observer_altitude" not in ds["basis"].dims
    if stored_once:
        shared = ds["basis"]
        n_o = ds.sizes["observer_altitude"]
        ds["basis"] = (
            ("observer_altitude", *shared.dims),
            np.broadcast_to(shared.values, (n_o, *shared.shape)),
            shared.attrs,
        )
    if not all(name in ds for name in _SPECTRA):
        basis = ds["basis"]
        if stored_once:
            spectrum = np.fft.rfft(basis.values[0], axis=-1)
            spectrum = np.broadcast_to(spectrum, (basis.shape[0], *spectrum.shape))
        else:
            spectrum = np.fft.rfft(basis.values, axis=-1)
        dims = ("observer_altitude", "component", "elevation", "frequency")
        attrs = {"units": "1", "transform": "rfft over azimuth"}
        ds["basis_fft_real"] = (dims, spectrum.real, attrs)
        ds["basis_fft_imag"] = (dims, spectrum.imag, attrs)
        ds = ds.assign_coords(frequency=np.arange(spectrum.shape[-1]))
    return ds


def read_kernel(path: PathLike) -> xr.Dataset:
    """Read a kernel dataset written by :func:`write_kernel`, loaded into memory.

    Parameters
    ----------
    path
        NetCDF file.

    Returns
    -------
    xarray.Dataset
        Kernel dataset.

    Raises
    ------
    InputError
        The file is missing, unreadable or not a kernel.
    """
    source = Path(path)
    if not source.is_file():
        raise InputError(f"{source}: kernel file does not exist")
    try:
        ds = xr.load_dataset(source, engine="h5netcdf")
    except (OSError, ValueError) as exc:
        raise InputError(f"{source}: not a readable NetCDF kernel ({exc})") from exc
    missing = [name for name in _REQUIRED_VARIABLES if name not in ds]
    if missing or "content_hash" not in ds.attrs:
        raise InputError(
            f"{source}: not a skyglow kernel; missing {missing or ['content_hash attribute']}"
        )
    return _memory_layout(ds)


def load_kernel(kernel: KernelResult | xr.Dataset | PathLike) -> xr.Dataset:
    """The kernel dataset of a stage's ``kernel`` input.

    Parameters
    ----------
    kernel
        A :class:`KernelResult`, a kernel dataset or a NetCDF path.

    Returns
    -------
    xarray.Dataset
        Kernel dataset.
    """
    if isinstance(kernel, KernelResult):
        return kernel.kernel
    if isinstance(kernel, xr.Dataset):
        return kernel
    if isinstance(kernel, (str, os.PathLike)):
        return read_kernel(kernel)
    raise InputError(
        f"kernel of type {type(kernel).__name__}; expected a KernelResult, an xarray.Dataset "
        "or a path"
    )


def default_cache_dir() -> Path:
    """Kernel cache folder: ``$NIGHTLIGHTS_CACHE/sky`` or ``~/.cache/nightlights/sky``.

    Returns
    -------
    pathlib.Path
        Folder (not created).
    """
    root = os.environ.get("NIGHTLIGHTS_CACHE")
    base = Path(root) if root else Path.home() / ".cache" / "nightlights"
    return base / "sky"


def kernel_cache_path(spec: KernelSpec | str, cache_dir: PathLike | None = None) -> Path:
    """Cache file of a kernel, keyed by its content hash.

    Parameters
    ----------
    spec
        Kernel specification, or a content hash.
    cache_dir
        Cache folder; default :func:`default_cache_dir`.

    Returns
    -------
    pathlib.Path
        ``<cache_dir>/kernel-<hash[:24]>.nc``.
    """
    digest = spec if isinstance(spec, str) else spec.content_hash
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    return folder / f"kernel-{digest[:24]}.nc"


def get_or_build_kernel(
    spec: KernelSpec | None = None,
    *,
    cache_dir: PathLike | None = None,
    backend: str = "auto",
    progress: bool = True,
) -> KernelResult:
    """A cached kernel whose content hash matches the specification, or build and cache it.

    Parameters
    ----------
    spec
        Kernel specification; default ``KernelSpec()``.
    cache_dir
        Cache folder; default :func:`default_cache_dir`.
    backend
        Line-of-sight integrator when building (:func:`~nightlights.sky.build.compute_kernel`).
    progress
        Show a progress bar while building.

    Returns
    -------
    KernelResult
        The kernel and its cache file.
    """
    spec = spec if spec is not None else KernelSpec()
    path = kernel_cache_path(spec, cache_dir)
    if path.is_file():
        try:
            ds = read_kernel(path)
        except InputError:
            log.warning("cached kernel %s is unreadable; rebuilding", path)
        else:
            if ds.attrs.get("content_hash") == spec.content_hash:
                log.info("reusing cached kernel %s", path)
                return KernelResult(ds, spec, path)
            log.warning("cached kernel %s has another content hash; rebuilding", path)
    ds = compute_kernel(spec, backend=backend, progress=progress)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_kernel(ds, path)
    log.info("kernel cached at %s", path)
    return KernelResult(ds, spec, path)
