"""Hair: Cycles' Principled Hair BSDF (Chiang's model) and its older Hair BSDF (Reflection and Transmission).

A fibre is a thin dielectric cylinder along the curve's tangent X. Light from the viewer wo meets it at an offset h
across its width (-1 .. 1 from one grazing edge to the other; 0 through the centre) and leaves after p internal
paths: R (reflected at the cuticle), TT (through the fibre), TRT (through, reflected inside, out) and the residual
TRRT+ (Chiang et al. 2016, "A practical and controllable hair and fur model for production path tracing"; Cycles'
`closure/bsdf_principled_hair_chiang.h`). In the frame X (along the fibre), Y = X x wo, Z = X x Y, a direction is
its longitudinal angle theta (sin theta = its X component) and its azimuth phi about X; each path p scatters

    f cos = sum_p A_p(theta_o, h) M_p(theta_i, theta_o) N_p(phi)

A_p: the light that takes path p: Fresnel's f at cos theta_o cos gamma_o (sin gamma_o = h) and the fibre's
transmittance T = exp(-sigma 2 cos gamma_t / cos theta_t) along each chord (sigma the absorption per unit of the
fibre's radius): A_R = f, A_TT = (1 - f)^2 T, A_TRT = A_TT T f, A_TRRT+ = A_TRT T f / (1 - T f).
M_p: the longitudinal spread (d'Eon's von Mises-Fisher lobe of variance v; TT's v / 4, TRT's and the rest's 4 v,
R's the Coat-reduced m0), about theta_o tilted by the cuticle's scales (alpha, the node's Offset, 2 alpha for R,
-alpha for TT, -4 alpha for TRT). N_p: the azimuthal spread, a logistic of scale s (Radial Roughness) trimmed to
[-pi, pi] around the deflection 2 p gamma_t - 2 gamma_o + p pi; uniform 1 / (2 pi) for the residual.

Cycles returns this sum as its eval (f cos), and samples p by the A_p's luminances, then theta_i (d'Eon's exact
sampling of M_p) and phi (the trimmed logistic), so its pdf is the same sum with each A_p's luminance share in
place of A_p. With no absorption the four A_p add to 1 and the lobes are normalised: the fibre loses no light
(tests/test_hair.py's white furnace).

The Hair BSDF (Cycles' `closure/bsdf_hair.h`, from OSL) is two closures: Reflection, a lobe about the mirror of
the view across the fibre (longitudinal: a Cauchy lobe of RoughnessU about the half angle shifted by Offset;
azimuthal: a cosine lobe of RoughnessV), and Transmission, through the fibre (its azimuth a Cauchy lobe about pi).
Their eval is their pdf (a sample's weight is 1, times the colour); Reflection takes only light in front of the
surface's normal, Transmission only light behind it. Their samplers do not look at that normal, so their samples
keep their own weight (OWN_WEIGHT), as Cycles keeps a sampled closure's.

Where the h of a hit comes from: Cycles' thick curves give it from the true round normal Ng of the hit, the tangent
X and the view, h = (Ng x X) . Z; Primer's tubes (core/geometry/curves.py) carry smooth normals pointing out of the
spline, which are Ng's at the ring vertices, and their spline tangent per vertex ("curve_tangent"), which the node
reads through its `tangent` input (curve_links). The C twin is core/materials/hair.c; the nodes' setups are
nodes.c's principled_hair_node and hair_node.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from ..native import schema
from .base import BSDF, BsdfSample, PARAMS
from .base import BSDFFlags as F
from .converters.colorspace import RGB_TO_Y
from .nodes import Node, per_hit_rows

# Chiang's parameter row: absorption sigma (3), longitudinal variance v, azimuthal scale s, R's variance m0, the
# cuticle tilt alpha (radians, Cycles' sign: minus the node's Offset), the index eta, the offset h, the tangent X (3).
SIGMA, V, S, M0, ALPHA, ETA, H, TANGENT = 0, 3, 4, 5, 6, 7, 8, 9
# The Hair BSDF's row: RoughnessU, RoughnessV (clipped to 0.001 .. 1), the offset (minus the node's), the tangent (3).
ROUGHNESS_U, ROUGHNESS_V, OFFSET, HAIR_TANGENT = 0, 1, 2, 3
# The luminance the sampler weighs the paths by (Cycles' spectrum_to_gray, rgb_to_y of Blender's colour space).
GRAY = tuple(schema.constant(f"HAIR_GRAY_{c}", float(v), "the luminance of a hair path's colour (hair.GRAY)")
             for c, v in zip("RGB", RGB_TO_Y))
# The node's colour parametrisations (Cycles' NODE_PRINCIPLED_HAIR_*), its `parametrization` input.
PARAMETRIZATIONS = schema.constants("HAIR_PARAMETRIZATION", ("direct_coloring", "melanin", "absorption"),
                                    "a Principled Hair BSDF's colour parametrisation (hair.PARAMETRIZATIONS)")
EUMELANIN = (0.506, 0.841, 1.653)       # absorption per unit of eumelanin, and of pheomelanin (Cycles)
PHEOMELANIN = (0.343, 0.733, 1.924)
SQRT_PI_8 = schema.constant("HAIR_SQRT_PI_8", math.sqrt(math.pi / 8.0), "sqrt(pi / 8), the azimuthal scale's factor")
LN_2PI = math.log(2.0 * math.pi)


def safe_normalize(v: np.ndarray) -> np.ndarray:
    """v (n, 3) over its length; 0 where the length is 0."""
    length = np.sqrt(vectors.dot(v, v))
    return np.divide(v, length[:, None], out=np.zeros_like(v), where=length[:, None] > 0.0)


def cos_from_sin(s: np.ndarray) -> np.ndarray:
    """sqrt(max(1 - s^2, 0))."""
    return np.sqrt(np.maximum(1.0 - s * s, 0.0))


def safe_asin(s: np.ndarray) -> np.ndarray:
    """asin of s clipped to -1..1."""
    return np.arcsin(np.clip(s, -1.0, 1.0))


def fresnel_cos(cos_i: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Cycles' fresnel_dielectric_cos: the reflectance of relative index eta at |cos_i| (1 under total reflection)."""
    c = np.abs(cos_i)
    g = eta * eta - 1.0 + c * c
    inside = g > 0.0
    g = np.sqrt(np.where(inside, g, 1.0))
    A = (g - c) / (g + c)
    B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return np.where(inside, 0.5 * A * A * (1.0 + B * B), 1.0)


def bessel_I0(x: np.ndarray) -> np.ndarray:
    """The modified Bessel function I0 (n,) by its series, stopped where a term no longer changes the sum (Cycles)."""
    x = x * x
    val = 1.0 + 0.25 * x
    power, factorial, four = x * x, 1.0, 16.0
    done = np.zeros(x.shape, bool)
    for i in range(2, 10):
        factorial *= i * i
        new = val + power / (four * factorial)
        done |= new == val
        val = np.where(done, val, new)
        power = power * x
        four *= 4.0
    return val


def log_bessel_I0(x: np.ndarray) -> np.ndarray:
    """log I0(x) (n,): its asymptote above 12, else the log of the series."""
    big = x > 12.0
    safe = np.where(big, x, 1.0)
    asymptote = safe + 0.5 * (1.0 / (8.0 * safe) - LN_2PI - np.log(safe))
    return np.where(big, asymptote, np.log(bessel_I0(np.where(big, 0.0, x))))


def logistic(x: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The logistic density of scale s at x."""
    v = np.exp(-np.abs(x) / s)
    return v / (s * (1.0 + v) ** 2)


def logistic_cdf(x: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The logistic distribution function of scale s at x (0 where exp would overflow in float32, as Cycles)."""
    arg = -x / s
    return np.where(arg > 88.0, 0.0, 1.0 / (1.0 + np.exp(np.minimum(arg, 88.0))))


def trimmed_logistic(x: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The logistic of scale s trimmed to [-pi, pi] (renormalised)."""
    scale = 1.0 - 2.0 * logistic_cdf(np.full_like(s, -math.pi), s)
    val = logistic(x, s)
    return np.divide(val, scale, out=np.zeros_like(val), where=scale != 0.0)


def sample_trimmed_logistic(u: np.ndarray, s: np.ndarray) -> np.ndarray:
    """An angle in [-pi, pi] drawn from trimmed_logistic by inverting its distribution at u (n,)."""
    low = logistic_cdf(np.full_like(s, -math.pi), s)
    x = -s * np.log(1.0 / (u * (1.0 - 2.0 * low) + low) - 1.0)
    return np.clip(x, -math.pi, math.pi)


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """a (n,) moved into [-pi, pi] by whole turns."""
    return (a + math.pi) - 2.0 * math.pi * np.floor((a + math.pi) / (2.0 * math.pi)) - math.pi


def delta_phi(p: int, gamma_o: np.ndarray, gamma_t: np.ndarray) -> np.ndarray:
    """How far path p turns the azimuth: 2 p gamma_t - 2 gamma_o + p pi."""
    return 2.0 * p * gamma_t - 2.0 * gamma_o + p * math.pi


def longitudinal(sin_i, cos_i, sin_o, cos_o, v) -> np.ndarray:
    """M_p (n,): d'Eon's longitudinal lobe of variance v (n,); in logs where v <= 0.1, as Cycles."""
    inv_v = 1.0 / v
    cos_arg = cos_i * cos_o * inv_v
    sin_arg = sin_i * sin_o * inv_v
    small = v <= 0.1
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        logs = np.exp(log_bessel_I0(cos_arg) - sin_arg - inv_v + 0.6931 + np.log(0.5 * inv_v))
        direct = np.exp(-sin_arg) * bessel_I0(np.where(small, 0.0, cos_arg)) / (np.sinh(np.where(small, 1.0, inv_v))
                                                                                * 2.0 * v)
    return np.where(small, logs, direct)


def tilted_angles(sin_o: np.ndarray, cos_o: np.ndarray, alpha: np.ndarray) -> list:
    """(sin, cos) of theta_o tilted for R (by 2 alpha), TT (-alpha) and TRT (-4 alpha): six (n,) arrays."""
    s1 = np.sin(alpha)
    c1 = cos_from_sin(s1)
    s2, c2 = 2.0 * s1 * c1, c1 * c1 - s1 * s1
    s4, c4 = 2.0 * s2 * c2, c2 * c2 - s2 * s2
    return [sin_o * c2 - cos_o * s2, np.abs(cos_o * c2 + sin_o * s2),
            sin_o * c1 + cos_o * s1, np.abs(cos_o * c1 - sin_o * s1),
            sin_o * c4 + cos_o * s4, np.abs(cos_o * c4 - sin_o * s4)]


def gray(c: np.ndarray) -> np.ndarray:
    """The luminance (n,) of colours c (n, 3)."""
    return (GRAY[0] * c[:, 0] + GRAY[1] * c[:, 1]) + GRAY[2] * c[:, 2]


def attenuation(f: np.ndarray, T: np.ndarray) -> tuple:
    """A_p (4, n, 3) of the paths R, TT, TRT, TRRT+ from Fresnel's f (n,) and the transmittance T (n, 3); and their
    luminance shares (4, n), which add to 1 (0 where the paths carry nothing)."""
    R = np.repeat(f[:, None], 3, axis=1)
    TT = (1.0 - f)[:, None] ** 2 * T
    TRT = TT * T * f[:, None]
    Tf = T * f[:, None]
    rest = TRT * np.divide(Tf, 1.0 - Tf, out=np.zeros_like(Tf), where=(1.0 - Tf) != 0.0)
    A = np.stack([R, TT, TRT, rest])
    energy = np.stack([f, gray(TT), gray(TRT), gray(rest)])
    total = energy.sum(axis=0)
    energy = energy * np.divide(1.0, total, out=np.zeros_like(total), where=total != 0.0)
    return A, energy


class Fibre:
    """What Chiang's model needs of a view: the frame (X, Y, Z), theta_o, phi_o, gamma_o, gamma_t and the paths'
    A_p and shares, for n hits (params (n, PARAMS), wo (n, 3))."""

    def __init__(self, params: np.ndarray, wo: np.ndarray):
        self.p = params
        self.X = safe_normalize(params[:, TANGENT:TANGENT + 3])
        self.Y = safe_normalize(vectors.cross(self.X, wo))
        self.Z = safe_normalize(vectors.cross(self.X, self.Y))
        self.sin_o = vectors.dot(wo, self.X)
        self.cos_o = cos_from_sin(self.sin_o)
        self.phi_o = np.arctan2(vectors.dot(wo, self.Z), vectors.dot(wo, self.Y))
        eta = params[:, ETA]
        cos_t = np.maximum(cos_from_sin(self.sin_o / eta), 1e-30)
        sin_gamma_o = params[:, H]
        cos_gamma_o = cos_from_sin(sin_gamma_o)
        self.gamma_o = safe_asin(sin_gamma_o)
        sin_gamma_t = sin_gamma_o * self.cos_o / np.sqrt(np.maximum(eta * eta - self.sin_o * self.sin_o, 1e-30))
        self.gamma_t = safe_asin(sin_gamma_t)
        T = np.exp(-params[:, SIGMA:SIGMA + 3] * (2.0 * cos_from_sin(sin_gamma_t) / cos_t)[:, None])
        self.A, self.energy = attenuation(fresnel_cos(self.cos_o * cos_gamma_o, eta), T)
        self.angles = tilted_angles(self.sin_o, self.cos_o, params[:, ALPHA])

    def variance(self, p: int) -> np.ndarray:
        """The longitudinal variance of path p (n,): m0 for R, v / 4 for TT, 4 v beyond."""
        v = self.p[:, V]
        return self.p[:, M0] if p == 0 else (0.25 * v if p == 1 else 4.0 * v)

    def scatter(self, sin_i: np.ndarray, cos_i: np.ndarray, phi: np.ndarray) -> tuple:
        """f cos (n, 3) and pdf (n,) towards (theta_i, phi = phi_i - phi_o): the four paths' sum."""
        s = self.p[:, S]
        f_cos, pdf = np.zeros((len(phi), 3)), np.zeros(len(phi))
        for p in range(3):
            Mp = longitudinal(sin_i, cos_i, self.angles[2 * p], self.angles[2 * p + 1], self.variance(p))
            Np = trimmed_logistic(wrap_angle(phi - delta_phi(p, self.gamma_o, self.gamma_t)), s)
            f_cos += self.A[p] * (Mp * Np)[:, None]
            pdf += self.energy[p] * Mp * Np
        Mp = longitudinal(sin_i, cos_i, self.sin_o, self.cos_o, 4.0 * self.p[:, V])
        Np = 1.0 / (2.0 * math.pi)
        f_cos += self.A[3] * (Mp * Np)[:, None]
        pdf += self.energy[3] * Mp * Np
        return f_cos, pdf


class ChiangHair(BSDF):
    """The Principled Hair BSDF's Chiang model (module docstring). Its directions are glossy, reflected or through
    the fibre; Cycles counts it a glossy closure (CLOSURE_BSDF_HAIR_CHIANG_ID)."""

    name: ClassVar[str] = "HAIR_CHIANG"
    flags: ClassVar[F] = F.REFLECTION | F.TRANSMISSION | F.GLOSSY | F.GLOSSY_TYPE | F.ROUGHENS | F.ANY_FACE
    # Filter Glossy caps the variances v, s and m0 (not the tilt alpha) at its roughness, as bsdf_hair_chiang_blur.
    blurred: ClassVar[tuple] = ("v", "s", "m0")
    params: ClassVar[tuple] = ("sigma_r", "sigma_g", "sigma_b", "v", "s", "m0", "alpha", "eta", "h",
                               "tangent_x", "tangent_y", "tangent_z")

    @classmethod
    def c_name(cls) -> str:
        """Its C functions' prefix in hair.c."""
        return "chiang_hair"

    @staticmethod
    def albedo(params, N, wo):
        """The colour passes' albedo, Cycles' estimate (bsdf_hair_chiang_albedo): exp(-sqrt(sigma) scale(v)) plus
        Fresnel's f at cos theta_o cos gamma_o, all as reflection (scale: Chiang's polynomial, read at the closure's
        longitudinal variance as Cycles does)."""
        X = safe_normalize(params[:, TANGENT:TANGENT + 3])
        cos_o = cos_from_sin(vectors.dot(wo, X))
        f = fresnel_cos(cos_o * cos_from_sin(params[:, H]), params[:, ETA])
        x = params[:, V]
        scale = (((((0.245 * x) + 5.574) * x - 10.73) * x + 2.532) * x - 0.215) * x + 5.969
        R = np.exp(-np.sqrt(np.maximum(params[:, SIGMA:SIGMA + 3], 0.0)) * scale[:, None]) + f[:, None]
        return R, np.zeros_like(R)

    @staticmethod
    def eval(params, N, wo, wi):
        fibre = Fibre(params, wo)
        sin_i = vectors.dot(wi, fibre.X)
        phi_i = np.arctan2(vectors.dot(wi, fibre.Z), vectors.dot(wi, fibre.Y))
        return fibre.scatter(sin_i, cos_from_sin(sin_i), phi_i - fibre.phi_o)

    @staticmethod
    def sample(params, N, wo, u):
        fibre = Fibre(params, wo)
        m = len(wo)
        # 1. A path by the luminance shares (the third number, rescaled within the chosen share).
        z = np.array(u[:, 2] if u.shape[1] > 2 else np.full(m, 0.5), np.float64)
        path = np.full(m, 3)
        chosen = np.zeros(m, bool)
        for p in range(3):
            here = ~chosen & (z < fibre.energy[p])
            path[here] = p
            chosen |= here
            z = np.where(chosen, z, z - fibre.energy[p])
        share = np.take_along_axis(fibre.energy, path[None, :], axis=0)[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = z / share
        # 2. theta_i from the path's longitudinal lobe (about theta_o tilted, untilted for the residual).
        v = np.select([path == 0, path == 1], [fibre.p[:, M0], 0.25 * fibre.p[:, V]], 4.0 * fibre.p[:, V])
        sin_t = np.select([path == 0, path == 1, path == 2], fibre.angles[0::2], fibre.sin_o)
        cos_t = np.select([path == 0, path == 1, path == 2], fibre.angles[1::2], fibre.cos_o)
        z = np.maximum(z, 1e-5)
        with np.errstate(over="ignore", invalid="ignore"):
            fac = 1.0 + v * np.log(z + (1.0 - z) * np.exp(-2.0 / v))
        sin_i = -fac * sin_t + cos_from_sin(fac) * np.cos(2.0 * math.pi * u[:, 1]) * cos_t
        cos_i = cos_from_sin(sin_i)
        # 3. phi about the path's deflection (uniform for the residual).
        deflection = np.select([path == 0, path == 1, path == 2],
                               [delta_phi(p, fibre.gamma_o, fibre.gamma_t) for p in range(3)], 0.0)
        phi = np.where(path < 3, deflection + sample_trimmed_logistic(u[:, 0], fibre.p[:, S]),
                       2.0 * math.pi * u[:, 0])
        phi_i = fibre.phi_o + phi
        f_cos, pdf = fibre.scatter(sin_i, cos_i, phi)
        wi = ((cos_i * np.cos(phi_i))[:, None] * fibre.Y + (cos_i * np.sin(phi_i))[:, None] * fibre.Z
              + sin_i[:, None] * fibre.X)
        sampled = (pdf > 0.0) & np.isfinite(pdf) & np.all(np.isfinite(f_cos), axis=1)
        weight = np.divide(f_cos, pdf[:, None], out=np.zeros_like(f_cos), where=sampled[:, None])
        return BsdfSample(wi, weight, np.where(sampled, pdf, 0.0))


def hair_frame(params: np.ndarray, wo: np.ndarray) -> tuple:
    """The Hair BSDF's view: the tangent T (n, 3), locy (wo across T, unit), theta_r (the view's angle from the
    normal plane of T) (n,)."""
    T = params[:, HAIR_TANGENT:HAIR_TANGENT + 3]
    Iz = vectors.dot(T, wo)
    locy = safe_normalize(wo - T * Iz[:, None])
    return T, locy, math.pi / 2.0 - np.arccos(np.clip(Iz, -1.0, 1.0))


def theta_lobe(params: np.ndarray, theta_r: np.ndarray) -> tuple:
    """The Cauchy lobe's ends a, b (n,) of the half angle shifted by the offset, in units of RoughnessU."""
    r1, offset = params[:, ROUGHNESS_U], params[:, OFFSET]
    a = np.arctan(((math.pi / 2.0 + theta_r) * 0.5 - offset) / r1)
    b = np.arctan(((-math.pi / 2.0 + theta_r) * 0.5 - offset) / r1)
    return a, b


def sample_theta(params: np.ndarray, theta_r: np.ndarray, u0: np.ndarray) -> tuple:
    """theta_i (n,) drawn from the Cauchy lobe by u0 (n,), with the lobe's ends a, b (theta_lobe) for its pdf."""
    a, b = theta_lobe(params, theta_r)
    t = params[:, ROUGHNESS_U] * np.tan(u0 * (a - b) + b)
    return 2.0 * (t + params[:, OFFSET]) - theta_r, a, b


def theta_pdf(params, a, b, theta_i, theta_r) -> np.ndarray:
    """The longitudinal pdf (n,) of theta_i (per solid angle, its cosine divided out)."""
    r1 = params[:, ROUGHNESS_U]
    t = (theta_i + theta_r) * 0.5 - params[:, OFFSET]
    return r1 / (2.0 * (t * t + r1 * r1) * (a - b) * np.cos(theta_i))


def light_angles(params, wi, locy) -> tuple:
    """The light's theta_i (n,) from the normal plane of T and the cosine (n,) of its azimuth from locy."""
    T = params[:, HAIR_TANGENT:HAIR_TANGENT + 3]
    z = vectors.dot(T, wi)
    y = safe_normalize(wi - T * z[:, None])
    return math.pi / 2.0 - np.arccos(np.clip(z, -1.0, 1.0)), vectors.dot(y, locy)


def hair_direction(T, locy, theta_i, phi) -> np.ndarray:
    """The direction (n, 3) of longitudinal angle theta_i and azimuth phi from locy about T."""
    locx = vectors.cross(locy, T)
    c = np.cos(theta_i)
    return ((np.cos(phi) * c)[:, None] * locy - (np.sin(phi) * c)[:, None] * locx + np.sin(theta_i)[:, None] * T)


class HairReflection(BSDF):
    """The Hair BSDF's Reflection component (module docstring): eval = pdf, light in front of N only."""

    name: ClassVar[str] = "HAIR_REFLECTION"
    flags: ClassVar[F] = F.REFLECTION | F.GLOSSY | F.GLOSSY_TYPE | F.OWN_WEIGHT | F.ANY_FACE
    params: ClassVar[tuple] = ("roughness_u", "roughness_v", "offset", "tangent_x", "tangent_y", "tangent_z")

    @classmethod
    def c_name(cls) -> str:
        """Its C functions' prefix in hair.c."""
        return "hair_reflection"

    @staticmethod
    def eval(params, N, wo, wi):
        T, locy, theta_r = hair_frame(params, wo)
        theta_i, cos_phi = light_angles(params, wi, locy)
        ok = (vectors.dot(N, wi) >= 0.0) & (math.pi / 2.0 - np.abs(theta_i) >= 0.001) & (cos_phi >= 0.0)
        r2 = params[:, ROUGHNESS_V]
        phi = np.arccos(np.clip(cos_phi, -1.0, 1.0)) / r2
        phi = np.where(np.abs(phi) < math.pi, phi, math.pi)
        a, b = theta_lobe(params, theta_r)
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = np.cos(phi * 0.5) * 0.25 / r2 * theta_pdf(params, a, b, theta_i, theta_r)
        pdf = np.where(ok, pdf, 0.0)
        return np.repeat(pdf[:, None], 3, axis=1), pdf

    @staticmethod
    def sample(params, N, wo, u):
        T, locy, theta_r = hair_frame(params, wo)
        r2 = params[:, ROUGHNESS_V]
        theta_i, a, b = sample_theta(params, theta_r, u[:, 0])
        phi = 2.0 * safe_asin(1.0 - 2.0 * u[:, 1]) * r2
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = np.abs(np.cos(phi * 0.5) * 0.25 / r2 * theta_pdf(params, a, b, theta_i, theta_r))
        pdf = np.where((math.pi / 2.0 - np.abs(theta_i) < 0.001) | ~np.isfinite(pdf), 0.0, pdf)
        weight = np.repeat(np.where(pdf > 0.0, 1.0, 0.0)[:, None], 3, axis=1)
        return BsdfSample(hair_direction(T, locy, theta_i, phi), weight, pdf)


class HairTransmission(BSDF):
    """The Hair BSDF's Transmission component (module docstring): eval = pdf, light behind N only."""

    name: ClassVar[str] = "HAIR_TRANSMISSION"
    flags: ClassVar[F] = F.TRANSMISSION | F.GLOSSY | F.TRANSMISSION_TYPE | F.OWN_WEIGHT | F.ANY_FACE
    params: ClassVar[tuple] = HairReflection.params

    @classmethod
    def c_name(cls) -> str:
        """Its C functions' prefix in hair.c."""
        return "hair_transmission"

    @staticmethod
    def albedo(params, N, wo):
        """The colour passes' albedo: all of its weight, transmitted (Cycles' weight, a transmission closure's)."""
        return np.zeros((len(wo), 3)), np.ones((len(wo), 3))

    @staticmethod
    def eval(params, N, wo, wi):
        T, locy, theta_r = hair_frame(params, wo)
        theta_i, cos_phi = light_angles(params, wi, locy)
        ok = (vectors.dot(N, wi) < 0.0) & (math.pi / 2.0 - np.abs(theta_i) >= 0.001)
        r2 = params[:, ROUGHNESS_V]
        a, b = theta_lobe(params, theta_r)
        c = 2.0 * np.arctan(math.pi / 2.0 / r2)
        q = math.pi - np.arccos(np.clip(cos_phi, -1.0, 1.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = r2 / (c * (q * q + r2 * r2)) * theta_pdf(params, a, b, theta_i, theta_r)
        pdf = np.where(ok, pdf, 0.0)
        return np.repeat(pdf[:, None], 3, axis=1), pdf

    @staticmethod
    def sample(params, N, wo, u):
        T, locy, theta_r = hair_frame(params, wo)
        r2 = params[:, ROUGHNESS_V]
        theta_i, a, b = sample_theta(params, theta_r, u[:, 0])
        c = 2.0 * np.arctan(math.pi / 2.0 / r2)
        q = r2 * np.tan(c * (u[:, 1] - 0.5))
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = np.abs(r2 / (c * (q * q + r2 * r2)) * theta_pdf(params, a, b, theta_i, theta_r))
        pdf = np.where((math.pi / 2.0 - np.abs(theta_i) < 0.001) | ~np.isfinite(pdf), 0.0, pdf)
        weight = np.repeat(np.where(pdf > 0.0, 1.0, 0.0)[:, None], 3, axis=1)
        return BsdfSample(hair_direction(T, locy, theta_i, q + math.pi), weight, pdf)


def variance_of(r: np.ndarray) -> np.ndarray:
    """Chiang's longitudinal variance from a roughness (n,) in 0.001..1: (0.726 r + 0.812 r^2 + 3.7 r^20)^2."""
    return (0.726 * r + 0.812 * r * r + 3.7 * r ** 20) ** 2


def sigma_from_reflectance(color: np.ndarray, radial: np.ndarray) -> np.ndarray:
    """The absorption (n, 3) that gives hair of azimuthal roughness `radial` (n,) about the colour (n, 3) (Chiang's
    fit, Cycles' bsdf_principled_hair_sigma_from_reflectance); a black channel absorbs (nearly) everything."""
    x = radial
    scale = (((((0.245 * x) + 5.574) * x - 10.73) * x + 2.532) * x - 0.215) * x + 5.969
    sigma = np.log(np.maximum(color, 1e-30)) / scale[:, None]
    return sigma * sigma


def hair_sigma(p: np.ndarray, radial: np.ndarray) -> np.ndarray:
    """The absorption sigma (n, 3) of the Principled Hair BSDF's inputs p (n, NODE_PARAMS) by its parametrisation
    (Direct Coloring, Melanin with Redness, Tint and Random Color, or Absorption Coefficient), the colours' fit read at
    the azimuthal roughness `radial` (n,) (Chiang's Radial Roughness, Huang's Roughness), as Cycles' svm node."""
    random = p[:, 16]
    kind = p[:, 0]
    melanin = p[:, 4] * (1.0 + 2.0 * (random - 0.5) * np.clip(p[:, 15], 0.0, 1.0))
    melanin = -np.log(np.maximum(1.0 - melanin, 0.0001))
    eu, pheo = melanin * (1.0 - p[:, 5]), melanin * p[:, 5]
    pigment = (eu[:, None] * np.array(EUMELANIN) + pheo[:, None] * np.array(PHEOMELANIN)
               + sigma_from_reflectance(p[:, 6:9], radial))
    return np.where((kind == PARAMETRIZATIONS["absorption"])[:, None], p[:, 17:20],
                    np.where((kind == PARAMETRIZATIONS["melanin"])[:, None], pigment,
                             sigma_from_reflectance(p[:, 1:4], radial)))


def chiang_params(p: np.ndarray, N: np.ndarray, wo: np.ndarray, surface=None) -> np.ndarray:
    """Chiang's closure rows (n, PARAMS) from the node's inputs p (n, NODE_PARAMS) at hits with normal N (the round
    normal, Cycles' Ng) and view wo (n, 3), as Cycles' svm closure node and bsdf_hair_chiang_setup compute them;
    surface: (n, 3) a triangle's dPdu turned towards the viewer's side (surface_tangent), zero on curves, or None:
    there X is dPdu and Ng the triangle's true normal, dPdu x dPdv (p[:, 26:29]) towards the viewer."""
    n = len(p)
    random = p[:, 16]
    factor = 1.0 + 2.0 * (random - 0.5) * p[:, 14]
    roughness, radial = p[:, 9] * factor, p[:, 10] * factor
    sigma = hair_sigma(p, radial)
    v = np.clip(roughness, 0.001, 1.0)
    s = np.clip(radial, 0.001, 1.0)
    m0 = np.clip((1.0 - np.clip(p[:, 11], 0.0, 1.0)) * v, 0.001, 1.0)
    X = safe_normalize(p[:, 20:23])
    if surface is not None:                 # (a triangle: Cycles' X is its dPdu, its h from the triangle's Ng)
        mesh = np.any(surface != 0.0, axis=1)
        X = np.where(mesh[:, None], safe_normalize(surface), X)
        Ng = safe_normalize(vectors.cross(p[:, 23:26], p[:, 26:29]))
        Ng = np.where((vectors.dot(Ng, wo) < 0.0)[:, None], -Ng, Ng)
        N = np.where((mesh & np.any(Ng != 0.0, axis=1))[:, None], Ng, N)
    no_tangent = ~np.any(X != 0.0, axis=1)
    if no_tangent.any():                    # (a degenerate triangle: a tangent across the normal, Primer's own)
        X = np.where(no_tangent[:, None], vectors.orthonormal_frame(N)[0], X)
    Y = safe_normalize(vectors.cross(X, wo))
    Z = safe_normalize(vectors.cross(X, Y))
    out = np.zeros((n, PARAMS))
    out[:, SIGMA:SIGMA + 3] = sigma
    out[:, V] = variance_of(v)
    out[:, S] = (0.265 * s + 1.194 * s * s + 5.372 * s ** 22) * SQRT_PI_8
    out[:, M0] = variance_of(m0)
    out[:, ALPHA] = -p[:, 13]
    out[:, ETA] = p[:, 12]
    out[:, H] = vectors.dot(vectors.cross(N, X), Z)
    out[:, TANGENT:TANGENT + 3] = X
    return out


# The Principled Hair BSDF's inputs, in their slots (Huang's model adds its own: huang.HUANG_INPUTS).
PRINCIPLED_HAIR_INPUTS = ("parametrization", "color", "melanin", "melanin_redness", "tint", "roughness",
                          "radial_roughness", "coat", "ior", "offset", "random_roughness", "random_color", "random",
                          "absorption", "tangent")
# Chiang's node adds the triangle's dPdu and dPdv (surface_tangent, surface_bitangent; zero on curves: mesh_links).
CHIANG_INPUTS = PRINCIPLED_HAIR_INPUTS + ("surface_tangent", "surface_bitangent")
PRINCIPLED_HAIR_DEFAULTS = (float(PARAMETRIZATIONS["direct_coloring"]), (0.017513, 0.005763, 0.002059), 0.8, 1.0,
                            (1.0, 1.0, 1.0), 0.3, 0.3, 0.0, 1.55, math.radians(2.0), 0.0, 0.0, 0.0,
                            (0.245531, 0.52, 1.365), (0.0, 0.0, 0.0))
CHIANG_DEFAULTS = PRINCIPLED_HAIR_DEFAULTS + ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


class PrincipledHairNode(Node):
    """Principled Hair BSDF, Chiang's model (Blender's ShaderNodeBsdfHairPrincipled): one ChiangHair closure of the
    node's weight (its colour parametrises the absorption instead, as Cycles: Direct Coloring, Melanin concentration
    with Melanin Redness, Tint and Random Color, or the Absorption Coefficient), Roughness and Radial Roughness scaled
    by 1 + 2 (Random - 1/2) Random Roughness, the R lobe's roughness cut by Coat, IOR, Offset (the cuticle tilt);
    its `tangent` is the curve's (curve_links), its `random` Curves Info's Random unless the socket is linked."""

    name = "PRINCIPLED_HAIR"
    lets_light_through = True           # (from inside its tube: through_own_fibre)
    inputs, defaults = CHIANG_INPUTS, CHIANG_DEFAULTS

    @staticmethod
    def setup(b, weight, p):
        """One ChiangHair closure per hit (chiang_params), its normal the hit's; on a triangle its frame from dPdu
        and its normal Cycles' bsdf->N, the frame's Y = X x wo (shadowed where it differs from the hit's:
        closures.bump_shadowing)."""
        p = per_hit_rows(p, len(weight))
        surface = surface_tangent(b, p[:, 23:26])
        rows = chiang_params(p, b.N, b.wo, surface)
        b.add(ChiangHair.kind, through_own_fibre(b, weight, surface), rows,
              N=fibre_normal(b.N, surface, safe_normalize(vectors.cross(rows[:, TANGENT:TANGENT + 3], b.wo))))


class HairNode(Node):
    """Hair BSDF (Blender's ShaderNodeBsdfHair): one HairReflection or HairTransmission closure (`transmission`, the
    node's Component) of the node's weight times its Color (an input: a ray passing its own tube from inside is not
    tinted by it), RoughnessU and RoughnessV clipped to 0.001..1, minus the
    Offset, and its Tangent: the linked one, else the curve's (curve_links); off curves (no tangent) Cycles takes
    the surface's dPdv and no offset: Primer a tangent across the normal of its own choosing."""

    name = "HAIR"
    lets_light_through = True
    inputs = ("offset", "roughness_u", "roughness_v", "tangent", "transmission", "color", "surface_tangent")
    defaults = (0.0, 0.2, 0.2, (0.0, 0.0, 0.0), 0.0, (0.8, 0.8, 0.8), (0.0, 0.0, 0.0))

    @staticmethod
    def setup(b, weight, p):
        """One closure of the component's class per hit."""
        n = len(weight)
        p = per_hit_rows(p, n)
        kind = HairTransmission.kind if p[0, 6] != 0.0 else HairReflection.kind
        T = safe_normalize(p[:, 3:6])
        none = ~np.any(T != 0.0, axis=1)
        surface = surface_tangent(b, p[:, 10:13])
        out = np.zeros((n, PARAMS))
        out[:, ROUGHNESS_U] = np.clip(p[:, 1], 0.001, 1.0)
        out[:, ROUGHNESS_V] = np.clip(p[:, 2], 0.001, 1.0)
        out[:, OFFSET] = np.where(none, 0.0, -p[:, 0])
        T = np.where(none[:, None], safe_normalize(surface), T)           # (a triangle's dPdv, no offset)
        none = ~np.any(T != 0.0, axis=1)
        if none.any():                      # (a degenerate triangle: a tangent across the normal, Primer's own)
            T = np.where(none[:, None], vectors.orthonormal_frame(b.N)[0], T)
        out[:, HAIR_TANGENT:HAIR_TANGENT + 3] = T
        b.add(kind, through_own_fibre(b, weight, surface) * np.maximum(p[:, 7:10], 0.0), out)


def fibre_normal(N: np.ndarray, surface: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """A principled hair closure's normal (n, 3): on a triangle (surface (n, 3) nonzero: surface_tangent) Cycles'
    bsdf->N, its fibre frame's axis across the tangent and the view (axis (n, 3) unit: Chiang's Y, Huang's X), the
    hit's N (n, 3) elsewhere and where that axis is degenerate (Cycles skips bump shadowing on curves)."""
    mesh = np.any(surface != 0.0, axis=1) & np.any(axis != 0.0, axis=1)
    return np.where(mesh[:, None], axis, N)


def surface_tangent(b, edge: np.ndarray) -> np.ndarray:
    """A triangle's edge vector (n, 3) in world space (Cycles' sd->dPdu or dPdv: mesh_links), negated where the ray
    met the triangle from behind (as Cycles turns dPdu, dPdv with the normal); zero on curves."""
    return np.where(b.backfacing[:, None], -edge, edge)


def through_own_fibre(b, weight: np.ndarray, surface=None) -> np.ndarray:
    """The hair closure's weight (n, 3): 0 where the ray met the tube from inside, whose light (the node's weight,
    its share of the surface) goes on straight through instead (b.transparency): a ray leaving a strand passes its
    own tube, as Cycles' rays leaving a curve pass its segment (the fibre is the BSDF's, not the tube's). surface:
    (n, 3) the triangle's edge (surface_tangent), nonzero on meshes, whose back faces scatter as their front."""
    inside = b.backfacing
    if surface is not None:
        inside = inside & ~np.any(surface != 0.0, axis=1)
    inside = inside[:, None]
    b.transparency += np.where(inside, weight, 0.0)
    return np.where(inside, 0.0, weight)


def curve_links() -> dict:
    """The graph links a hair node reads on curves: `tangent`, the tubes' spline tangent ("curve_tangent", per
    vertex) turned to world space, and `random`, Curves Info's Random (as Cycles reads ATTR_STD_CURVE_RANDOM)."""
    from .graph import GraphNode, Link
    tangent = Link(GraphNode("ATTRIBUTE", {"attribute": "curve_tangent"}, {}, "curve tangent"), "Vector")
    world = Link(GraphNode("VECTOR_TRANSFORM", {"type": "VECTOR", "from": "OBJECT", "to": "WORLD"},
                           {"Vector": tangent}, "curve tangent in world space"), "Vector")
    return {"tangent": world, "random": Link(GraphNode("CURVES_INFO", {}, {}, "curve random"), "Random")}


def mesh_links(edge: str = "triangle_dpdu") -> dict:
    """The graph links a hair node reads on meshes: `surface_tangent`, the triangle's dPdu ("triangle_dpdu", Chiang's
    and Huang's X) or dPdv ("triangle_dpdv", the Hair BSDF's tangent) in world space, and `surface_bitangent`, its
    dPdv (Chiang's true normal dPdu x dPdv); zero on curves' tubes."""
    from .graph import GraphNode, Link

    def world(name):
        tangent = Link(GraphNode("ATTRIBUTE", {"attribute": name}, {}, "triangle " + name[-4:]), "Vector")
        return Link(GraphNode("VECTOR_TRANSFORM", {"type": "VECTOR", "from": "OBJECT", "to": "WORLD"},
                              {"Vector": tangent}, "triangle edge in world space"), "Vector")
    return {"surface_tangent": world(edge), "surface_bitangent": world("triangle_dpdv")}
