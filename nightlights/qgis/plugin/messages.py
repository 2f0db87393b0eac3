"""What the algorithms read from the commands' messages (standard library only).

``skyglow`` prints its zenith brightness and Bortle class in one line; the ``skyglow``
algorithm returns them as outputs. The toolkit's tests run the command and check that this
parser reads its line.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

_ZENITH = re.compile(
    r"zenith: (?P<luminance>\S+) cd m-2 = (?P<magnitude>\S+) mag arcsec-2.*?"
    r"Bortle class (?P<bortle>\d+)"
)


def parse_zenith(lines: Iterable[str]) -> dict[str, float] | None:
    """The zenith luminance [cd m-2], brightness [mag arcsec-2] and Bortle class that
    ``nightlights skyglow`` printed, or None when no line has them.

    Examples
    --------
    >>> parse_zenith(["zenith: 0.00397 cd m-2 = 18.59 mag arcsec-2 (artificial skyglow "
    ...               "only), Bortle class 7; panorama 9.4 ms (pca) -> sky.nc"])
    {'ZENITH_LUMINANCE': 0.00397, 'ZENITH_MAGNITUDE': 18.59, 'BORTLE': 7}
    """
    for line in lines:
        found = _ZENITH.search(line)
        if found:
            return {
                "ZENITH_LUMINANCE": float(found["luminance"]),
                "ZENITH_MAGNITUDE": float(found["magnitude"]),
                "BORTLE": int(found["bortle"]),
            }
    return None
