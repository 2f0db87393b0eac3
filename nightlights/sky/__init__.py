"""Skyglow: sky luminance above an observer caused by ground light sources.

The kernel side (``atmosphere``, ``geometry``, ``quadrature``, ``kernel``, ``precompute``)
computes single-scattering sky luminance from a unit ground source and tabulates it, compressed
by PCA and Fourier-transformed in azimuth, following Dobashi, Ishikawa & Iwasaki 2023, Sec. 3.
The runtime side turns an emission raster into panoramas with those tables.

Units: flux [lm] in, luminance [cd m-2] out; angles in degrees, azimuth clockwise from north,
elevation above the horizon.
"""
