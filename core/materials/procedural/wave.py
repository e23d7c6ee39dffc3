"""Cycles' Wave Texture (kernel/svm/wave.h): bands or rings of a sine, saw or triangle profile, distorted by fBM."""
from __future__ import annotations

import numpy as np

from . import perlin
from .base import F32, TextureNode, as_f32

WAVE_TYPES = ("BANDS", "RINGS")
BANDS_DIRECTIONS = ("X", "Y", "Z", "DIAGONAL")
RINGS_DIRECTIONS = ("X", "Y", "Z", "SPHERICAL")
PROFILES = ("SIN", "SAW", "TRI")
HALF_PI = F32(1.570796327)
TWO_PI = F32(6.283185307)


def sine(x: np.ndarray) -> np.ndarray:
    """sin of float32 x, in double rounded to float32 (the same in numpy and C; Cycles' sinf may differ by an ulp)."""
    return np.sin(x.astype(np.float64)).astype(F32)


def cosine(x: np.ndarray) -> np.ndarray:
    """cos of float32 x, in double rounded to float32 (as `sine`)."""
    return np.cos(x.astype(np.float64)).astype(F32)


class WaveTexture(TextureNode):
    """Fac: the profile of n + Phase Offset + Distortion x (2 fBM(p x Detail Scale) - 1), where n is 20 x the point's
    coordinate along the bands' direction (10 x (x + y + z) diagonally) or 20 x its distance from the rings' axis
    (from the origin: spherical); sine 1/2 - cos(n) / 2, saw n / 2pi mod 1, triangle twice the distance of n / 2pi
    to the nearest integer. The scaled point is nudged by (p + 1e-6) x 0.999999 first, as Cycles does. Color: (f, f,
    f)."""

    kind = "TEX_WAVE"
    blender = "ShaderNodeTexWave"
    c_name = "wave"
    inputs = (("Vector", 3, "generated"), ("Scale", 1, 5.0), ("Distortion", 1, 0.0), ("Detail", 1, 2.0),
              ("Detail Scale", 1, 1.0), ("Detail Roughness", 1, 0.5), ("Phase Offset", 1, 0.0))
    outputs = {"Color": (3, "color"), "Fac": (1, "float")}
    settings = {"wave_type": ("wave_type", WAVE_TYPES, "BANDS"),
                "bands_direction": ("bands_direction", BANDS_DIRECTIONS, "X"),
                "rings_direction": ("rings_direction", RINGS_DIRECTIONS, "X"),
                "wave_profile": ("wave_profile", PROFILES, "SIN")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Colour (f, f, f) and Fac f side by side."""
        vector, scale, distortion, detail, dscale, droughness, phase = (as_f32(x) for x in inputs)
        wave_type, bands, rings, profile = numbers[:4]
        p = vector * scale
        p = (p + F32(0.000001)) * F32(0.999999)
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        if WAVE_TYPES[wave_type] == "BANDS":
            n = (x + y + z) * F32(10.0) if BANDS_DIRECTIONS[bands] == "DIAGONAL" else p[:, bands] * F32(20.0)
        else:
            r = p.copy()
            if RINGS_DIRECTIONS[rings] != "SPHERICAL":
                r[:, rings] = F32(0.0)
            n = np.sqrt(r[:, 0] * r[:, 0] + r[:, 1] * r[:, 1] + r[:, 2] * r[:, 2]) * F32(20.0)
        n = n + phase[:, 0]
        distortion = distortion[:, 0]
        distorted = distortion != F32(0.0)
        if distorted.any():
            q = p * dscale
            fbm = perlin.fbm(q, detail[:, 0], droughness[:, 0], np.full(len(p), F32(2.0)), True)
            n = np.where(distorted, n + distortion * (fbm * F32(2.0) - F32(1.0)), n)
        if PROFILES[profile] == "SIN":
            f = F32(0.5) + F32(0.5) * sine(n - HALF_PI)
        elif PROFILES[profile] == "SAW":
            n = n / TWO_PI
            f = n - np.floor(n)
        else:
            n = n / TWO_PI
            f = np.abs(n - np.floor(n + F32(0.5))) * F32(2.0)
        f = f.astype(np.float64)
        return np.stack([f, f, f, f], axis=1)
