"""Refuse a scene or settings that cannot be rendered, with a message that says why.

It checks the settings against the tables of the parts that use them (integrators, passes, debug
buffers, kernels, instancing modes), so it sits in the render part, above them all.
"""
from __future__ import annotations

import math

import numpy as np

from ..geometry import instancing
from ..integrators import INTEGRATORS
from ..integrators.debug import AUX_BUFFERS
from ..integrators.lightpasses import LIGHT_PASSES
from ..integrators.passes import CRYPTO_PASSES, PASS_CHANNELS
from ..native.library import KERNELS

# The most bounces a path may take (Blender's own limit for Light Paths > Max Bounces).
MAX_BOUNCES = 1024


def validate(scene, settings) -> None:
    """Raise ValueError with a clear message when the scene or settings cannot be rendered."""
    if scene.camera is None:
        raise ValueError("the scene has no camera")
    if settings.width < 1 or settings.height < 1:
        raise ValueError(f"resolution must be at least 1x1 pixels, got {settings.width}x{settings.height}")
    if settings.samples < 1:
        raise ValueError(f"samples must be at least 1, got {settings.samples}")
    if settings.chunk_size < 1:
        raise ValueError(f"chunk size must be at least 1 sample, got {settings.chunk_size}")
    if not (math.isfinite(settings.adaptive_threshold) and settings.adaptive_threshold >= 0):
        raise ValueError(f"the adaptive noise threshold must be a finite number >= 0, got {settings.adaptive_threshold}")
    if settings.adaptive_min_samples < 0:
        raise ValueError(f"adaptive min samples must be >= 0, got {settings.adaptive_min_samples}")
    if not all(math.isfinite(a) and a > 0 for a in settings.pixel_aspect):
        raise ValueError(f"pixel aspect must be two finite numbers > 0, got {settings.pixel_aspect}")
    settings.filter  # noqa: B018  (a known pixel filter of a positive width, or a ValueError saying so)
    if settings.integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {sorted(INTEGRATORS)}, got {settings.integrator!r}")
    for name in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
                 "transparent_max_bounces", "volume_bounces", "min_light_bounces", "ao_bounces"):
        value = getattr(settings, name)
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value <= MAX_BOUNCES:
            raise ValueError(f"{name.replace('_', ' ')} must be a whole number from 0 to {MAX_BOUNCES}, got {value!r}")
    for name in ("sample_clamp_direct", "sample_clamp_indirect"):
        value = getattr(settings, name)
        if not (isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value) and value >= 0):
            raise ValueError(f"{name.replace('_', ' ')} must be a finite number >= 0 (0: no clamping), got {value!r}")
    for name in ("ao_factor", "ao_additive_factor", "ao_distance"):      # (Fast GI; the Ambient Occlusion pass)
        value = getattr(settings, name)
        if not (isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value)):
            raise ValueError(f"{name.replace('_', ' ')} must be a finite number, got {value!r}")
    if settings.fresnel not in ("exact", "schlick"):
        raise ValueError(f"fresnel must be 'exact' or 'schlick', got {settings.fresnel!r}")
    if settings.light_sampling not in ("mis", "light", "bsdf"):
        raise ValueError(f"light sampling must be 'mis', 'light' or 'bsdf', got {settings.light_sampling!r}")
    if settings.shadow_method not in ("robust", "epsilon"):
        raise ValueError(f"shadow method must be 'robust' or 'epsilon', got {settings.shadow_method!r}")
    if settings.visibility_normal not in ("face", "shading"):
        raise ValueError(f"visibility normal must be 'face' or 'shading', got {settings.visibility_normal!r}")
    if settings.kernels not in KERNELS:
        raise ValueError(f"kernels must be one of {KERNELS}, got {settings.kernels!r}")
    if settings.instancing not in instancing.INSTANCING_MODES:
        raise ValueError(f"instancing must be one of {instancing.INSTANCING_MODES}, got {settings.instancing!r}")
    if settings.shadow_method == "epsilon" and not (settings.epsilon >= 0 and math.isfinite(settings.epsilon)):
        raise ValueError(f"epsilon must be a finite length >= 0, got {settings.epsilon}")
    if not np.isfinite(np.asarray(scene.camera.matrix_world)).all():
        raise ValueError("the camera's transform has NaN or infinite values")
    unknown = set(settings.aux) - set(AUX_BUFFERS)
    if unknown:
        raise ValueError(f"unknown auxiliary buffers {sorted(unknown)}; choose from {list(AUX_BUFFERS)}")
    known = list(PASS_CHANNELS) + list(CRYPTO_PASSES) + list(LIGHT_PASSES)
    unknown = set(settings.passes) - set(known)
    if unknown:
        raise ValueError(f"unknown render passes {sorted(unknown)}; choose from {known}")
    wrong = [aov for aov in settings.aovs if len(aov) != 2 or aov[1] not in ("COLOR", "VALUE")]
    if wrong:
        raise ValueError(f"shader AOVs must be (name, \"COLOR\" or \"VALUE\") pairs, got {wrong}")
    if not 1 <= int(settings.cryptomatte_depth) <= 16:
        raise ValueError(f"cryptomatte_depth must be 1 .. 16 ranks, got {settings.cryptomatte_depth}")
