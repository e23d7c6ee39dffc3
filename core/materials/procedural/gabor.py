"""Cycles' Gabor Texture (kernel/svm/gabor.h): sparse convolution noise of windowed Gabor kernels, in 2D or 3D."""
from __future__ import annotations

import numpy as np

from . import hash as hash_
from .base import F32, TextureNode, as_f32

GABOR_TYPES = ("2D", "3D")
IMPULSES = 8                                    # Gabor kernels per cell
PI = F32(np.pi)
TWO_PI = F32(2.0) * PI


def f32(function, *args) -> np.ndarray:
    """A libm function of float32 arguments, in double rounded to float32 (the same in numpy and C; Cycles' float
    versions may differ by an ulp)."""
    return function(*(np.asarray(a, F32).astype(np.float64) for a in args)).astype(F32)


def kernel(d2: np.ndarray, angle_dot: np.ndarray) -> tuple:
    """A Gabor kernel at squared distance d2 from its centre, its phase argument angle_dot (the offset dotted with
    the frequency vector): the Gaussian e^(-pi d2) times the Hann window 1/2 + cos(pi d2) / 2, as a phasor of angle
    2pi angle_dot. -> (real, imaginary) float32."""
    hann = F32(0.5) + F32(0.5) * f32(np.cos, PI * d2)
    envelope = f32(np.exp, -PI * d2) * hann
    angle = TWO_PI * angle_dot
    return envelope * f32(np.cos, angle), envelope * f32(np.sin, angle)


def noise_2d(p: np.ndarray, frequency, isotropy, base) -> tuple:
    """Cycles' compute_2d_gabor_noise at points p (n, 2) float32: the phasors of 8 kernels per cell summed over the
    3 x 3 cells about the point (each cell's own sum added in turn). -> (real, imaginary) (n,) float32."""
    cell = np.floor(p)
    local = p - cell
    total = [np.zeros(len(p), F32), np.zeros(len(p), F32)]
    for j in (-1, 0, 1):
        for i in (-1, 0, 1):
            cx, cy = cell[:, 0] + F32(i), cell[:, 1] + F32(j)
            px, py = local[:, 0] - F32(i), local[:, 1] - F32(j)
            noise = [np.zeros(len(p), F32), np.zeros(len(p), F32)]
            for k in range(IMPULSES):
                seed = F32(k * 3)
                orientation = base + (hash_.hash_float3(cx, cy, seed) - F32(0.5)) * PI * isotropy
                centre_x = hash_.hash_float3(cx, cy, seed + F32(1.0))
                centre_y = hash_.hash_float3(seed + F32(1.0), cx, cy)
                x, y = px - centre_x, py - centre_y
                d2 = x * x + y * y
                inside = d2 < F32(1.0)
                weight = np.where(hash_.hash_float3(cx, cy, seed + F32(2.0)) < F32(0.5), F32(-1.0), F32(1.0))
                fx, fy = frequency * f32(np.cos, orientation), frequency * f32(np.sin, orientation)
                real, imaginary = kernel(d2, x * fx + y * fy)
                noise[0] = np.where(inside, noise[0] + weight * real, noise[0])
                noise[1] = np.where(inside, noise[1] + weight * imaginary, noise[1])
            total = [total[0] + noise[0], total[1] + noise[1]]
    return total[0], total[1]


def orientation_3d(base: np.ndarray, isotropy, seed: tuple) -> np.ndarray:
    """Cycles' compute_3d_orientation: the base direction (n, 3) turned by random inclination and azimuth (hashes
    of the seed x pi x isotropy); the base itself where isotropy is 0."""
    inclination = f32(np.arccos, base[:, 2])
    planar = np.sqrt(base[:, 0] * base[:, 0] + base[:, 1] * base[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        azimuth = np.where(base[:, 1] < F32(0.0), F32(-1.0), F32(1.0)) * f32(np.arccos, base[:, 0] / planar)
    cx, cy, cz, w = seed
    inclination = inclination + hash_.hash_float4(cx, cy, cz, w) * PI * isotropy
    azimuth = azimuth + hash_.hash_float4(cz, cx, w, cy) * PI * isotropy
    sine = f32(np.sin, inclination)
    turned = np.stack([sine * f32(np.cos, azimuth), sine * f32(np.sin, azimuth), f32(np.cos, inclination)], axis=1)
    return np.where((isotropy == F32(0.0))[:, None], base, turned)


def noise_3d(p: np.ndarray, frequency, isotropy, base: np.ndarray) -> tuple:
    """Cycles' compute_3d_gabor_noise at points p (n, 3) float32 over the 3 x 3 x 3 cells about each."""
    cell = np.floor(p)
    local = p - cell
    total = [np.zeros(len(p), F32), np.zeros(len(p), F32)]
    for k3 in (-1, 0, 1):
        for j in (-1, 0, 1):
            for i in (-1, 0, 1):
                offset = np.array([i, j, k3], F32)
                c = cell + offset
                q = local - offset
                noise = [np.zeros(len(p), F32), np.zeros(len(p), F32)]
                for k in range(IMPULSES):
                    seed = F32(k * 3)
                    orientation = orientation_3d(base, isotropy, (c[:, 0], c[:, 1], c[:, 2], seed))
                    centre = hash_.hash_float4_to_float3(c[:, 0], c[:, 1], c[:, 2], seed + F32(1.0))
                    x = q - centre
                    d2 = (x[:, 0] * x[:, 0] + x[:, 1] * x[:, 1]) + x[:, 2] * x[:, 2]
                    inside = d2 < F32(1.0)
                    weight = np.where(hash_.hash_float4(c[:, 0], c[:, 1], c[:, 2], seed + F32(2.0)) < F32(0.5),
                                      F32(-1.0), F32(1.0))
                    f = frequency[:, None] * orientation
                    real, imaginary = kernel(d2, (x[:, 0] * f[:, 0] + x[:, 1] * f[:, 1]) + x[:, 2] * f[:, 2])
                    noise[0] = np.where(inside, noise[0] + weight * real, noise[0])
                    noise[1] = np.where(inside, noise[1] + weight * imaginary, noise[1])
                total = [total[0] + noise[0], total[1] + noise[1]]
    return total[0], total[1]


class GaborTexture(TextureNode):
    """The phasor (real, imaginary) of Gabor noise at the point x Scale: 8 kernels per unit cell, each at a hashed
    centre with a hashed sign, of frequency Frequency (at least 0.001) along Orientation turned by a hashed angle x
    (1 - Anisotropy). Value: imaginary / (6 sigma) / 2 + 1/2; Phase: (atan2(imaginary, real) + pi) / 2pi; Intensity:
    |phasor| / (6 sigma), sigma the noise's standard deviation (1 in 2D, sqrt(1 / sqrt 2) in 3D)."""

    kind = "TEX_GABOR"
    blender = "ShaderNodeTexGabor"
    c_name = "gabor"
    inputs = (("Vector", 3, "generated"), ("Scale", 1, 5.0), ("Frequency", 1, 2.0), ("Anisotropy", 1, 1.0),
              ("Orientation 2D", 1, float(F32(np.pi / 4))), ("Orientation 3D", 3, (1.4142135381698608,) * 2 + (0.0,)))
    outputs = {"Value": (1, "float"), "Phase": (1, "float"), "Intensity": (1, "float")}
    settings = {"gabor_type": ("gabor_type", GABOR_TYPES, "2D")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Value, Phase and Intensity side by side (n, 3)."""
        vector, scale, frequency, anisotropy, angle, direction = (as_f32(x) for x in inputs)
        p = vector * scale
        isotropy = F32(1.0) - np.clip(anisotropy[:, 0], F32(0.0), F32(1.0))
        frequency = np.maximum(F32(0.001), frequency[:, 0])
        if GABOR_TYPES[numbers[0]] == "2D":
            real, imaginary = noise_2d(p[:, :2], frequency, isotropy, angle[:, 0])
            sigma = np.sqrt(F32(IMPULSES) * F32(0.5) * F32(0.25))
        else:
            length = np.sqrt((direction[:, 0] * direction[:, 0] + direction[:, 1] * direction[:, 1])
                             + direction[:, 2] * direction[:, 2])
            with np.errstate(divide="ignore", invalid="ignore"):
                base = direction / length[:, None]
            real, imaginary = noise_3d(p, frequency, isotropy, base)
            sigma = np.sqrt(F32(IMPULSES) * F32(0.5) * (F32(1.0) / (F32(4.0) * F32(np.sqrt(2.0)))))
        norm = F32(6.0) * sigma
        value = (imaginary / norm) * F32(0.5) + F32(0.5)
        phase = (f32(np.arctan2, imaginary, real) + PI) / TWO_PI
        intensity = np.sqrt(real * real + imaginary * imaginary) / norm
        return np.stack([value, phase, intensity], axis=1).astype(np.float64)
