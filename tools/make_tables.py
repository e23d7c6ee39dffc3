"""Write core/materials/ggx_tables.h: the GGX albedo tables that Multiscatter GGX and the Principled BSDF's
layering read (core/materials/ggx_tables.py says what each holds and how it is looked up).

Each entry is an integral over the directions a GGX lobe reflects into, computed here from Primer's
own BSDF (core/materials/microfacet.py) with a 128 x 128 grid of stratified points, the same way
Cycles defines its tables (intern/cycles/app/cycles_precompute.cpp): the mean, over directions sampled
from the visible normals, of the sample's weight (E) or of the Fresnel curve's blend factor (s), a
direction that falls below the surface counting as 0. The grid points are rough, mu and z at
i / (size - 1), clamped as Cycles clamps them.

    .venv/bin/python tools/make_tables.py          # rewrites core/materials/ggx_tables.h (about a minute)
"""
from __future__ import annotations

import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from core.materials import microfacet as mf  # noqa: E402

GRID = 128          # stratified points per axis of the unit square, per table entry
OUT = os.path.join(ROOT, "core", "materials", "ggx_tables.h")


def square(grid: int = GRID) -> np.ndarray:
    """The midpoints of a grid x grid partition of the unit square: (grid^2, 2) float64."""
    axis = (np.arange(grid) + 0.5) / grid
    u, v = np.meshgrid(axis, axis, indexing="ij")
    return np.stack([u.ravel(), v.ravel()], axis=1)


def lobe_samples(rough: float, mu: np.ndarray, ior: float = 1.0, grid: int = GRID):
    """Sample a GGX lobe (no Fresnel) seen from each mu (k,): return (weight (k, g), cos_HI (k, g), valid (k, g)).

    A lobe smoother than ROUGHNESS_SQ_THRESHOLD is a mirror: every sample reflects about N with weight 1."""
    u = square(grid)
    g, k = len(u), len(mu)
    if (rough * rough) ** 2 <= mf.ROUGHNESS_SQ_THRESHOLD:
        return np.ones((k, g)), np.repeat(mu[:, None], g, axis=1), np.ones((k, g), bool)
    wo = np.stack([np.sqrt(np.maximum(1.0 - mu * mu, 0.0)), np.zeros(k), mu], axis=1)
    wo = np.repeat(wo, g, axis=0)
    N = np.tile([0.0, 0.0, 1.0], (k * g, 1))
    params = np.zeros((k * g, 24))
    params[:, mf.ALPHA] = rough * rough
    params[:, mf.IOR] = ior
    params[:, mf.ENERGY] = 1.0
    s = mf.Microfacet.sample(params, N, wo, np.tile(u, (k, 1)))
    H = s.wi + wo
    H /= np.maximum(np.linalg.norm(H, axis=1), 1e-300)[:, None]
    cos_HI = np.einsum("ij,ij->i", H, wo)
    valid = s.pdf > 0.0
    return s.weight[:, 0].reshape(k, g), cos_HI.reshape(k, g), valid.reshape(k, g)


def clamp_axis(size: int, low: float = 1e-4, high: float = 1.0) -> np.ndarray:
    """The grid coordinates i / (size - 1), clamped to [low, high], as Cycles' precomputation does."""
    return np.clip(np.arange(size) / (size - 1), low, high)


def ggx_E(size: int = 32) -> np.ndarray:
    """E[mu][rough]: directional albedo of GGX with F = 1."""
    table = np.zeros((size, size))
    mus = clamp_axis(size)
    for x, rough in enumerate(clamp_axis(size)):
        weight, _, _ = lobe_samples(rough, mus)
        table[:, x] = weight.mean(axis=1)
    return np.clip(table, 0.0, 1.0)


def ggx_Eavg(size: int = 32, mu_points: int = 64) -> np.ndarray:
    """Eavg[rough] = integral over mu of 2 mu E(mu)."""
    mus = (np.arange(mu_points) + 0.5) / mu_points
    out = np.zeros(size)
    for x, rough in enumerate(clamp_axis(size)):
        weight, _, _ = lobe_samples(rough, mus, grid=GRID // 2)
        out[x] = np.mean(2.0 * mus * weight.mean(axis=1))
    return np.clip(out, 0.0, 1.0)


def ggx_gen_schlick_ior_s(size: int = 16) -> np.ndarray:
    """s[z][mu][rough]: the mean blend factor from F0 to F90 of the real dielectric curve, ior = ior_from_F0(z^4)."""
    table = np.zeros((size, size, size))
    mus = clamp_axis(size)
    zs = clamp_axis(size, 1e-4, 0.99)
    for x, rough in enumerate(clamp_axis(size)):
        _, cos_HI, valid = lobe_samples(rough, mus, grid=GRID // 2)
        for z, zz in enumerate(zs):
            ior = float(mf.ior_from_F0(zz ** 4))
            real = mf.fresnel_dielectric(cos_HI.ravel(), ior).reshape(cos_HI.shape)
            F0 = mf.F0_from_ior(ior)
            s = np.clip((real - F0) / (1.0 - F0), 0.0, 1.0)
            table[z, :, x] = np.where(valid, s, 0.0).mean(axis=1)
    return np.clip(table, 0.0, 1.0)


def ggx_schlick_s_half(size: int = 16) -> np.ndarray:
    """s[mu][rough] of Schlick's curve (1 - cos)^exponent, as Cycles reads its exponent table at z = 0.5:
    halfway between its slices z = 7/15 and 8/15 (exponent 5 (1 - z) / z)."""
    table = np.zeros((size, size))
    mus = clamp_axis(size)
    for x, rough in enumerate(clamp_axis(size)):
        _, cos_HI, valid = lobe_samples(rough, mus, grid=GRID // 2)
        for z in (7 / 15, 8 / 15):
            exponent = 5.0 * (1.0 - z) / z
            s = np.clip(1.0 - cos_HI, 0.0, 1.0) ** exponent
            table[:, x] += 0.5 * np.where(valid, s, 0.0).mean(axis=1)
    return np.clip(table, 0.0, 1.0)


def glass_weights(rough: float, mu: np.ndarray, eta: float, grid: int = GRID // 2) -> np.ndarray:
    """Rough glass (dielectric Fresnel, relative index eta) seen from each mu (k,): the mean weight of its
    samples over a grid of visible normals, reflection and refraction each counted with its Fresnel share
    (so no third number is needed): F G2 / G1 where the reflected direction is above the surface, plus
    (1 - F) G2 / G1 where the refracted one is below. Returns (k,)."""
    u = square(grid)
    g, k = len(u), len(mu)
    alpha = rough * rough
    if alpha * alpha <= mf.ROUGHNESS_SQ_THRESHOLD:
        return np.ones(k)
    wo = np.repeat(np.stack([np.sqrt(np.maximum(1.0 - mu * mu, 0.0)), np.zeros(k), mu], axis=1), g, axis=0)
    H = mf.sample_visible_normal(wo, np.full(k * g, alpha), np.tile(u, (k, 1)))
    cos_HO = np.einsum("ij,ij->i", H, wo)
    F = mf.fresnel_dielectric(cos_HO, eta)
    reflected = 2.0 * cos_HO[:, None] * H - wo
    cos_t2 = 1.0 - (1.0 - cos_HO * cos_HO) / (eta * eta)
    refracted = -wo / eta + (cos_HO / eta - np.sqrt(np.maximum(cos_t2, 0.0)))[:, None] * H
    a2 = alpha * alpha
    lambda_O = mf.lambda_ggx(a2, wo[:, 2])

    def lobe(wi, valid):
        G2_over_G1 = (1.0 + lambda_O) / (1.0 + lambda_O + mf.lambda_ggx(a2, np.abs(wi[:, 2])))
        return np.where(valid, G2_over_G1, 0.0)
    weight = F * lobe(reflected, reflected[:, 2] > 0.0) + (1.0 - F) * lobe(refracted, (refracted[:, 2] < 0.0) & (cos_t2 > 0.0))
    return weight.reshape(k, g).mean(axis=1)


def ggx_glass_E(inverse: bool, size: int = 16) -> tuple:
    """(E[z][mu][rough] 16^3, Eavg[z][rough] 16^2) of rough glass entering (ior = ior_from_F0(z^4)) or, with
    `inverse`, leaving it (relative index 1 / ior)."""
    table, average = np.zeros((size, size, size)), np.zeros((size, size))
    mus = clamp_axis(size)
    mid = (np.arange(32) + 0.5) / 32
    for z, zz in enumerate(clamp_axis(size, 1e-4, 0.99)):
        ior = float(mf.ior_from_F0(zz ** 4))
        eta = 1.0 / ior if inverse else ior
        for x, rough in enumerate(clamp_axis(size)):
            table[z, :, x] = glass_weights(rough, mus, eta)
            average[z, x] = np.mean(2.0 * mid * glass_weights(rough, mid, eta, GRID // 4))
    return np.clip(table, 0.0, 1.0), np.clip(average, 0.0, 1.0)


def c_array(name: str, values: np.ndarray, comment: str) -> str:
    """One table as a C array of doubles, 8 numbers a line."""
    flat = np.asarray(values, np.float64).ravel()
    lines = [", ".join(f"{v:.7g}" for v in flat[i:i + 8]) for i in range(0, len(flat), 8)]
    body = ",\n    ".join(lines)
    return f"/* {comment} */\nstatic const double {name}[{len(flat)}] = {{\n    {body}\n}};\n"


def main() -> None:
    """Compute every table and write the header."""
    parts = ["/* Generated by tools/make_tables.py; do not edit. GGX albedo tables (core/materials/ggx_tables.py). */\n"]
    parts.append(c_array("GGX_E", ggx_E(), "E[mu][rough], 32 x 32: directional albedo of GGX, F = 1"))
    parts.append(c_array("GGX_EAVG", ggx_Eavg(), "Eavg[rough], 32: its cosine-weighted mean over mu"))
    parts.append(c_array("GGX_SCHLICK_IOR_S", ggx_gen_schlick_ior_s(),
                         "s[z][mu][rough], 16^3: blend from F0 to F90 of the dielectric curve, ior = ior_from_F0(z^4)"))
    parts.append(c_array("GGX_SCHLICK_S_HALF", ggx_schlick_s_half(),
                         "s[mu][rough], 16 x 16: blend of Schlick's curve, as read at z = 0.5 (exponent about 5)"))
    for inverse, name in ((False, "GGX_GLASS"), (True, "GGX_GLASS_INV")):
        E, E_avg = ggx_glass_E(inverse)
        side = "leaving (relative index 1 / ior)" if inverse else "entering (relative index ior)"
        parts.append(c_array(name + "_E", E, f"E[z][mu][rough], 16^3: albedo of rough glass {side}, "
                                             "ior = ior_from_F0(z^4)"))
        parts.append(c_array(name + "_EAVG", E_avg, f"Eavg[z][rough], 16^2: its cosine-weighted mean over mu"))
    with open(OUT, "w") as handle:
        handle.write("\n".join(parts))
    print(f"wrote {os.path.relpath(OUT, ROOT)}")


if __name__ == "__main__":
    main()
