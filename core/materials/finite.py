"""Non-finite inputs read as Cycles renders them: what a NaN or an infinity in a material or the world becomes.

Cycles never lets a NaN or an infinity reach its film: its SVM compiler reads an input's NaN or infinite own
value as 0 (scene/svm.cpp, SVMCompiler::input_float and input_float3), a node clamps what it clamps (Principled:
roughness, metallic, alpha ... with saturatef, IOR with fmaxf(ior, 1e-5)), bsdf_alloc drops a closure whose
weight is not a number (kernel/closure/alloc.h, closure_sample_weight), and the film replaces each component of a
contribution that is still not finite by 0 (kernel/film/light_passes.h, film_clamp_light: ensure_finite). Primer
reads the inputs that way once, when a material or the world is set up, and says which it changed:

- NaN: 0;
- +-infinity in an input the node clamps to 0..1 (UNIT_INPUTS): the bound it clamps to (Cycles' saturatef);
- +-infinity elsewhere (a colour, an emission, a strength, an IOR, a weight): 0, since every contribution it
  makes is infinite or NaN and Cycles' film drops it (ensure_finite). An IOR read as 0 becomes 1e-5 in the node,
  as Cycles clamps it: a surface that reflects nearly all light, as an infinite IOR does.

core/film/film.py keeps the last guard: a sample that is still not finite is replaced by 0 and counted.
"""
from __future__ import annotations

import numpy as np

# Inputs every node that has them clamps to 0..1 (Cycles' saturatef): an infinity there is the bound.
UNIT_INPUTS = frozenset({"metallic", "roughness", "alpha", "subsurface", "coat_roughness", "transmission",
                         "diffuse_roughness", "sheen_roughness", "anisotropic"})


def finite_value(name: str, value):
    """Return `value` (a float or (k,) floats) as Cycles reads it (module docstring), and whether it changed."""
    array = np.asarray(value, np.float64)
    bad = ~np.isfinite(array)
    if not bad.any():
        return value, False
    if name in UNIT_INPUTS:
        clean = np.where(np.isnan(array), 0.0, np.clip(array, 0.0, 1.0))
    else:
        clean = np.where(bad, 0.0, array)
    return (float(clean) if clean.ndim == 0 else clean), True


def finite_color(value) -> tuple:
    """Return a colour (3,) float64 with each NaN or infinite channel 0 (Cycles' ensure_finite), and whether it
    changed."""
    array = np.asarray(value, np.float64)[:3]
    bad = ~np.isfinite(array)
    return np.where(bad, 0.0, array), bool(bad.any())
