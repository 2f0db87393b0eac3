"""Skyglow: sky luminance above an observer caused by ground light sources.

The kernel side (``atmosphere``, ``geometry``, ``quadrature``, ``kernel``; ``spec``,
``build``, ``pca``, ``store``) computes single-scattering sky luminance from a unit ground
source and tabulates it, compressed by PCA and Fourier-transformed in azimuth, following
Dobashi, Ishikawa & Iwasaki 2023, Sec. 3. The runtime side (``polar``, ``panorama``, ``scene``)
turns an emission raster into panoramas with those tables; ``stage`` holds the file stages.
Many observers at once: ``observers`` (a summary point per observer) and ``darkness`` (the
zenith at every cell of a region); ``influence`` splits a weighted panorama sum per lit cell.

Units: flux [lm] in, luminance [cd m-2] out; angles in degrees, azimuth clockwise from north,
elevation above the horizon.
"""

from nightlights.sky.darkness import DarknessResult, darkness
from nightlights.sky.forward import SkyglowScene, skyglow_panorama
from nightlights.sky.observer import Observer
from nightlights.sky.scene import Scene
from nightlights.sky.spec import KernelSpec
from nightlights.sky.stage import SkyglowResult, build_kernel, skyglow
from nightlights.sky.store import KernelResult

__all__ = [
    "DarknessResult",
    "KernelResult",
    "KernelSpec",
    "Observer",
    "Scene",
    "SkyglowResult",
    "SkyglowScene",
    "build_kernel",
    "darkness",
    "skyglow",
    "skyglow_panorama",
]
