"""The GGX microfacet BSDF: rough specular reflection, as Cycles' Glossy BSDF and Principled BSDF use it.

A rough surface is a field of tiny mirrors (microfacets) whose normals H spread around N. GGX says how
they spread (D), Smith's masking-shadowing says how many of them the two directions both see (G), and
Fresnel says how much each mirror reflects (F):

    f cos = F(wo.H) D(H) G(wo, wi) / (4 N.wo)          with H = normalize(wo + wi)

alpha = roughness^2 sets the spread. Directions are sampled from the normals the viewer can see
(Heitz 2018, "Sampling the GGX Distribution of Visible Normals"), so pdf = D G1(wo) / (4 N.wo).

A single-scattering microfacet model loses the light that bounces between microfacets before it
leaves (up to 40% at roughness 1). Cycles' Multiscatter GGX puts it back by scaling f with
energy_scale = 1 / E(mu, roughness), E being the model's directional albedo (core/materials/ggx_tables.py),
and darkens it where Fresnel colours each extra bounce; both are set per hit by the closure's setup
(core/materials/principled.py), so this class only multiplies by `energy_scale`.

Anisotropic GGX (Cycles' bsdf_aniso_D and bsdf_aniso_lambda) spreads the normals by alpha_x along a tangent T
and alpha_y across it: in the frame X = T made perpendicular to N, Y = N x X, Z = N,

    D(h) = 1 / (pi ax ay ((hx/ax)^2 + (hy/ay)^2 + hz^2)^2),
    Lambda(v) = (sqrt(1 + ((ax vx)^2 + (ay vy)^2) / vz^2) - 1) / 2,

and the visible normals are sampled by stretching the view direction by (ax, ay, 1). A closure is anisotropic
where its TANGENT slots hold a non-zero vector and ALPHA_Y differs from ALPHA; otherwise it runs the isotropic
code unchanged (the same bits as before).

Fresnel models (parameter "fresnel"), as Cycles names them:
  NONE 0         F = 1 (the Glossy BSDF; its colour is the closure's weight)
  DIELECTRIC 1   the exact Fresnel reflectance of a dielectric with index `ior` (the Principled coat)
  SCHLICK_IOR 2  the dielectric's curve remapped to run from F0 to F90 (the Principled specular layer,
                 whose Specular IOR Level and Specular Tint scale F0)
  F82_TINT 3     Schlick's curve from F0 (the metal's colour) to 1, less b cos (1 - cos)^6, which dips it
                 near 82 degrees by the Specular Tint (the Principled metal: Kutz et al., Adobe Standard Material)
  THIN_FILM 4    the dielectric under a thin film (slots THICKNESS nm and FILM_IOR, relative to the ambient),
                 iridescent, scaled towards F0 as SCHLICK_IOR's F0 (core/materials/thin_film.py; the
                 Principled specular layer and glass with Thin Film Thickness > 0.1 nm); F90 is 1
  THIN_FILM_F82 5  F82_TINT's metal under a thin film (slots THICKNESS, FILM_IOR; thin_film.metal)
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from . import thin_film
from .base import BSDF, BsdfSample
from .base import BSDFFlags as F

# Parameter slots (a closure's row of PARAMS floats).
ALPHA, FRESNEL, IOR, F0, F90, ENERGY = 0, 1, 2, 3, 6, 9        # F0 and F90 take 3 slots each (RGB)
ALPHA_Y, TANGENT = 10, 11                                       # anisotropic: alpha across T, and T (3 slots)
THICKNESS, FILM_IOR = 16, 17                                    # thin film: nm, and its index (past glass's tints)
FRESNEL_NONE, FRESNEL_DIELECTRIC, FRESNEL_SCHLICK_IOR, FRESNEL_F82_TINT, FRESNEL_THIN_FILM = 0, 1, 2, 3, 4
FRESNEL_THIN_FILM_F82 = 5
# Below this alpha^2 a microfacet lobe is a perfect mirror (Cycles' BSDF_ROUGHNESS_SQ_THRESH).
ROUGHNESS_SQ_THRESHOLD = 2e-10


def fresnel_dielectric(cos_i: np.ndarray, eta) -> np.ndarray:
    """Exact unpolarized Fresnel reflectance of light arriving at cos_i (n,) on a dielectric of relative
    index eta (scalar or (n,)); 1 under total internal reflection."""
    cos_i = np.abs(cos_i)
    sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta)
    cos_t = np.sqrt(np.maximum(1.0 - sin_t2, 0.0))
    r_s = (cos_i - eta * cos_t) / np.maximum(cos_i + eta * cos_t, 1e-300)
    r_p = (eta * cos_i - cos_t) / np.maximum(eta * cos_i + cos_t, 1e-300)
    return np.where(sin_t2 >= 1.0, 1.0, 0.5 * (r_s * r_s + r_p * r_p))


def F0_from_ior(ior):
    """Reflectance at normal incidence of a dielectric of index ior: ((ior - 1) / (ior + 1))^2."""
    return ((ior - 1.0) / (ior + 1.0)) ** 2


def ior_from_F0(f0):
    """The index whose normal-incidence reflectance is f0 (in 0..1)."""
    root = np.sqrt(np.clip(f0, 0.0, 1.0 - 1e-7))
    return (1.0 + root) / (1.0 - root)


def fresnel(params: np.ndarray, cos_HI: np.ndarray) -> np.ndarray:
    """The reflectance (m, 3) of each closure's Fresnel model at cos_HI (m,) = wo.H."""
    mode = params[:, FRESNEL]
    ior = params[:, IOR]
    f0, f90 = params[:, F0:F0 + 3], params[:, F90:F90 + 3]
    F = np.ones((len(cos_HI), 3))
    dielectric = (mode == FRESNEL_DIELECTRIC) | (mode == FRESNEL_SCHLICK_IOR)
    if dielectric.any():
        real = fresnel_dielectric(cos_HI, np.where(dielectric, ior, 1.5))
        F = np.where((mode == FRESNEL_DIELECTRIC)[:, None], real[:, None], F)
        # Where the real curve is between its F0 and 1, the same fraction of the way from F0 to F90.
        F0_real = F0_from_ior(np.where(dielectric, ior, 1.5))
        s = np.clip((real - F0_real) / np.maximum(1.0 - F0_real, 1e-300), 0.0, 1.0)
        F = np.where((mode == FRESNEL_SCHLICK_IOR)[:, None], f0 + (f90 - f0) * s[:, None], F)
    metal = mode == FRESNEL_F82_TINT
    if metal.any():
        F = np.where(metal[:, None], fresnel_f82(cos_HI, f0, f90), F)
    film = mode == FRESNEL_THIN_FILM
    if film.any():
        rows = np.flatnonzero(film)
        F[rows] = thin_film.fresnel(cos_HI[rows], ior[rows], f0[rows], params[rows, THICKNESS], params[rows, FILM_IOR])
    film = mode == FRESNEL_THIN_FILM_F82
    if film.any():
        rows = np.flatnonzero(film)
        F[rows] = thin_film.metal(cos_HI[rows], f0[rows], f90[rows], params[rows, THICKNESS], params[rows, FILM_IOR])
    return F


def fresnel_f82(cos_i: np.ndarray, f0: np.ndarray, b: np.ndarray) -> np.ndarray:
    """F82-tint: Schlick from f0 (m, 3) to 1, less b cos (1 - cos)^6, clipped to 0..1."""
    s = np.clip(1.0 - cos_i, 0.0, 1.0)[:, None]
    s5 = s ** 5
    return np.clip(f0 + (1.0 - f0) * s5 - b * (cos_i[:, None] * s5 * s), 0.0, 1.0)


def lambda_ggx(alpha2: np.ndarray, cosine: np.ndarray) -> np.ndarray:
    """Smith's Lambda for GGX: the masking of a direction at `cosine` to the normal (Heitz 2014, eq. 72)."""
    tan2 = np.maximum(1.0 / np.maximum(cosine * cosine, 1e-300) - 1.0, 0.0)
    return 0.5 * (np.sqrt(1.0 + alpha2 * tan2) - 1.0)


def D_ggx(alpha2: np.ndarray, cos_NH: np.ndarray) -> np.ndarray:
    """The GGX distribution of microfacet normals at cos_NH (per unit projected area)."""
    c2 = np.minimum(cos_NH * cos_NH, 1.0)
    return alpha2 / (math.pi * (1.0 - c2 + alpha2 * c2) ** 2)


def sample_visible_normal(local_wo: np.ndarray, alpha: np.ndarray, u: np.ndarray, alpha_y=None) -> np.ndarray:
    """A microfacet normal (n, 3), in the frame where N = z, seen from local_wo (n, 3) (Heitz 2018); alpha (n,)
    along x, alpha_y (n,) along y (default alpha: isotropic)."""
    alpha_x = alpha
    alpha_y = alpha if alpha_y is None else alpha_y
    # 1. Stretch the view direction so the distribution becomes a hemisphere of radius 1.
    v = np.stack([alpha_x * local_wo[:, 0], alpha_y * local_wo[:, 1], local_wo[:, 2]], axis=1)
    v /= np.linalg.norm(v, axis=1)[:, None]
    # 2. A frame around it.
    lensq = v[:, 0] ** 2 + v[:, 1] ** 2
    flat = lensq <= 1e-7
    inv = 1.0 / np.sqrt(np.where(flat, 1.0, lensq))
    T1 = np.where(flat[:, None], [1.0, 0.0, 0.0], np.stack([-v[:, 1] * inv, v[:, 0] * inv, np.zeros(len(v))], axis=1))
    T2 = vectors.cross(v, T1)
    # 3. A point of the disk, squeezed into the part of it the view direction sees.
    r = np.sqrt(u[:, 0])
    cos_phi, sin_phi = vectors.cos_sin(2.0 * math.pi * u[:, 1])
    t1, t2 = r * cos_phi, r * sin_phi
    blend = 0.5 * (1.0 + v[:, 2])
    t2 = (1.0 - blend) * np.sqrt(np.maximum(1.0 - t1 * t1, 0.0)) + blend * t2
    # 4. Lifted onto the hemisphere, and unstretched.
    lift = np.sqrt(np.maximum(1.0 - t1 * t1 - t2 * t2, 0.0))
    H = T1 * t1[:, None] + T2 * t2[:, None] + v * lift[:, None]
    H = np.stack([alpha_x * H[:, 0], alpha_y * H[:, 1], np.maximum(H[:, 2], 0.0)], axis=1)
    return H / np.linalg.norm(H, axis=1)[:, None]


def is_anisotropic(params: np.ndarray) -> np.ndarray:
    """Where closures' rows (m, PARAMS) are anisotropic: a non-zero tangent and alpha_y != alpha: (m,) bool."""
    T = params[:, TANGENT:TANGENT + 3]
    return np.any(T != 0.0, axis=1) & (params[:, ALPHA_Y] != params[:, ALPHA])


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a.b (m,) of (m, 3) vectors, summed in C's order (dot3), so that the C twin gives the same bits."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def tangent_frame(N: np.ndarray, T: np.ndarray):
    """The frame (X, Y) (m, 3) of anisotropy: Y = normalize(N x T), X = Y x N (Cycles' make_orthonormals_tangent)."""
    Y = vectors.cross(N, T)
    Y /= np.maximum(np.sqrt(dot(Y, Y)), 1e-300)[:, None]
    return vectors.cross(Y, N), Y


def lambda_aniso(alpha_x: np.ndarray, alpha_y: np.ndarray, local: np.ndarray) -> np.ndarray:
    """Smith's Lambda (m,) of anisotropic GGX for directions local (m, 3) in the tangent frame (bsdf_aniso_lambda)."""
    z2 = np.maximum(local[:, 2] ** 2, 1e-300)
    return 0.5 * (np.sqrt(1.0 + ((alpha_x * local[:, 0]) ** 2 + (alpha_y * local[:, 1]) ** 2) / z2) - 1.0)


def D_aniso(alpha_x: np.ndarray, alpha_y: np.ndarray, local_H: np.ndarray) -> np.ndarray:
    """Anisotropic GGX D (m,) of microfacet normals local_H (m, 3) in the tangent frame (per unit projected area)."""
    s = (local_H[:, 0] / alpha_x) ** 2 + (local_H[:, 1] / alpha_y) ** 2 + local_H[:, 2] ** 2
    return 1.0 / (math.pi * alpha_x * alpha_y * s * s)


def to_local(X: np.ndarray, Y: np.ndarray, N: np.ndarray, v: np.ndarray) -> np.ndarray:
    """v (m, 3) in the frame (X, Y, N): (m, 3)."""
    return np.stack([dot(X, v), dot(Y, v), dot(N, v)], axis=1)


class Microfacet(BSDF):
    """GGX reflection with Smith masking-shadowing, a Fresnel model and an energy scale (module docstring).

    f cos = energy_scale F D / (4 N.wo (1 + Lambda(wo) + Lambda(wi))),  pdf = D / (4 N.wo (1 + Lambda(wo))).
    Anisotropic (alpha_x = alpha, alpha_y, tangent) where is_anisotropic. Below ROUGHNESS_SQ_THRESHOLD (of
    alpha_x alpha_y) the lobe is a mirror: closure setups give a Mirror closure instead.
    """

    name: ClassVar[str] = "GLOSSY"
    flags: ClassVar[F] = F.REFLECTION | F.GLOSSY | F.GLOSSY_TYPE
    params: ClassVar[tuple] = ("alpha", "fresnel", "ior", "f0_r", "f0_g", "f0_b", "f90_r", "f90_g", "f90_b",
                               "energy_scale", "alpha_y", "tangent_x", "tangent_y", "tangent_z")

    @staticmethod
    def albedo(params, N, wo):
        """The colour passes' albedo: its Fresnel at N.wo (no transmission)."""
        R = fresnel(params, np.clip(np.einsum("ij,ij->i", N, wo), 0.0, 1.0))
        return R, np.zeros_like(R)

    @staticmethod
    def eval(params, N, wo, wi):
        alpha2 = params[:, ALPHA] ** 2
        aniso = is_anisotropic(params)
        if aniso.any():
            alpha2 = np.where(aniso, params[:, ALPHA] * params[:, ALPHA_Y], alpha2)
        cos_NI, cos_NO = np.einsum("ij,ij->i", N, wo), np.einsum("ij,ij->i", N, wi)
        valid = (cos_NI > 0.0) & (cos_NO > 0.0) & (alpha2 > ROUGHNESS_SQ_THRESHOLD)
        H = wo + wi
        H /= np.maximum(np.linalg.norm(H, axis=1), 1e-300)[:, None]
        cos_NH, cos_HI = np.einsum("ij,ij->i", N, H), np.einsum("ij,ij->i", H, wo)
        safe_NI = np.where(valid, cos_NI, 1.0)
        common = D_ggx(alpha2, cos_NH) / safe_NI * 0.25
        lambda_I, lambda_O = lambda_ggx(alpha2, safe_NI), lambda_ggx(alpha2, np.where(valid, cos_NO, 1.0))
        if aniso.any():
            ax, ay = params[:, ALPHA], np.where(aniso, params[:, ALPHA_Y], 1.0)
            ax = np.where(aniso, ax, 1.0)
            X, Y = tangent_frame(N, np.where(aniso[:, None], params[:, TANGENT:TANGENT + 3], [1.0, 0.0, 0.0]))
            local_I = to_local(X, Y, N, wo)
            local_O = to_local(X, Y, N, wi)
            local_I[:, 2], local_O[:, 2] = safe_NI, np.where(valid, cos_NO, 1.0)
            common = np.where(aniso, D_aniso(ax, ay, to_local(X, Y, N, H)) / safe_NI * 0.25, common)
            lambda_I = np.where(aniso, lambda_aniso(ax, ay, local_I), lambda_I)
            lambda_O = np.where(aniso, lambda_aniso(ax, ay, local_O), lambda_O)
        pdf = np.where(valid, common / (1.0 + lambda_I), 0.0)
        scale = np.where(valid, common / (1.0 + lambda_I + lambda_O) * params[:, ENERGY], 0.0)
        return fresnel(params, cos_HI) * scale[:, None], pdf

    @staticmethod
    def sample(params, N, wo, u):
        alpha = params[:, ALPHA]
        alpha_y = alpha
        t, b = vectors.orthonormal_frame(N)
        aniso = is_anisotropic(params)
        if aniso.any():
            X, Y = tangent_frame(N, np.where(aniso[:, None], params[:, TANGENT:TANGENT + 3], [1.0, 0.0, 0.0]))
            t, b = np.where(aniso[:, None], X, t), np.where(aniso[:, None], Y, b)
            alpha_y = np.where(aniso, params[:, ALPHA_Y], alpha)
        local = np.stack([np.einsum("ij,ij->i", t, wo), np.einsum("ij,ij->i", b, wo), np.einsum("ij,ij->i", N, wo)],
                         axis=1)
        h = sample_visible_normal(np.where(local[:, 2:] > 0.0, local, [0.0, 0.0, 1.0]), alpha, u, alpha_y)
        H = t * h[:, 0:1] + b * h[:, 1:2] + N * h[:, 2:3]
        wi = 2.0 * np.einsum("ij,ij->i", H, wo)[:, None] * H - wo
        f_cos, pdf = Microfacet.eval(params, N, wo, wi)
        weight = np.divide(f_cos, pdf[:, None], out=np.zeros_like(f_cos), where=pdf[:, None] > 0.0)
        return BsdfSample(wi, weight, pdf)
