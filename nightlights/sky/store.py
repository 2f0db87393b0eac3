"""Kernel files: NetCDF write and read, the kernel cache, and the kernel a stage was given.

Kernels are written as NetCDF (h5netcdf) atomically, with every model parameter in the
attributes (:meth:`~nightlights.sky.spec.KernelSpec.to_attrs`). The cache keeps one file per
content hash under :func:`default_cache_dir`; a kernel is reused when its hash matches.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

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

_REQUIRED_VARIABLES = (
    "basis",
    "coefficient",
    "basis_fft_real",
    "basis_fft_imag",
    "distance_edges",
)


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


def write_kernel(ds: xr.Dataset, path: PathLike) -> Path:
    """Write a kernel dataset to NetCDF (h5netcdf) atomically.

    Parameters
    ----------
    ds
        Kernel dataset.
    path
        Output path.

    Returns
    -------
    pathlib.Path
        The written path.
    """
    target = Path(path)
    with atomic_output(target) as tmp:
        ds.to_netcdf(tmp, engine="h5netcdf")
    return target


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
    return ds


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
