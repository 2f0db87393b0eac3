"""Array and path types shared by the whole package."""

from __future__ import annotations

import os
from typing import TypeAlias

import numpy as np
from numpy.typing import NDArray

#: A float64 array of any shape.
FloatArray: TypeAlias = NDArray[np.float64]

#: A complex128 array of any shape.
ComplexArray: TypeAlias = NDArray[np.complex128]

#: A file path as the stages accept it.
PathLike: TypeAlias = str | os.PathLike[str]
