"""Emission angular distributions of a ground source and their registry, as the sky package has
named them.

The shapes and their registry are a leaf of the whole package now
(:mod:`nightlights.emission_functions`, with the band tag that names a band's mix of them),
importable from any layer; this module hands the same objects on under their earlier path, so a
shape registered through either path is one registration.
"""

from __future__ import annotations

from nightlights.emission_functions import (
    COMPILED_FORMS,
    COSINE_FORM,
    EMISSION_MODELS,
    GARSTANG_LOBE_NORM,
    ISOTROPIC_FORM,
    PSI4_LOBE_FORM,
    SAMPLED_FORMS,
    SINE_POWER_FORM,
    TABLE_FORM,
    TABULATED_PREFIX,
    UPLIGHT_EXPONENT,
    EmissionShape,
    emission_intensity,
    emission_shape,
    emission_shape_names,
    form_intensity,
    garstang_weights,
    kernel_table_names,
    parse_tabulated_emission,
    register_emission_shape,
    sampled_shape,
    tabulated_emission_intensity,
    tabulated_norm,
    unregister_emission_shape,
)

__all__ = [
    "COMPILED_FORMS",
    "COSINE_FORM",
    "EMISSION_MODELS",
    "GARSTANG_LOBE_NORM",
    "ISOTROPIC_FORM",
    "PSI4_LOBE_FORM",
    "SAMPLED_FORMS",
    "SINE_POWER_FORM",
    "TABLE_FORM",
    "TABULATED_PREFIX",
    "UPLIGHT_EXPONENT",
    "EmissionShape",
    "emission_intensity",
    "emission_shape",
    "emission_shape_names",
    "form_intensity",
    "garstang_weights",
    "kernel_table_names",
    "parse_tabulated_emission",
    "register_emission_shape",
    "sampled_shape",
    "tabulated_emission_intensity",
    "tabulated_norm",
    "unregister_emission_shape",
]
