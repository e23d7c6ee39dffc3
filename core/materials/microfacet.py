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


def lambda_beckmann_tan2(alpha2_tan2: np.ndarray) -> np.ndarray:
    """Smith's Lambda (m,) for Beckmann from alpha^2 tan^2 (m,) of the direction: Walter et al.'s rational fit, 0
    below 0.39 (a = 1 / (alpha tan) >= 1.6), as Cycles' bsdf_lambda_from_sqr_alpha_tan_n."""
    steep = alpha2_tan2 >= 0.39
    a = 1.0 / np.sqrt(np.where(steep, alpha2_tan2, 1.0))
    return np.where(steep, ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a), 0.0)


def lambda_beckmann(alpha2: np.ndarray, cosine: np.ndarray) -> np.ndarray:
    """Smith's Lambda for Beckmann: the masking of a direction at `cosine` to the normal."""
    tan2 = np.maximum(1.0 / np.maximum(cosine * cosine, 1e-300) - 1.0, 0.0)
    return lambda_beckmann_tan2(alpha2 * tan2)


def lambda_aniso_beckmann(alpha_x: np.ndarray, alpha_y: np.ndarray, local: np.ndarray) -> np.ndarray:
    """Smith's Lambda (m,) of anisotropic Beckmann for directions local (m, 3) in the tangent frame."""
    z2 = np.maximum(local[:, 2] ** 2, 1e-300)
    return lambda_beckmann_tan2(((alpha_x * local[:, 0]) ** 2 + (alpha_y * local[:, 1]) ** 2) / z2)


def D_beckmann(alpha2: np.ndarray, cos_NH: np.ndarray) -> np.ndarray:
    """The Beckmann distribution of microfacet normals at cos_NH: exp(-tan^2 / alpha^2) / (pi alpha^2 cos^4)."""
    c2 = np.minimum(cos_NH * cos_NH, 1.0)
    up = c2 > 0.0
    safe = np.where(up, c2, 1.0)
    with np.errstate(over="ignore"):
        return np.where(up, 1.0 / (np.exp((1.0 - safe) / (safe * alpha2)) * math.pi * alpha2 * (safe * safe)), 0.0)


def D_aniso_beckmann(alpha_x: np.ndarray, alpha_y: np.ndarray, local_H: np.ndarray) -> np.ndarray:
    """Anisotropic Beckmann D (m,) of microfacet normals local_H (m, 3) in the tangent frame."""
    c2 = local_H[:, 2] ** 2
    up = c2 > 0.0
    safe = np.where(up, c2, 1.0)
    slope2 = (local_H[:, 0] / alpha_x) ** 2 + (local_H[:, 1] / alpha_y) ** 2
    return np.where(up, np.exp(-slope2 / safe) / (math.pi * (alpha_x * alpha_y) * (safe * safe)), 0.0)


def erf(x: np.ndarray) -> np.ndarray:
    """The error function (n,) to 1.5e-7 (Abramowitz and Stegun 7.1.26), the same arithmetic as the C twin."""
    ax = np.abs(x)
    t = 1.0 / (1.0 + 0.3275911 * ax)
    poly = ((((1.061405429 * t - 1.453152027) * t + 1.421413741) * t - 0.284496736) * t + 0.254829592) * t
    return np.where(x < 0.0, -1.0, 1.0) * (1.0 - poly * np.exp(-ax * ax))


def erfinv(x: np.ndarray) -> np.ndarray:
    """The inverse error function (n,) for x in (-1, 1) (Giles 2010, "Approximating the erfinv function", its
    single-precision polynomials evaluated in double; erf(erfinv(x)) within 5e-8 of x). x is kept within 1e-15
    of +-1."""
    x = np.clip(x, -1.0 + 1e-15, 1.0 - 1e-15)
    w = -np.log((1.0 - x) * (1.0 + x))
    centre = w < 5.0
    wc = np.where(centre, w, 5.0) - 2.5
    p = np.full(len(x), 2.81022636e-08)
    for c in (3.43273939e-07, -3.5233877e-06, -4.39150654e-06, 0.00021858087, -0.00125372503, -0.00417768164,
              0.246640727, 1.50140941):
        p = c + p * wc
    wt = np.sqrt(np.where(centre, 5.0, w)) - 3.0
    q = np.full(len(x), -0.000200214257)
    for c in (0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773, -0.0076224613, 0.00943887047,
              1.00167406, 2.83297682):
        q = c + q * wt
    return np.where(centre, p, q) * x


BECKMANN_NEWTON_STEPS = 6       # the slope's root found by safeguarded Newton steps (Cycles takes 3 in float)


def sample_visible_normal_beckmann(local_wo: np.ndarray, alpha: np.ndarray, u: np.ndarray, alpha_y=None) -> np.ndarray:
    """A Beckmann microfacet normal (n, 3), in the frame where N = z, seen from local_wo (n, 3) (Heitz and d'Eon
    2014, with Jakob's root finding on erf, as Cycles' microfacet_beckmann_sample_vndf); alpha (n,) along x,
    alpha_y (n,) along y (default alpha)."""
    alpha_x = alpha
    alpha_y = alpha if alpha_y is None else alpha_y
    # 1. Stretch the view direction to unit roughness.
    v = np.stack([alpha_x * local_wo[:, 0], alpha_y * local_wo[:, 1], local_wo[:, 2]], axis=1)
    v /= np.linalg.norm(v, axis=1)[:, None]
    # 2. At normal incidence the slopes are a 2D Gaussian.
    top = v[:, 2] >= 0.99999
    r = np.sqrt(-np.log(np.maximum(u[:, 0], 1e-300)))
    cos_u, sin_u = vectors.cos_sin(2.0 * math.pi * u[:, 1])
    top_x, top_y = r * cos_u, r * sin_u
    # 3. Else the slope x along the view (its CDF is (1 + erf(x) + K exp(-x^2)) up to x = cot theta), solved for
    #    b = erf(x) by Newton steps kept inside the bracket, and the slope y across it, a Gaussian.
    cos_t = np.where(top, 0.5, v[:, 2])
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    tan_t = sin_t / cos_t
    cot_t = 1.0 / tan_t
    erf_a, exp_a2 = erf(cot_t), np.exp(-cot_t * cot_t)
    K = tan_t / math.sqrt(math.pi)
    y_approx = u[:, 0] * (1.0 + erf_a + K * (1.0 - erf_a * erf_a))
    y_exact = u[:, 0] * (1.0 + erf_a + K * exp_a2)
    b = (0.5 - np.sqrt(K * (K - y_approx + 1.0) + 0.25)) / K
    x = erfinv(b)
    low_b, low_f, high_b = np.full(len(b), -1.0), -y_exact, erf_a
    f = 1.0 + b + K * np.exp(-x * x) - y_exact
    for _ in range(BECKMANN_NEWTON_STEPS):
        same = (low_f < 0.0) == (f < 0.0)
        low_b, low_f, high_b = np.where(same, b, low_b), np.where(same, f, low_f), np.where(same, high_b, b)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = b - f / (1.0 - x * tan_t)
        b = np.where((newton >= low_b) & (newton <= high_b), newton, 0.5 * (low_b + high_b))
        x = erfinv(b)
        f = 1.0 + b + K * np.exp(-x * x) - y_exact
    slope_y = erfinv(2.0 * u[:, 1] - 1.0)
    # 4. Turned to the view's azimuth, unstretched, and made a normal.
    cos_phi, sin_phi = v[:, 0] / np.where(top, 1.0, sin_t), v[:, 1] / np.where(top, 1.0, sin_t)
    sx = np.where(top, top_x, cos_phi * x - sin_phi * slope_y)
    sy = np.where(top, top_y, sin_phi * x + cos_phi * slope_y)
    H = np.stack([-(sx * alpha_x), -(sy * alpha_y), np.ones(len(sx))], axis=1)
    return H / np.linalg.norm(H, axis=1)[:, None]


def to_local(X: np.ndarray, Y: np.ndarray, N: np.ndarray, v: np.ndarray) -> np.ndarray:
    """v (m, 3) in the frame (X, Y, N): (m, 3)."""
    return np.stack([dot(X, v), dot(Y, v), dot(N, v)], axis=1)


class Microfacet(BSDF):
    """GGX reflection with Smith masking-shadowing, a Fresnel model and an energy scale (module docstring).

    f cos = energy_scale F D / (4 N.wo (1 + Lambda(wo) + Lambda(wi))),  pdf = D / (4 N.wo (1 + Lambda(wo))).
    Anisotropic (alpha_x = alpha, alpha_y, tangent) where is_anisotropic. Below ROUGHNESS_SQ_THRESHOLD (of
    alpha_x alpha_y) the lobe is a mirror: closure setups give a Mirror closure instead. `beckmann`: the
    distribution, its Lambda and its visible normals are Beckmann's (core/materials/beckmann.py), not GGX's.
    """

    name: ClassVar[str] = "GLOSSY"
    flags: ClassVar[F] = F.REFLECTION | F.GLOSSY | F.GLOSSY_TYPE | F.ROUGHENS
    params: ClassVar[tuple] = ("alpha", "fresnel", "ior", "f0_r", "f0_g", "f0_b", "f90_r", "f90_g", "f90_b",
                               "energy_scale", "alpha_y", "tangent_x", "tangent_y", "tangent_z")
    specular_alpha: ClassVar[tuple] = ("alpha", "alpha_y")
    beckmann: ClassVar[bool] = False

    @classmethod
    def distribution(cls) -> tuple:
        """Its (D, D_aniso, Lambda, Lambda_aniso, visible-normal sampler): GGX's, or Beckmann's."""
        if cls.beckmann:
            return D_beckmann, D_aniso_beckmann, lambda_beckmann, lambda_aniso_beckmann, sample_visible_normal_beckmann
        return D_ggx, D_aniso, lambda_ggx, lambda_aniso, sample_visible_normal

    @staticmethod
    def singular(params: np.ndarray) -> np.ndarray:
        """Where rows (m, PARAMS) are too smooth to evaluate (alpha_x alpha_y at most ROUGHNESS_SQ_THRESHOLD): (m,)
        bool; a closure setup gives a mirror there."""
        alpha2 = params[:, ALPHA] ** 2
        aniso = is_anisotropic(params)
        if aniso.any():
            alpha2 = np.where(aniso, params[:, ALPHA] * params[:, ALPHA_Y], alpha2)
        return alpha2 <= ROUGHNESS_SQ_THRESHOLD

    @staticmethod
    def albedo(params, N, wo):
        """The colour passes' albedo: its Fresnel at N.wo (no transmission)."""
        R = fresnel(params, np.clip(np.einsum("ij,ij->i", N, wo), 0.0, 1.0))
        return R, np.zeros_like(R)

    @classmethod
    def eval(cls, params, N, wo, wi):
        D_iso, D_an, lambda_iso, lambda_an, _ = cls.distribution()
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
        safe_alpha2 = np.where(valid, alpha2, 1.0)
        common = D_iso(safe_alpha2, cos_NH) / safe_NI * 0.25
        lambda_I, lambda_O = lambda_iso(safe_alpha2, safe_NI), lambda_iso(safe_alpha2, np.where(valid, cos_NO, 1.0))
        if aniso.any():
            ax, ay = params[:, ALPHA], np.where(aniso, params[:, ALPHA_Y], 1.0)
            ax = np.where(aniso, ax, 1.0)
            X, Y = tangent_frame(N, np.where(aniso[:, None], params[:, TANGENT:TANGENT + 3], [1.0, 0.0, 0.0]))
            local_I = to_local(X, Y, N, wo)
            local_O = to_local(X, Y, N, wi)
            local_I[:, 2], local_O[:, 2] = safe_NI, np.where(valid, cos_NO, 1.0)
            common = np.where(aniso, D_an(ax, ay, to_local(X, Y, N, H)) / safe_NI * 0.25, common)
            lambda_I = np.where(aniso, lambda_an(ax, ay, local_I), lambda_I)
            lambda_O = np.where(aniso, lambda_an(ax, ay, local_O), lambda_O)
        pdf = np.where(valid, common / (1.0 + lambda_I), 0.0)
        scale = np.where(valid, common / (1.0 + lambda_I + lambda_O) * params[:, ENERGY], 0.0)
        return fresnel(params, cos_HI) * scale[:, None], pdf

    @classmethod
    def sample(cls, params, N, wo, u):
        visible_normal = cls.distribution()[4]
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
        h = visible_normal(np.where(local[:, 2:] > 0.0, local, [0.0, 0.0, 1.0]), alpha, u, alpha_y)
        H = t * h[:, 0:1] + b * h[:, 1:2] + N * h[:, 2:3]
        wi = 2.0 * np.einsum("ij,ij->i", H, wo)[:, None] * H - wo
        f_cos, pdf = cls.eval(params, N, wo, wi)
        weight = np.divide(f_cos, pdf[:, None], out=np.zeros_like(f_cos), where=pdf[:, None] > 0.0)
        return BsdfSample(wi, weight, pdf)
