"""Build ``photometer_response.csv``: reconstructed responses of the SQM and TESS-W photometers.

A **reconstruction from the published components**, not a measurement. Both photometers use a
TAOS TSL237 light-to-frequency converter (a silicon photodiode) behind a filter:

* the SQM behind a HOYA CM-500 near-infrared absorbing glass (Cinzano 2005);
* the TESS-W behind a dichroic (interference) filter cutting near 740 nm (Zamorano et al. 2016).

The components are modelled as follows, with only the numbers stated here:

* TSL237 photodiode: energy responsivity of a photodiode at constant quantum efficiency,
  proportional to wavelength (R = eta e lambda / (h c)), over the response range the TSL237
  data sheet states, 320-1050 nm (TAOS052J, 2008); zero outside it. The real quantum
  efficiency of silicon falls in the blue and beyond about 800 nm: not modelled.
* HOYA CM-500: a logistic short-pass edge through two published statements: 90 % transmission
  at 550 nm, the end of the range HOYA's near-infrared absorbing glass "transmits" (400-550
  nm, HOYA's product description), and 1 % at 720 nm, where the SQM's combined response ends
  (320-720 nm, as the SQM's band is described, e.g. by the Wikipedia article "Sky quality
  meter" summarising Cinzano 2005 and Sánchez de Miguel et al. 2017). The edge's 50 % point
  then falls at 605 nm. The glass's weak near-infrared leak, which measured SQM responses
  show, is not modelled.
* TESS-W dichroic: a logistic edge with its 50 % point at 740 nm and a 10-90 % width of
  10 nm (an interference filter's edge), from the descriptions of the TESS-W (Zamorano et al.
  2016; Bará et al. 2019).

Each product is normalised to a peak of 1 and sampled every 5 nm from 320 to 1050 nm. Run
``python ies/data/build_photometer_response.py`` to regenerate.

References
----------
1. Cinzano, P. (2005). Night sky photometry with Sky Quality Meter. ISTIL Internal Report 9.
2. TAOS (2008). TSL237 high-sensitivity light-to-frequency converter, data sheet TAOS052J.
3. HOYA Corporation. Near-infrared absorbing (colour correction) filter glass, product page.
4. Zamorano, J. et al. (2016). Testing sky brightness models against radial dependency: a
   dense two dimensional survey around the city of Madrid. JQSRT 181, 52-66.
5. Bará, S. et al. (2019). Estimating linear radiance indicators from the zenith night-sky
   brightness: on the photometric bands of SQM, TESS. (Sensors / JQSRT.)
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

PHOTODIODE_RANGE = (320.0, 1050.0)  # TSL237 response range, data sheet [nm]
CM500_EDGE = (550.0, 0.90, 720.0, 0.01)  # CM-500 transmission 90 % at 550, 1 % at 720 [nm, 1]
TESS_CUT = 740.0  # TESS-W dichroic 50 % point [nm]
TESS_EDGE_WIDTH = 10.0  # its 10-90 % width [nm]


def photodiode(wavelength: np.ndarray) -> np.ndarray:
    """TSL237 relative energy responsivity: proportional to wavelength in its range."""
    inside = (wavelength >= PHOTODIODE_RANGE[0]) & (wavelength <= PHOTODIODE_RANGE[1])
    return np.where(inside, wavelength / PHOTODIODE_RANGE[1], 0.0)


def short_pass(wavelength: np.ndarray, cut: float, scale: float) -> np.ndarray:
    """A logistic short-pass edge, 0.5 at ``cut`` [nm], of logistic scale ``scale`` [nm]."""
    return 1.0 / (1.0 + np.exp((wavelength - cut) / scale))


def through(first: float, t_first: float, second: float, t_second: float) -> tuple[float, float]:
    """(cut, scale) of the logistic short-pass edge through two (wavelength, transmission)."""
    logit_first = math.log((1.0 - t_first) / t_first)
    logit_second = math.log((1.0 - t_second) / t_second)
    scale = (second - first) / (logit_second - logit_first)
    return first - scale * logit_first, scale


def responses(wavelength: np.ndarray) -> dict[str, np.ndarray]:
    """The peak-normalised SQM and TESS-W responses."""
    cm500 = short_pass(wavelength, *through(*CM500_EDGE))
    dichroic = short_pass(wavelength, TESS_CUT, TESS_EDGE_WIDTH / (2.0 * math.log(9.0)))
    products = {"sqm": photodiode(wavelength) * cm500, "tess_w": photodiode(wavelength) * dichroic}
    return {name: values / values.max() for name, values in products.items()}


def main() -> None:
    wavelength = np.arange(PHOTODIODE_RANGE[0], PHOTODIODE_RANGE[1] + 1.0, 5.0)
    columns = responses(wavelength)
    lines = [
        "# SQM (TSL237 x HOYA CM-500) and TESS-W (TSL237 x 740 nm dichroic) relative spectral "
        "responses, peak-normalised; a reconstruction from the published components built by "
        "build_photometer_response.py (see its docstring), not a measurement",
        "wavelength_nm," + ",".join(columns),
    ]
    for k, nm in enumerate(wavelength):
        lines.append(f"{nm:.0f}," + ",".join(f"{c[k]:.6f}" for c in columns.values()))
    Path(__file__).with_name("photometer_response.csv").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
