"""QGIS styles of the toolkit's products: QML documents and the GeoPackage ``layer_styles`` table.

QGIS opens a raster with the ``.qml`` file of the same name beside it as its default style
(QGIS User Guide, "Managing Custom Styles"), and a GeoPackage layer with the row of the
``layer_styles`` table that names it and is marked ``useAsDefault``. Every raster the toolkit
writes (:func:`~nightlights.io.write_cog`) gets such a sidecar, chosen by the product the
raster holds (its dataset tag :data:`PRODUCT_TAG`, through the registry of
:func:`register_raster_style`; :func:`raster_qml`); the vector writers pass a
:class:`LayerStyle` to :func:`~nightlights.io.write_gpkg`, which stores it in the GeoPackage
(:func:`add_layer_style`).

One function per product kind (the registered product tags in brackets):

============================  ====================================================
product                       style
============================  ====================================================
illuminance [lx], irradiance  :func:`illuminance_qml`: a log ramp (inferno)
(``irradiance``)
emission [lm m-2]             :func:`emission_qml`: a log ramp (viridis)
(``emission``,
``polar_emission``)
sky luminance [cd m-2]        :func:`luminance_qml`: a log ramp (magma)
(``panorama`` without a
brightness band)
sky brightness [mag arcsec-2] :func:`sky_brightness_qml`: the Bortle colour key
(``panorama``,
``zenith_brightness``)
influence Q, S [cd m-2]       :func:`influence_qml`: deciles of the lit cells
(``influence_q``,
``influence_s``)
dimming [1] (``dimming``)     :func:`dimming_qml`: a linear ramp over 0-1
luminaires (poles)            :func:`poles_style`: arrows turned by heading, one colour
                              per light system
streets                       :func:`streets_style`: one colour per pole arrangement
observers (summary points)    :func:`observers_style`: the Bortle colour key of the
                              zenith brightness
============================  ====================================================

The documents follow the QML format of QGIS 3.22 (the version in Debian 12), which later
QGIS versions read as well.

Length: the QML documents of eleven product kinds share one set of XML builders, and the
registry that chooses among them is keyed by the products they style; splitting them would put
the builders in a second module that only this one uses.

References
----------
1. QGIS Project (2022). QGIS User Guide 3.22, "Managing Custom Styles" (``.qml`` files
   beside a layer) and "Storing styles in a database" (the ``layer_styles`` table).
2. Bortle, J. E. (2001). Introducing the Bortle dark-sky scale. Sky & Telescope 101(2),
   126-129.
3. Falchi, F. et al. (2016). The new world atlas of artificial night sky brightness.
   Science Advances 2(6), e1600377 (Fig. 1: the colour key of light-pollution maps, black
   through grey, blue, green, yellow, orange and red to white as the sky brightens).
4. van der Walt, S. and Smith, N. (2015). A better default colormap for Matplotlib
   (viridis, magma, inferno), SciPy 2015.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import ArrayLike

from nightlights.brightness import BORTLE_LOWER_EDGES
from nightlights.errors import InputError, NightlightsWarning, OutputError

__all__ = [
    "PRODUCT_TAG",
    "LayerStyle",
    "StyleBuilder",
    "add_layer_style",
    "compliance_style",
    "dimming_qml",
    "emission_qml",
    "illuminance_qml",
    "influence_qml",
    "luminance_qml",
    "observers_style",
    "poles_style",
    "raster_qml",
    "raster_styles",
    "register_raster_style",
    "sidecar_path",
    "sky_brightness_qml",
    "streets_style",
    "unregister_raster_style",
]

#: The GeoPackage table of QGIS layer styles (QGIS User Guide, "Storing styles in a database").
STYLES_TABLE = "layer_styles"
#: QGIS version the documents are written for (Debian 12's QGIS; later versions read it).
QGIS_VERSION = "3.22.16-Białowieża"

#: Colour maps sampled at nine equally spaced points, 0 to 1 (van der Walt & Smith 2015).
PALETTES: dict[str, tuple[str, ...]] = {
    "inferno": tuple(
        "#000004 #210c4a #57106e #8a226a #bc3754 #e45a31 #f98e09 #f9cb35 #fcffa4".split()
    ),
    "viridis": tuple(
        "#440154 #472d7b #3b528b #2c728e #21918c #28ae80 #5ec962 #addc30 #fde725".split()
    ),
    "magma": tuple(
        "#000004 #1d1147 #51127c #832681 #b73779 #e75263 #fc8961 #fec488 #fcfdbf".split()
    ),
}

#: Colour of each Bortle class 1 (darkest) .. 9 (inner city): the colour key of
#: light-pollution maps (Falchi et al. 2016, Fig. 1), one colour per class (Bortle 2001).
BORTLE_COLOURS: tuple[str, ...] = (
    "#000000",  # 1 black
    "#4d4d4d",  # 2 grey
    "#1f3fbf",  # 3 blue
    "#1f9f3f",  # 4 green
    "#e6e61a",  # 5 yellow
    "#f08c1a",  # 6 orange
    "#e01f1f",  # 7 red
    "#f2a6d9",  # 8 pink
    "#ffffff",  # 9 white
)

#: Quantiles of the positive values that set a log ramp's ends before rounding out to whole
#: decades [1]: a display choice that keeps a few bright cells from flattening the map.
LOG_RAMP_QUANTILES = (0.02, 0.999)
#: Decades a log ramp spans at most [1] (display choice: darker cells take the first colour).
LOG_RAMP_MAX_DECADES = 5
#: Colour stops per decade of a log ramp [1]: QGIS interpolates linearly between stops, so
#: four per decade keep the ramp within ~3 % of a true log scale in position.
LOG_RAMP_STOPS_PER_DECADE = 4
#: Classes of the quantile ramp of influence maps (deciles) [1].
QUANTILE_CLASSES = 10
#: Values sampled at most to place a ramp's ends or quantiles [1].
SAMPLE_LIMIT = 1_000_000
#: Upper end of the Bortle key's darkest class [mag arcsec-2]: far beyond any natural night
#: sky (~22 mag arcsec-2), so that an artificial-only map's darkest cells stay in the class.
FAINTEST_MAGNITUDE = 99.0

# --- colours ---------------------------------------------------------------------------------


def _rgb(colour: str) -> tuple[int, int, int]:
    text = colour.lstrip("#")
    return int(text[0:2], 16), int(text[2:4], 16), int(text[4:6], 16)


def _ramp_colour(palette: str, position: float) -> str:
    """The colour at ``position`` in [0, 1] along a palette, interpolated linearly in RGB."""
    stops = PALETTES[palette]
    scaled = min(max(position, 0.0), 1.0) * (len(stops) - 1)
    low = min(math.floor(scaled), len(stops) - 2)
    weight = scaled - low
    a, b = _rgb(stops[low]), _rgb(stops[low + 1])
    mixed = (round(a[i] + (b[i] - a[i]) * weight) for i in range(3))
    return "#" + "".join(f"{value:02x}" for value in mixed)


def _qgis_colour(colour: str, alpha: int = 255) -> str:
    r, g, b = _rgb(colour)
    return f"{r},{g},{b},{alpha}"


# --- values ------------------------------------------------------------------------------------


def _sample(values: ArrayLike) -> np.ndarray:
    """Finite values, at most :data:`SAMPLE_LIMIT` of them (an even stride through the rest)."""
    flat = np.asarray(values, dtype=np.float64).ravel()
    if flat.size > SAMPLE_LIMIT:
        flat = flat[:: math.ceil(flat.size / SAMPLE_LIMIT)]
    return flat[np.isfinite(flat)]


def log_ramp_range(values: ArrayLike, default: tuple[float, float]) -> tuple[float, float]:
    """Ends of a log ramp in whole decades from the positive values.

    Parameters
    ----------
    values
        The band's values; NaN and values <= 0 are left out [band unit].
    default
        (low, high) when there is no positive value [band unit].

    Returns
    -------
    tuple of float
        (low, high), powers of ten, at most :data:`LOG_RAMP_MAX_DECADES` apart.

    Examples
    --------
    >>> log_ramp_range([0.0, 0.3, 2.0, 45.0], default=(0.1, 100.0))
    (0.1, 100.0)
    """
    sample = _sample(values)
    positive = sample[sample > 0]
    if positive.size == 0:
        return default
    low_q, high_q = np.quantile(positive, LOG_RAMP_QUANTILES)
    high = math.ceil(math.log10(high_q))
    low = math.floor(math.log10(low_q))
    if high <= low:
        high = low + 1
    low = max(low, high - LOG_RAMP_MAX_DECADES)
    return 10.0**low, 10.0**high


def _label(value: float, unit: str) -> str:
    text = f"{value:.3g}"
    return f"{text} {unit}" if unit and unit != "1" else text


# --- raster documents -----------------------------------------------------------------------


def _raster_document(
    *,
    band: int,
    items: Sequence[tuple[float, str, str]],
    ramp_type: str,
    classification_mode: int,
    description: str,
    transparent_zero: bool = False,
) -> str:
    """A QML document with a single-band pseudocolour renderer.

    ``items`` are (value, colour, label) in increasing value; ``ramp_type`` is ``INTERPOLATED``
    (linear between items) or ``DISCRETE`` (a value takes the first item at or above it);
    ``classification_mode`` is QGIS's (1 continuous, 2 equal interval, 3 quantile);
    ``transparent_zero`` leaves cells of exactly 0 (no light) transparent.
    """
    low, high = items[0][0], items[-1][0]
    entries = "\n".join(
        f'          <item alpha="255" value="{value!r}" label={quoteattr(label)} color="{colour}"/>'
        for value, colour, label in items
    )
    return f"""<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>
<qgis version="{QGIS_VERSION}" styleCategories="AllStyleCategories" hasScaleBasedVisibilityFlag="0" minScale="1e+08" maxScale="0">
  <!-- {_escape_comment(description)} -->
  <pipe>
    <rasterrenderer type="singlebandpseudocolor" band="{band}" opacity="1" alphaBand="-1" classificationMin="{low!r}" classificationMax="{high!r}" nodataColor="">
      {_transparency(transparent_zero)}
      <minMaxOrigin>
        <limits>None</limits>
        <extent>WholeRaster</extent>
        <statAccuracy>Estimated</statAccuracy>
        <cumulativeCutLower>0.02</cumulativeCutLower>
        <cumulativeCutUpper>0.98</cumulativeCutUpper>
        <stdDevFactor>2</stdDevFactor>
      </minMaxOrigin>
      <rastershader>
        <colorrampshader colorRampType="{ramp_type}" classificationMode="{classification_mode}" clip="0" minimumValue="{low!r}" maximumValue="{high!r}" labelPrecision="4">
{entries}
        </colorrampshader>
      </rastershader>
    </rasterrenderer>
    <brightnesscontrast brightness="0" contrast="0" gamma="1"/>
    <huesaturation saturation="0" grayscaleMode="0" colorizeOn="0" colorizeRed="255" colorizeGreen="128" colorizeBlue="128" colorizeStrength="100"/>
    <rasterresampler maxOversampling="2"/>
  </pipe>
  <blendMode>0</blendMode>
</qgis>
"""  # noqa: E501


def _transparency(zero: bool) -> str:
    if not zero:
        return "<rasterTransparency/>"
    return (
        "<rasterTransparency><singleValuePixelList>"
        '<pixelListEntry min="0" max="0" percentTransparent="100"/>'
        "</singleValuePixelList></rasterTransparency>"
    )


def _escape_comment(text: str) -> str:
    return text.replace("--", "- -")


def _log_ramp_qml(
    values: ArrayLike,
    *,
    band: int,
    unit: str,
    palette: str,
    default: tuple[float, float],
    what: str,
) -> str:
    low, high = log_ramp_range(values, default)
    decades = round(math.log10(high / low))
    steps = decades * LOG_RAMP_STOPS_PER_DECADE
    items = []
    for k in range(steps + 1):
        value = low * 10.0 ** (k / LOG_RAMP_STOPS_PER_DECADE)
        items.append((value, _ramp_colour(palette, k / steps), _label(value, unit)))
    return _raster_document(
        band=band,
        items=items,
        ramp_type="INTERPOLATED",
        classification_mode=1,
        description=f"{what}: log ramp {low:g}-{high:g} {unit} ({palette}), nightlights",
        transparent_zero=True,
    )


def illuminance_qml(values: ArrayLike, *, band: int = 1, unit: str = "lx") -> str:
    """QML of a ground illuminance (or sensor irradiance) raster: a log ramp in whole decades.

    Parameters
    ----------
    values
        The styled band's values, for the ramp's ends (:func:`log_ramp_range`) [``unit``].
    band
        1-based band the renderer shows.
    unit
        Unit in the legend labels (``lx``, or ``W m-2`` for a sensor band).

    Returns
    -------
    str
        The QML document (inferno; cells darker than the ramp in its first colour, cells of
        zero transparent).
    """
    return _log_ramp_qml(
        values, band=band, unit=unit, palette="inferno", default=(0.1, 100.0), what="illuminance"
    )


def emission_qml(values: ArrayLike, *, band: int = 1) -> str:
    """QML of an upward flux density (emission) raster: a log ramp in whole decades.

    Parameters
    ----------
    values
        The styled band's values [lm m-2].
    band
        1-based band the renderer shows.
    """
    return _log_ramp_qml(
        values,
        band=band,
        unit="lm m-2",
        palette="viridis",
        default=(0.001, 10.0),
        what="upward flux density",
    )


def luminance_qml(values: ArrayLike, *, band: int = 1) -> str:
    """QML of a sky luminance raster (a panorama's luminance band): a log ramp.

    Parameters
    ----------
    values
        The styled band's values [cd m-2].
    band
        1-based band the renderer shows.
    """
    return _log_ramp_qml(
        values, band=band, unit="cd m-2", palette="magma", default=(1e-5, 1e-2), what="luminance"
    )


def sky_brightness_qml(*, band: int = 1) -> str:
    """QML of a sky brightness raster [mag arcsec-2]: the Bortle classes in their colour key.

    A cell darker than 21.99 mag arcsec-2 is black (class 1), one brighter than 18.00 white
    (class 9); the class edges are :data:`nightlights.brightness.BORTLE_LOWER_EDGES`
    (Bortle 2001) and the colours :data:`BORTLE_COLOURS` (Falchi et al. 2016).

    Parameters
    ----------
    band
        1-based band the renderer shows.
    """
    items = [
        (value, colour, label)
        for value, colour, label in zip(
            _bortle_upper_edges(), reversed(BORTLE_COLOURS), _bortle_labels(), strict=True
        )
    ]
    return _raster_document(
        band=band,
        items=items,
        ramp_type="DISCRETE",
        classification_mode=2,
        description="sky brightness: Bortle classes (Bortle 2001), nightlights",
    )


def _bortle_upper_edges() -> list[float]:
    """Upper (fainter) edge of each class, brightest class first [mag arcsec-2]."""
    return [*sorted(BORTLE_LOWER_EDGES), FAINTEST_MAGNITUDE]


def _bortle_labels() -> list[str]:
    """Legend labels, brightest class (9) first."""
    edges = sorted(_bortle_upper_edges()[:-1])
    labels = [f"Bortle 9 (< {edges[0]:.2f} mag arcsec-2)"]
    for index in range(1, len(edges)):
        labels.append(f"Bortle {9 - index} ({edges[index - 1]:.2f}-{edges[index]:.2f})")
    labels.append(f"Bortle 1 (>= {edges[-1]:.2f})")
    return labels


def influence_qml(values: ArrayLike, *, band: int = 1, unit: str = "cd m-2") -> str:
    """QML of an influence map (Q or S): classes of equal counts of the lit cells (deciles).

    Parameters
    ----------
    values
        The styled band's values; NaN and zero (cells without light) are left out [``unit``].
    band
        1-based band the renderer shows.
    unit
        Unit in the legend labels.
    """
    sample = _sample(values)
    lit = sample[sample > 0]
    if lit.size == 0:
        edges = np.array([1.0])
    else:
        edges = np.unique(np.quantile(lit, np.linspace(0, 1, QUANTILE_CLASSES + 1)[1:]))
    items = []
    for index, edge in enumerate(edges):
        position = index / max(edges.size - 1, 1)
        low, high = 100.0 * index / edges.size, 100.0 * (index + 1) / edges.size
        label = f"<= {_label(float(edge), unit)} ({low:.0f}-{high:.0f} % of lit cells)"
        items.append((float(edge), _ramp_colour("magma", position), label))
    return _raster_document(
        band=band,
        items=items,
        ramp_type="DISCRETE",
        classification_mode=3,
        description=f"influence: {edges.size} quantile classes of the lit cells, nightlights",
    )


def dimming_qml(*, band: int = 1) -> str:
    """QML of a dimming raster: the fraction of each cell's flux removed, 0 to 1, linear.

    Parameters
    ----------
    band
        1-based band the renderer shows.
    """
    items = [
        (k / 8, _ramp_colour("inferno", 1.0 - k / 8), label)
        for k, label in (
            (k, {0: "0 (unchanged)", 4: "0.5", 8: "1 (off)"}.get(k, "")) for k in range(9)
        )
    ]
    return _raster_document(
        band=band,
        items=items,
        ramp_type="INTERPOLATED",
        classification_mode=2,
        description="dimming fraction 0-1, nightlights",
    )


#: Dataset tag naming the product a raster holds (``irradiance``, ``emission``, ...): the key of
#: the style registry (:func:`register_raster_style`).
PRODUCT_TAG = "product"

#: Style builder of a product: (band descriptions, band units, band arrays [band unit],
#: dataset tags) -> the QML document.
StyleBuilder = Callable[[Sequence[str], Sequence[str], Sequence[ArrayLike], Mapping[str, str]], str]

_STYLES: dict[str, StyleBuilder] = {}


def register_raster_style(product: str, builder: StyleBuilder, *, replace: bool = False) -> None:
    """Style the rasters tagged ``product`` (:data:`PRODUCT_TAG`) with ``builder``.

    Parameters
    ----------
    product
        The product tag a stage writes into its rasters.
    builder
        (descriptions, units, bands, tags) -> QML document (:data:`StyleBuilder`).
    replace
        Replace the builder registered for ``product``.

    Raises
    ------
    nightlights.errors.InputError
        An empty product name, or one already registered (without ``replace``).

    Examples
    --------
    >>> register_raster_style("toy", lambda d, u, b, t: dimming_qml())
    >>> raster_qml(["x"], ["1"], [[0.5]], {PRODUCT_TAG: "toy"}) == dimming_qml()
    True
    >>> unregister_raster_style("toy")
    """
    if not (isinstance(product, str) and product.strip()):
        raise InputError(f"raster product {product!r}; expected a non-empty name")
    if product in _STYLES and not replace:
        raise InputError(f"raster product {product!r} already has a style (replace=True)")
    _STYLES[product] = builder


def unregister_raster_style(product: str) -> None:
    """Remove the style of ``product``.

    Parameters
    ----------
    product
        A product registered by :func:`register_raster_style`.

    Raises
    ------
    nightlights.errors.InputError
        No style is registered for it.
    """
    if product not in _STYLES:
        raise InputError(f"raster product {product!r} has no registered style")
    del _STYLES[product]


def raster_styles() -> tuple[str, ...]:
    """The products that have a registered style."""
    return tuple(_STYLES)


def raster_qml(
    descriptions: Sequence[str],
    units: Sequence[str],
    bands: Sequence[ArrayLike],
    tags: Mapping[str, str] | None = None,
) -> str:
    """The QML of a raster: what :func:`~nightlights.io.write_cog` writes beside it.

    A raster tagged with its product (:data:`PRODUCT_TAG`, as every stage writes it) is styled
    by the builder registered for that product (:func:`register_raster_style`; a product
    without one gets the neutral ramp of rule 7 below, with a warning). A raster without the
    tag (a file written before the tag existed, or by another program) is styled from its
    bands by the first rule that matches, in this order:

    1. a band in ``mag arcsec-2``: :func:`sky_brightness_qml` on it;
    2. a band described ``dimming``: :func:`dimming_qml`;
    3. an influence map (a ``metric`` tag, as the Q and S maps carry): :func:`influence_qml`;
    4. a band in ``lx`` (else ``W m-2``): :func:`illuminance_qml`;
    5. a band in ``lm m-2``: :func:`emission_qml`;
    6. a band in ``cd m-2``: :func:`luminance_qml`;
    7. otherwise a log ramp over the first band (:func:`emission_qml`'s, labelled in its
       unit) when its positive values span more than two decades, else a linear one.

    Parameters
    ----------
    descriptions, units
        One per band.
    bands
        The band arrays [band unit].
    tags
        Dataset-level metadata.

    Returns
    -------
    str
        The QML document.
    """
    tags = tags or {}
    units = [unit or "" for unit in units]
    product = tags.get(PRODUCT_TAG)
    if product is not None:
        builder = _STYLES.get(product)
        if builder is not None:
            return builder(descriptions, units, bands, tags)
        warnings.warn(
            f"raster product {product!r} has no registered style "
            f"({', '.join(_STYLES)}); writing a neutral ramp",
            NightlightsWarning,
            stacklevel=2,
        )
        return _generic_qml(bands[0], unit=units[0] if units else "")
    return _style_by_units(descriptions, units, bands, tags)


def _style_by_units(
    descriptions: Sequence[str],
    units: Sequence[str],
    bands: Sequence[ArrayLike],
    tags: Mapping[str, str],
) -> str:
    """The style of a raster without a product tag, chosen from its bands (the rules of
    :func:`raster_qml`)."""

    def first(unit: str) -> int | None:
        return list(units).index(unit) if unit in units else None

    if (index := first("mag arcsec-2")) is not None:
        return sky_brightness_qml(band=index + 1)
    if "dimming" in descriptions:
        return dimming_qml(band=list(descriptions).index("dimming") + 1)
    if "metric" in tags:
        return influence_qml(bands[0], band=1, unit=units[0])
    for unit in ("lx", "W m-2"):
        if (index := first(unit)) is not None:
            return illuminance_qml(bands[index], band=index + 1, unit=unit)
    if (index := first("lm m-2")) is not None:
        return emission_qml(bands[index], band=index + 1)
    if (index := first("cd m-2")) is not None:
        return luminance_qml(bands[index], band=index + 1)
    return _generic_qml(bands[0], unit=units[0] if units else "")


def _band_index(values: Sequence[str], *wanted: str) -> int:
    """The first band whose unit (or description) is one of ``wanted``, else the first band."""
    for value in wanted:
        if value in values:
            return list(values).index(value)
    return 0


def _irradiance_style(
    descriptions: Sequence[str],
    units: Sequence[str],
    bands: Sequence[ArrayLike],
    tags: Mapping[str, str],
) -> str:
    """Ground illuminance or sensor irradiance: the first band in lx, else in W m-2."""
    index = _band_index(units, "lx", "W m-2")
    return illuminance_qml(bands[index], band=index + 1, unit=units[index])


def _emission_style(
    descriptions: Sequence[str],
    units: Sequence[str],
    bands: Sequence[ArrayLike],
    tags: Mapping[str, str],
) -> str:
    """Upward flux density: the first band in lm m-2."""
    index = _band_index(units, "lm m-2")
    return emission_qml(bands[index], band=index + 1)


def _brightness_style(
    descriptions: Sequence[str],
    units: Sequence[str],
    bands: Sequence[ArrayLike],
    tags: Mapping[str, str],
) -> str:
    """Sky brightness in the Bortle key; a panorama without a brightness band: its luminance."""
    if "mag arcsec-2" in units:
        return sky_brightness_qml(band=_band_index(units, "mag arcsec-2") + 1)
    index = _band_index(units, "cd m-2")
    return luminance_qml(bands[index], band=index + 1)


def _influence_style(
    descriptions: Sequence[str],
    units: Sequence[str],
    bands: Sequence[ArrayLike],
    tags: Mapping[str, str],
) -> str:
    """An influence map (Q or S): deciles of the lit cells of its one band."""
    return influence_qml(bands[0], band=1, unit=units[0])


def _dimming_style(
    descriptions: Sequence[str],
    units: Sequence[str],
    bands: Sequence[ArrayLike],
    tags: Mapping[str, str],
) -> str:
    """A dimming plan: the band described ``dimming``."""
    return dimming_qml(band=_band_index(descriptions, "dimming") + 1)


for _product, _builder in (
    ("irradiance", _irradiance_style),
    ("emission", _emission_style),
    ("polar_emission", _emission_style),
    ("panorama", _brightness_style),
    ("zenith_brightness", _brightness_style),
    ("influence_q", _influence_style),
    ("influence_s", _influence_style),
    ("dimming", _dimming_style),
):
    register_raster_style(_product, _builder)


def _generic_qml(values: ArrayLike, *, unit: str) -> str:
    sample = _sample(values)
    positive = sample[sample > 0]
    if positive.size and positive.max() > 100 * positive.min():
        return _log_ramp_qml(
            sample, band=1, unit=unit, palette="viridis", default=(1.0, 10.0), what="values"
        )
    low, high = (float(sample.min()), float(sample.max())) if sample.size else (0.0, 1.0)
    if high <= low:
        high = low + 1.0
    items = [(low + (high - low) * k / 8, _ramp_colour("viridis", k / 8), "") for k in range(9)]
    items[0] = (items[0][0], items[0][1], _label(low, unit))
    items[-1] = (items[-1][0], items[-1][1], _label(high, unit))
    return _raster_document(
        band=1,
        items=items,
        ramp_type="INTERPOLATED",
        classification_mode=2,
        description="values: linear ramp, nightlights",
    )


def sidecar_path(path: str | os.PathLike[str]) -> Path:
    """The ``.qml`` QGIS loads as the default style of a raster file: its name with ``.qml``.

    Examples
    --------
    >>> sidecar_path("out/irradiance.tif").as_posix()
    'out/irradiance.qml'
    """
    return Path(path).with_suffix(".qml")


# --- vector documents ---------------------------------------------------------------------


@dataclass(frozen=True)
class LayerStyle:
    """A vector layer's style as QGIS stores it in a GeoPackage's ``layer_styles`` table.

    Attributes
    ----------
    name
        Style name shown in QGIS's style manager.
    qml
        The QML document.
    description
        One line on what the style shows.
    """

    name: str
    qml: str
    description: str


def _props(properties: Mapping[str, str]) -> str:
    return "\n".join(
        f"          <prop k={quoteattr(key)} v={quoteattr(value)}/>"
        for key, value in properties.items()
    )


def _rotation_by_field(field: str) -> str:
    """A symbol layer's data-defined angle read from ``field`` [deg clockwise from north]."""
    return f"""          <data_defined_properties>
            <Option type="Map">
              <Option type="QString" name="name" value=""/>
              <Option type="Map" name="properties">
                <Option type="Map" name="angle">
                  <Option type="bool" name="active" value="true"/>
                  <Option type="QString" name="field" value={quoteattr(field)}/>
                  <Option type="int" name="type" value="2"/>
                </Option>
              </Option>
              <Option type="QString" name="type" value="collection"/>
            </Option>
          </data_defined_properties>"""


def _marker_symbol(
    name: str, colour: str, *, shape: str, size: float, rotation_field: str | None
) -> str:
    properties = {
        "angle": "0",
        "color": _qgis_colour(colour),
        "horizontal_anchor_point": "1",
        "joinstyle": "miter",
        "name": shape,
        "offset": "0,0",
        "offset_unit": "MM",
        "outline_color": "35,35,35,255",
        "outline_style": "solid",
        "outline_width": "0.2",
        "outline_width_unit": "MM",
        "scale_method": "diameter",
        "size": f"{size:g}",
        "size_unit": "MM",
        "vertical_anchor_point": "1",
    }
    rotation = _rotation_by_field(rotation_field) if rotation_field else ""
    return f"""      <symbol type="marker" name={quoteattr(name)} alpha="1" clip_to_extent="1" force_rhr="0">
        <layer class="SimpleMarker" enabled="1" pass="0" locked="0">
{_props(properties)}
{rotation}
        </layer>
      </symbol>"""  # noqa: E501


def _line_symbol(name: str, colour: str, *, width: float) -> str:
    properties = {
        "capstyle": "round",
        "joinstyle": "round",
        "line_color": _qgis_colour(colour),
        "line_style": "solid",
        "line_width": f"{width:g}",
        "line_width_unit": "MM",
        "offset": "0",
        "offset_unit": "MM",
    }
    return f"""      <symbol type="line" name={quoteattr(name)} alpha="1" clip_to_extent="1" force_rhr="0">
        <layer class="SimpleLine" enabled="1" pass="0" locked="0">
{_props(properties)}
        </layer>
      </symbol>"""  # noqa: E501


def _vector_document(renderer: str, description: str, labeling: str = "") -> str:
    return f"""<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>
<qgis version="{QGIS_VERSION}" styleCategories="Symbology|Labeling" labelsEnabled="{int(bool(labeling))}">
  <!-- {_escape_comment(description)} -->
{renderer}
{labeling}
  <blendMode>0</blendMode>
  <featureBlendMode>0</featureBlendMode>
</qgis>
"""  # noqa: E501


def _categorized(field: str, categories: Sequence[tuple[str, str]], symbols: Sequence[str]) -> str:
    """A categorized renderer; ``categories`` are (value, label), a value ``""`` catches every
    value not listed (and missing ones)."""
    rows = "\n".join(
        f'      <category value={quoteattr(value)} symbol="{index}" label={quoteattr(label)} '
        'render="true"/>'
        for index, (value, label) in enumerate(categories)
    )
    return f"""  <renderer-v2 type="categorizedSymbol" attr={quoteattr(field)} symbollevels="0" enableorderby="0" forceraster="0">
    <categories>
{rows}
    </categories>
    <symbols>
{chr(10).join(symbols)}
    </symbols>
  </renderer-v2>"""  # noqa: E501


#: Colours of the light systems of a pole layer, in the order of their first appearance
#: (Okabe & Ito 2008, "Color Universal Design": eight colours told apart with any colour vision).
CATEGORY_COLOURS: tuple[str, ...] = (
    "#e69f00",
    "#56b4e9",
    "#009e73",
    "#f0e442",
    "#0072b2",
    "#d55e00",
    "#cc79a7",
    "#999999",
)
#: Colour of a value that is not listed (other or missing).
OTHER_COLOUR = "#bdbdbd"
#: Pole symbol size [mm on the map].
POLE_SIZE_MM = 3.0
#: Street line width [mm on the map].
STREET_WIDTH_MM = 0.6
#: Observer symbol size [mm on the map].
OBSERVER_SIZE_MM = 4.0


def poles_style(systems: Sequence[str], *, heading_field: str = "heading") -> LayerStyle:
    """Style of a luminaire (pole) layer: arrows pointing along each light's heading, one
    colour per light system (``system_id``).

    Parameters
    ----------
    systems
        The layer's light systems (``system_id`` values); the first
        ``len(CATEGORY_COLOURS)`` get their own colour, the rest share :data:`OTHER_COLOUR`.
    heading_field
        Field with the compass bearing from the pole towards the lit area [deg clockwise
        from north], QGIS's rotation convention.

    Returns
    -------
    LayerStyle
        Categorized by ``system_id``; the arrow (QGIS's ``filled_arrowhead`` marker, pointing up at
        angle 0) turned by the heading.
    """
    listed = list(dict.fromkeys(str(s) for s in systems))[: len(CATEGORY_COLOURS)]
    categories = [(system, system) for system in listed] + [("", "other system")]
    colours = [*CATEGORY_COLOURS[: len(listed)], OTHER_COLOUR]
    symbols = [
        _marker_symbol(
            str(index),
            colour,
            shape="filled_arrowhead",
            size=POLE_SIZE_MM,
            rotation_field=heading_field,
        )
        for index, colour in enumerate(colours)
    ]
    description = "luminaires: arrows turned by heading, coloured by light system"
    return LayerStyle(
        "poles by system",
        _vector_document(_categorized("system_id", categories, symbols), description),
        description,
    )


def streets_style(arrangements: Sequence[str], *, field: str = "arrangement") -> LayerStyle:
    """Style of a street layer: one colour per pole arrangement (Chuang 2011, Fig. 8).

    Parameters
    ----------
    arrangements
        The arrangements, each its own colour
        (:data:`nightlights.streets.schema.ARRANGEMENTS`); any other or missing value is grey.
    field
        Field holding the arrangement.
    """
    listed = list(dict.fromkeys(arrangements))[: len(CATEGORY_COLOURS)]
    categories = [(name, name.replace("_", " ")) for name in listed]
    categories.append(("", "not known"))
    colours = [*CATEGORY_COLOURS[: len(listed)], OTHER_COLOUR]
    symbols = [
        _line_symbol(str(index), colour, width=STREET_WIDTH_MM)
        for index, colour in enumerate(colours)
    ]
    description = "streets: coloured by pole arrangement"
    return LayerStyle(
        "streets by arrangement",
        _vector_document(_categorized(field, categories, symbols), description),
        description,
    )


#: Colours of a compliance layer's statuses: pass, fail, not rated.
COMPLIANCE_COLOURS = {"pass": "#1a9641", "fail": "#d7191c", "not rated": OTHER_COLOUR}


def compliance_style(*, field: str = "status") -> LayerStyle:
    """Style of a road-lighting audit layer: segments green where they keep their lighting
    class, red where they do not, grey where not rated.

    Parameters
    ----------
    field
        Field holding ``pass``, ``fail`` or ``not rated``.
    """
    categories = [(name, name) for name in COMPLIANCE_COLOURS]
    symbols = [
        _line_symbol(str(index), colour, width=2 * STREET_WIDTH_MM)
        for index, colour in enumerate(COMPLIANCE_COLOURS.values())
    ]
    description = "road lighting: segments by compliance with their lighting class"
    return LayerStyle(
        "segments by compliance",
        _vector_document(_categorized(field, categories, symbols), description),
        description,
    )


def _graduated_points(
    field: str, edges: Sequence[float], labels: Sequence[str], colours: Sequence[str]
) -> str:
    """A graduated renderer of circles on ``field``: class i from ``edges[i]`` to
    ``edges[i + 1]``, labelled ``labels[i]``, in ``colours[i]``."""
    ranges = "\n".join(
        f'      <range lower="{edges[i]!r}" upper="{edges[i + 1]!r}" symbol="{i}" '
        f'label={quoteattr(labels[i])} render="true"/>'
        for i in range(len(labels))
    )
    symbols = "\n".join(
        _marker_symbol(str(i), colour, shape="circle", size=OBSERVER_SIZE_MM, rotation_field=None)
        for i, colour in enumerate(colours)
    )
    return f"""  <renderer-v2 type="graduatedSymbol" attr={quoteattr(field)} graduatedMethod="GraduatedColor" symbollevels="0" enableorderby="0" forceraster="0">
    <ranges>
{ranges}
    </ranges>
    <symbols>
{symbols}
    </symbols>
  </renderer-v2>"""  # noqa: E501


def observers_style(*, field: str = "zenith_mag", label_field: str | None = "name") -> LayerStyle:
    """Style of a points summary layer of observers: each point in the Bortle colour of its
    zenith sky brightness (:func:`sky_brightness_qml`'s classes), labelled with its name.

    Parameters
    ----------
    field
        Field with the zenith sky brightness [mag arcsec-2].
    label_field
        Field of the point labels; None for no labels.

    Returns
    -------
    LayerStyle
        A graduated renderer on ``field`` with the nine Bortle classes.
    """
    edges = [0.0, *_bortle_upper_edges()]
    renderer = _graduated_points(field, edges, _bortle_labels(), list(reversed(BORTLE_COLOURS)))
    labeling = _labels(label_field) if label_field else ""
    description = f"observers: Bortle colour of {field}"
    return LayerStyle(
        "observers by zenith brightness",
        _vector_document(renderer, description, labeling),
        description,
    )


#: Class edges of the residual style [mag arcsec-2]: within +-0.1 the model is as good as a
#: meter's repeatability; beyond +-0.5 it is off by more than the World Atlas's stated scatter
#: (Falchi et al. 2016 report 0.2-0.3 mag between the atlas and SQM readings).
RESIDUAL_EDGES = (-99.0, -0.5, -0.25, -0.1, 0.1, 0.25, 0.5, 99.0)
#: Their colours: brighter than predicted in reds, darker in blues (ColorBrewer RdBu).
RESIDUAL_COLOURS = ("#b2182b", "#ef8a62", "#fddbc7", "#f7f7f7", "#d1e5f0", "#67a9cf", "#2166ac")


def residual_style(*, field: str = "residual", label_field: str | None = "station") -> LayerStyle:
    """Style of a validation's stations: each point coloured by its residual (measured -
    predicted [mag arcsec-2]) in :data:`RESIDUAL_EDGES` classes, labelled with its name.

    Parameters
    ----------
    field
        Field with the residual [mag arcsec-2].
    label_field
        Field of the point labels; None for no labels.

    Returns
    -------
    LayerStyle
        A graduated renderer on ``field``, red where the sky is brighter than predicted.
    """
    edges = RESIDUAL_EDGES
    names = [
        "brighter by > 0.5",
        "brighter by 0.25-0.5",
        "brighter by 0.1-0.25",
        "within 0.1",
        "darker by 0.1-0.25",
        "darker by 0.25-0.5",
        "darker by > 0.5",
    ]
    renderer = _graduated_points(field, edges, names, RESIDUAL_COLOURS)
    labeling = _labels(label_field) if label_field else ""
    description = f"stations: {field} (measured - predicted, mag arcsec-2)"
    return LayerStyle(
        "stations by residual", _vector_document(renderer, description, labeling), description
    )


def _labels(field: str) -> str:
    return f"""  <labeling type="simple">
    <settings calloutType="simple">
      <text-style fieldName={quoteattr(field)} isExpression="0" fontSize="9" fontSizeUnit="Point" textColor="20,20,20,255" textOpacity="1" fontFamily="Sans Serif" namedStyle="Regular" fontWeight="50" fontItalic="0">
        <text-buffer bufferDraw="1" bufferSize="0.8" bufferSizeUnits="MM" bufferColor="255,255,255,255" bufferOpacity="0.8"/>
      </text-style>
      <placement placement="1" dist="1.5" distUnits="MM" quadOffset="2" offsetType="1"/>
      <rendering drawLabels="1" obstacle="1" scaleVisibility="0"/>
    </settings>
  </labeling>"""  # noqa: E501


# --- the layer_styles table -----------------------------------------------------------------


def add_layer_style(
    path: str | os.PathLike[str], layer: str, style: LayerStyle, *, geometry_column: str
) -> None:
    """Store ``style`` as the default style of ``layer`` in a GeoPackage's ``layer_styles``.

    The table is created when missing, with the columns QGIS creates (QGIS User Guide,
    "Storing styles in a database"), and registered as an attributes table.

    Parameters
    ----------
    path
        An existing GeoPackage holding ``layer`` (written in place: call on a temporary).
    layer
        The styled layer's name.
    style
        The style.
    geometry_column
        The layer's geometry column, which QGIS matches when it looks the style up.

    Raises
    ------
    OutputError
        GDAL cannot append the table.
    """
    import pandas as pd
    import pyogrio

    row = pd.DataFrame(
        {
            "f_table_catalog": [""],
            "f_table_schema": [""],
            "f_table_name": [layer],
            "f_geometry_column": [geometry_column],
            "styleName": [style.name],
            "styleQML": [style.qml],
            "styleSLD": [""],
            "useAsDefault": [True],
            "description": [style.description],
            "owner": [""],
            "ui": [""],
            "update_time": [pd.Timestamp(datetime.now(UTC))],
        }
    )
    try:
        pyogrio.write_dataframe(row, path, layer=STYLES_TABLE, driver="GPKG", append=True)
    except pyogrio.errors.DataSourceError as exc:
        raise OutputError(f"{path}: cannot store the style of layer {layer!r}: {exc}") from exc
