"""Hair, Huang's model: the Principled Hair BSDF's microfacet fibre (Blender 4.0+, Cycles'
`closure/bsdf_principled_hair_huang.h`; Huang, Hullin and Hanika 2022, "A microfacet-based hair scattering model").

A fibre is a dielectric cylinder of elliptical cross-section (minor / major axis b, the node's Aspect Ratio folded to
<= 1) along the curve's tangent Y, its surface a GGX microfacet surface of roughness r whose mesonormals are tilted
along the fibre by the cuticle's angle (Offset). In the local frame (X the major axis, or for round fibres across
the view; Y the tangent; Z = X x Y) a point of the rim is its angle gamma (the point (sin gamma, b cos gamma)); a
ray of the view meets the rim at an offset h across its projected width. The light leaving towards a direction is
an integral over h across the visible part of the width, of the paths

    R    reflected at the rim: GGX's D G times Fresnel at the half vector, the glass albedo table's energy scale;
    TT   refracted in, absorbed along the chord (exp(-sigma length / cos theta)), refracted out;
    TRT  refracted in, reflected inside, refracted out;
    TRRT+ the rest, Chiang's residual (an untilted longitudinal lobe of variance 4 r, uniform in azimuth) weighted by
         a geometric series of the TRT path's mean attenuation.

Cycles integrates R by Simpson's rule in h (steps of 0.7 r) and TT, TRT by Simpson's rule in h whose integrand
draws the first (and second) microfacet normal at random (steps of 0.8 r): eval is itself a Monte Carlo estimate,
with random numbers of the shading point (Cycles' sd->lcg_state). Primer draws them from its own generator
seeded by a hash of the bits of the two directions (eval) or of the view and the sample's numbers (sample),
each quadrature step's numbers its own (a counter-based generator): the same numbers in Python and C. Its sampler traces one path through the fibre (an h, three visible
GGX normals, the residual's direction) and weighs the lobes by their energy; Cycles gives both eval and sample a
pdf of 1 (the sample's weight is its own, OWN_WEIGHT), so multiple importance sampling weighs light samples and
BSDF samples half and half, as Cycles does.

Far field and near field: the integral runs over the whole visible width (far field: a strand thinner than a
pixel), or, for camera rays on strands wider than a pixel (Cycles: radius > half a pixel's footprint), over the
width the pixel sees around the hit's own h (near field); the slot `pixel_coverage` says which (1: far field).
Setup (huang_params) reads the node as Cycles' svm does. The C twin is core/materials/huang.c; the node's setup is
nodes.c's huang_hair_node.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from . import ggx_tables
from .base import BSDF, BsdfSample, PARAMS
from .base import BSDFFlags as F
from .hair import (PRINCIPLED_HAIR_DEFAULTS, PRINCIPLED_HAIR_INPUTS, fresnel_cos, longitudinal, safe_normalize,
                   surface_tangent, through_own_fibre, hair_sigma, fibre_normal)
from .microfacet import D_ggx, lambda_ggx
from .nodes import Node, per_hit_rows

# The closure's row: absorption sigma (3), roughness r, the tilt (minus the node's Offset), the index eta, the
# minor axis b (<= 1), the offset h, the lobe scales R, TT, TRT, the frame X (3, the major axis), Y (3, the
# tangent) and the pixel's half width in units of the fibre's radius (18 numbers, a closure's C storage); Z = X x Y
# and the projected radius are worked out again where needed (frame_z, radius_of).
SIGMA, ROUGH, TILT, ETA, B, H, LOBE_R, LOBE_TT, LOBE_TRT, AXIS_X, AXIS_Y, COVERAGE = (
    0, 3, 4, 5, 6, 7, 8, 9, 10, 11, 14, 17)
HASH_MUL = 0x9E3779B97F4A7C15


def seed_of(*columns) -> np.ndarray:
    """A uint64 seed (n,) from the bits of float64 columns (n,): a splitmix-like hash."""
    h = np.zeros(len(columns[0]), np.uint64)
    for c in columns:
        h = h ^ np.ascontiguousarray(c, np.float64).view(np.uint64)
        h = h * np.uint64(HASH_MUL)
        h = h ^ (h >> np.uint64(29))
    return h


def number(seed: np.ndarray, step, j: int) -> np.ndarray:
    """The j-th random number in [0, 1) (n,) of quadrature step `step` (n,) int under `seed` (n,) uint64: a
    counter-based generator (splitmix64's finaliser of seed + the counter), so each step's numbers are its own
    whatever the other steps drew (Cycles draws them in turn from one LCG; the distribution is the same)."""
    with np.errstate(over="ignore"):
        z = seed + (np.asarray(step, np.uint64) * np.uint64(8) + np.uint64(j) + np.uint64(1)) * np.uint64(HASH_MUL)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)


def vdot(a, b):
    """Row-wise dot product (n,) of (n, 3) arrays."""
    return (a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]) + a[:, 2] * b[:, 2]


def cos_theta(w):
    """cos theta of local directions (n, 3): their length across the tangent (y)."""
    return np.sqrt(np.maximum(w[:, 0] * w[:, 0] + w[:, 2] * w[:, 2], 0.0))


def dir_phi(w):
    """The azimuth (n,) of local directions about the tangent, from z towards x."""
    return np.arctan2(w[:, 0], w[:, 2])


def to_phi(gamma, b, circ):
    """The azimuth of the rim's normal at rim angle gamma (n,) of an ellipse of minor axis b."""
    return np.where(circ, gamma, np.arctan2(b * np.sin(gamma), np.cos(gamma)))


def h_to_gamma(h, b, wi, circ):
    """The rim angle (n,) where the view wi (local) meets the fibre at offset h (over the projected radius)."""
    with np.errstate(invalid="ignore"):
        return np.where(circ, -np.arcsin(np.clip(h, -1.0, 1.0)),
                        np.arctan2(wi[:, 2], -b * wi[:, 0]) - np.arccos(np.clip(-h, -1.0, 1.0)))


def phi_to_h(phi, b, wi, circ):
    """The offset h (n,) of the rim point whose normal has azimuth phi, seen from wi (local)."""
    gamma = np.where(circ, phi, np.arctan2(np.sin(phi), b * np.cos(phi)))
    c = cos_theta(wi)
    return np.where(circ, -np.sin(phi), -(wi[:, 2] / c) * np.sin(gamma) + b * (wi[:, 0] / c) * np.cos(gamma))


def d_gamma_d_h(wi, gamma, b, circ):
    """|d gamma / d h| (n,), 0 where it is infinite (Cycles' safe_divide)."""
    c = cos_theta(wi)
    d = np.where(circ, np.cos(gamma), (wi[:, 2] / c) * np.cos(gamma) + b * (wi[:, 0] / c) * np.sin(gamma))
    return np.divide(1.0, d, out=np.zeros_like(d), where=d != 0.0)


def to_point(gamma, b):
    """The rim point (n, 2) at angle gamma."""
    return np.stack([np.sin(gamma), b * np.cos(gamma)], axis=1)


def chord(g1, g2, b):
    """The distance (n,) between the rim points at angles g1 and g2."""
    d = to_point(g1, b) - to_point(g2, b)
    return np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])


def sphg_dir(theta, gamma, b, circ):
    """The direction (n, 3) of longitudinal angle theta (n, or scalar) whose azimuth is the rim normal's at gamma."""
    theta = np.broadcast_to(theta, gamma.shape)
    st, ct = np.sin(theta), np.cos(theta)
    sg, cg = np.sin(gamma), np.cos(gamma)
    plain = circ | (np.abs(cg) < 1e-6)
    safe_cg = np.where(plain, 1.0, cg)
    tan_phi = b * (sg / safe_cg)
    cp = np.sign(safe_cg) / np.sqrt(tan_phi * tan_phi + 1.0)
    sp = cp * tan_phi
    sp, cp = np.where(plain, sg, sp), np.where(plain, cg, cp)
    return np.stack([sp * ct, st, cp * ct], axis=1)


def arc_length(e2, gamma):
    """The rim's arc length per unit of gamma (n,): 1 on a circle."""
    s = np.sin(gamma)
    return np.where(e2 == 0.0, 1.0, np.sqrt(np.maximum(1.0 - e2 * (s * s), 0.0)))


def visible(v, m, h):
    """Whether the mesonormal m and the micronormal h both face v (n,) bool."""
    return (vdot(v, h) > 0.0) & (vdot(v, m) > 0.0)


def G_ggx(alpha2, cos_i, cos_o):
    """Smith's masking-shadowing of GGX: 1 / (1 + Lambda_i + Lambda_o)."""
    return 1.0 / ((1.0 + lambda_ggx(alpha2, cos_i)) + lambda_ggx(alpha2, cos_o))


def G_o(alpha2, cos_i, cos_o):
    """The masking-shadowing over the masking of the incoming direction: (1 + Li) / (1 + Li + Lo)."""
    li = lambda_ggx(alpha2, cos_i)
    return (1.0 + li) / ((1.0 + li) + lambda_ggx(alpha2, cos_o))


def energy_scale(mu, sqrt_rough, eta):
    """1 over rough glass's albedo (glass tables, by sqrt(r), mu, and the index; Cycles treats the rim as glass)."""
    ior_z = np.sqrt(np.abs((eta - 1.0) / (eta + 1.0)))
    E = np.where(eta < 1.0, ggx_tables.lookup_3d(ggx_tables.GLASS_INV_E, sqrt_rough, mu, ior_z),
                 ggx_tables.lookup_3d(ggx_tables.GLASS_E, sqrt_rough, mu, ior_z))
    return 1.0 / E


def fresnel_t(cos_i, eta):
    """Cycles' fresnel_dielectric: (the reflectance, the refracted cosine, negative; 0 under total reflection)."""
    s = eta * eta - (1.0 - cos_i * cos_i)
    tir = s <= 0.0
    c = np.abs(cos_i)
    ct = np.where(tir, 0.0, -np.sqrt(np.maximum(s, 0.0)) / eta)
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = (c + eta * ct) / (c - eta * ct)
        rp = (ct + eta * c) / (eta * c - ct)
    return np.where(tir, 1.0, 0.5 * (rs * rs + rp * rp)), ct


def refract(i, n, cos_t, inv_eta):
    """Cycles' refract_angle: i (n, 3) refracted through the normal n with the refracted cosine cos_t."""
    return (inv_eta * vdot(n, i) + cos_t)[:, None] * n - inv_eta[:, None] * i


def reflect(i, n):
    """i (n, 3) mirrored about n: i - 2 n (i.n)."""
    return i - (2.0 * vdot(i, n))[:, None] * n


def sample_wh(rough, wi, wm, u):
    """A GGX normal (n, 3) about the mesonormal wm, visible from wi, by the numbers u (n, 2)."""
    x, y, z = wm[:, 0], wm[:, 1], wm[:, 2]
    other = (x != y) | (x != z)
    a = np.where(other[:, None], np.stack([z - y, x - z, y - x], axis=1), np.stack([z - y, x + z, -y - x], axis=1))
    a = a / np.sqrt(vdot(a, a))[:, None]
    t = vectors.cross(wm, a)
    local = np.stack([vdot(wi, a), vdot(wi, t), vdot(wi, wm)], axis=1)
    Hm = visible_normal(local, rough, u)
    return Hm[:, 0:1] * a + Hm[:, 1:2] * t + Hm[:, 2:3] * wm


def visible_normal(local_wo, alpha, u):
    """A GGX normal (n, 3) seen from local_wo (n, 3) (z the mesonormal), Heitz's 2018 sampler as
    microfacet.sample_visible_normal, its angle's cosine and sine in float64 (eval integrates with these normals, so
    Python and C must draw the same ones)."""
    v = np.stack([alpha * local_wo[:, 0], alpha * local_wo[:, 1], local_wo[:, 2]], axis=1)
    v = v / np.sqrt(vdot(v, v))[:, None]
    lensq = v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1]
    flat = lensq <= 1e-7
    inv = 1.0 / np.sqrt(np.where(flat, 1.0, lensq))
    T1 = np.where(flat[:, None], [1.0, 0.0, 0.0], np.stack([-v[:, 1] * inv, v[:, 0] * inv, np.zeros(len(v))], axis=1))
    T2 = vectors.cross(v, T1)
    r = np.sqrt(u[:, 0])
    angle = 2.0 * math.pi * u[:, 1]
    t1, t2 = r * np.cos(angle), r * np.sin(angle)
    blend = 0.5 * (1.0 + v[:, 2])
    t2 = (1.0 - blend) * np.sqrt(np.maximum(1.0 - t1 * t1, 0.0)) + blend * t2
    lift = np.sqrt(np.maximum((1.0 - t1 * t1) - t2 * t2, 0.0))
    H = (T1 * t1[:, None] + T2 * t2[:, None]) + v * lift[:, None]
    H = np.stack([alpha * H[:, 0], alpha * H[:, 1], np.maximum(H[:, 2], 0.0)], axis=1)
    return H / np.sqrt(vdot(H, H))[:, None]


def trrt(T, R, A):
    """The residual's geometric series (n, 3) from the first transmission T, reflectance R (n,) and chord's A."""
    T_avg = np.maximum(1.0 - R, 1e-5)
    return (T * (R * R) * T_avg)[:, None] * A * A * A / (1.0 - A * (1.0 - T_avg)[:, None])


def finite_rows(x):
    """Rows (n,) of x (n, 3) whose entries are all finite."""
    return np.all(np.isfinite(x), axis=1)


class HuangHair(BSDF):
    """The Principled Hair BSDF's Huang model (module docstring); glossy, reflected or through the fibre, its sample
    weight its own (pdf 1, as Cycles)."""

    name: ClassVar[str] = "HAIR_HUANG"
    flags: ClassVar[F] = (F.REFLECTION | F.TRANSMISSION | F.GLOSSY | F.GLOSSY_TYPE | F.OWN_WEIGHT | F.ROUGHENS
                          | F.ANY_FACE)
    blurred: ClassVar[tuple] = ("roughness",)     # Filter Glossy caps the roughness (bsdf_hair_huang_blur)
    params: ClassVar[tuple] = ("sigma_r", "sigma_g", "sigma_b", "roughness", "tilt", "eta", "aspect_ratio", "h",
                               "r", "tt", "trt", "x_x", "x_y", "x_z", "y_x", "y_y", "y_z", "pixel_coverage")

    @classmethod
    def c_name(cls) -> str:
        """Its C functions' prefix in huang.c."""
        return "huang_hair"

    @staticmethod
    def albedo(params, N, wo):
        """The colour passes' albedo, Cycles' estimate (bsdf_hair_huang_albedo): a round, smooth fibre's paths summed
        as a geometric series, all as reflection."""
        wi = to_local(params, wo)
        h = params[:, H]
        wmi = np.stack([h, np.zeros_like(h), np.sqrt(np.maximum(1.0 - h * h, 0.0))], axis=1)
        f, cos_t = fresnel_t(vdot(wmi, wi), params[:, ETA])
        wt = refract(wi, wmi, cos_t, 1.0 / params[:, ETA])
        A = np.exp(2.0 * params[:, SIGMA:SIGMA + 3] * (cos_t / (1.0 - wt[:, 1] * wt[:, 1]))[:, None])
        den = 1.0 - f[:, None] * A
        num = A - 2.0 * f[:, None] * A + f[:, None]
        R = np.divide(num, den, out=np.zeros_like(num), where=den != 0.0)
        return R, np.zeros_like(R)

    @staticmethod
    def eval(params, N, wo, wi):
        n = len(wo)
        f_cos = np.zeros((n, 3))
        I, O = to_local(params, wo), to_local(params, wi)
        ok, lo, hi, area = integration_range(params, I, O)
        rows = np.flatnonzero(ok)
        if len(rows):
            p = params[rows]
            seed = seed_of(wo[rows, 0], wo[rows, 1], wo[rows, 2], wi[rows, 0], wi[rows, 1], wi[rows, 2])
            value = eval_r(p, I[rows], O[rows], lo[rows], hi[rows]) + eval_residual(
                p, I[rows], O[rows], lo[rows], hi[rows], seed)
            f_cos[rows] = value / area[rows, None]
        return f_cos, np.ones(n)

    @staticmethod
    def sample(params, N, wo, u):
        return sample_huang(params, wo, u)


def frame_z(params):
    """The frame's third axis Z = X x Y (n, 3), unit."""
    return safe_normalize(vectors.cross(params[:, AXIS_X:AXIS_X + 3], params[:, AXIS_Y:AXIS_Y + 3]))


def to_local(params, w):
    """Directions w (n, 3) in the fibre's frame (X, Y = the tangent, Z)."""
    return np.stack([vdot(w, params[:, AXIS_X:AXIS_X + 3]), vdot(w, params[:, AXIS_Y:AXIS_Y + 3]),
                     vdot(w, frame_z(params))], axis=1)


def to_global(params, w):
    """Local directions w (n, 3) back in world space."""
    return (w[:, 0:1] * params[:, AXIS_X:AXIS_X + 3] + w[:, 1:2] * params[:, AXIS_Y:AXIS_Y + 3]
            + w[:, 2:3] * frame_z(params))


def radius_of(b, I):
    """The fibre's projected radius (n,) (1: its major axis) seen from the local view I (n, 3)."""
    e2 = 1.0 - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(e2 == 0.0, 1.0, np.sqrt(1.0 - e2 * (I[:, 0] * I[:, 0]) / (I[:, 0] * I[:, 0] + I[:, 2] * I[:, 2])))


def near_field(params, radius):
    """Where the strand is wider than the pixel (the near-field model) (n,) bool."""
    return radius > params[:, COVERAGE]


def integration_range(params, I, O):
    """The h interval (over the radius) the eval integrates: (ok (n,) bool, lo, hi, the projected area (n,))."""
    b = params[:, B]
    circ = b == 1.0
    tan_tilt = np.tan(params[:, TILT])
    with np.errstate(divide="ignore", invalid="ignore"):
        tan_o = O[:, 1] / cos_theta(O)
        tan_i = I[:, 1] / cos_theta(I)
        half_span = np.arccos(np.maximum(-tan_tilt * tan_i, 0.0))
    ok = ~(tan_tilt * tan_o < -1.0) & ~np.isnan(half_span)
    half_span = np.where(np.isnan(half_span), 0.0, half_span)
    phi_i = np.where(circ, 0.0, dir_phi(I))
    with np.errstate(divide="ignore", invalid="ignore"):
        lo = phi_to_h(phi_i + half_span, b, I, circ)
        hi = phi_to_h(phi_i - half_span, b, I, circ)
    r = radius_of(b, I)
    near = near_field(params, r)
    half_pixel = params[:, COVERAGE]
    near_lo = np.maximum(-r, params[:, H] - half_pixel)
    near_hi = np.minimum(r, params[:, H] + half_pixel)
    dh = np.where(near, (near_hi - near_lo) / r, 2.0)
    lo = np.where(near, np.maximum(lo, near_lo), lo) / r
    hi = np.where(near, np.minimum(hi, near_hi), hi) / r
    lo, hi = np.maximum(lo, -0.999), np.minimum(hi, 0.999)
    ok &= lo < hi
    return ok, lo, hi, cos_theta(I) * dh


def intervals_of(length, step):
    """Simpson's even number of intervals (n,) int of at most `step` each over `length` (n,)."""
    return (2 * np.ceil(length / step * 0.5)).astype(np.int64)


def quadrature(lo, hi, step):
    """Simpson's rule's points over [lo, hi] (n,) in an even number of intervals of at most `step` (n,): (row (k,),
    the point's number i (k,), h (k,), its Simpson weight (k,), the interval's width (n,))."""
    count = (2 * np.ceil((hi - lo) / step * 0.5)).astype(np.int64)
    res = (hi - lo) / count
    row = np.repeat(np.arange(len(lo)), count + 1)
    first = np.cumsum(count + 1) - (count + 1)
    i = np.arange(len(row)) - first[row]
    simpson = np.where((i == 0) | (i == count[row]), 0.5, (i % 2 + 1).astype(np.float64))
    return row, i, lo[row] + i * res[row], simpson, res


def accumulate(n, row, values):
    """The sums (n, 3) of values (k, 3) by row, each row's added in order (as C's loop)."""
    out = np.zeros((n, 3))
    np.add.at(out, row, values)
    return out


def eval_r(p, wi, wo, lo, hi):
    """The R path (n, 3) towards wo (local; wi the view), Simpson's rule over h in [lo, hi]."""
    n = len(p)
    out = np.zeros(n)
    live = np.flatnonzero(p[:, LOBE_R] > 0.0)
    if not len(live):
        return np.zeros((n, 3))
    p, wi, wo, lo, hi = p[live], wi[live], wo[live], lo[live], hi[live]
    b, rough = p[:, B], p[:, ROUGH]
    e2 = 1.0 - b * b
    wh = wi + wo
    wh = wh / np.sqrt(vdot(wh, wh))[:, None]
    alpha2 = rough * rough
    k, i, h, simpson, res = quadrature(lo, hi, rough * 0.7)
    bk, circ = b[k], b[k] == 1.0
    gamma = h_to_gamma(h, bk, wi[k], circ)
    wm = sphg_dir(p[k, TILT], gamma, bk, circ)
    flat = wm * np.array([1.0, 0.0, 1.0])
    seen = visible(wi[k], flat, wh[k]) & visible(wo[k], flat, wh[k])
    weight = simpson * d_gamma_d_h(wi[k], gamma, bk, circ)
    cos_mi = vdot(wm, wi[k])
    G = G_ggx(alpha2[k], cos_mi, vdot(wm, wo[k]))
    term = (weight * D_ggx(alpha2[k], vdot(wm, wh[k])) * G * arc_length(e2[k], gamma)
            * energy_scale(cos_mi, np.sqrt(rough[k]), p[k, ETA]))
    integral = accumulate(len(p), k[seen], np.repeat(term[seen, None], 3, axis=1))[:, 0]
    integral *= 2.0 / 3.0 * res
    F = fresnel_cos(vdot(wi, wh), p[:, ETA])
    out[live] = p[:, LOBE_R] * 0.25 * F * integral
    return np.repeat(out[:, None], 3, axis=1)


def eval_residual(p, wi, wo, lo, hi, seed):
    """The TT, TRT and residual paths (n, 3) towards wo (local), Simpson's rule over h with random normals."""
    n = len(p)
    live = (p[:, LOBE_TT] > 0.0) | (p[:, LOBE_TRT] > 0.0)
    rough, eta = p[:, ROUGH], p[:, ETA]
    inv_eta = 1.0 / eta
    with np.errstate(all="ignore"):
        k, i, h, simpson, res = quadrature(lo, hi, rough * 0.8)
        keep = live[k]
        k, i, h, simpson = k[keep], i[keep], h[keep], simpson[keep]
        b, circ = p[k, B], p[k, B] == 1.0
        e2 = 1.0 - b * b
        ie = inv_eta[k]
        alpha2, sqrt_rough, r = rough[k] * rough[k], np.sqrt(rough[k]), rough[k]
        mu_a = p[k, SIGMA:SIGMA + 3]
        I, o = wi[k], wo[k]
        tilt = p[k, TILT]
        gamma_mi = h_to_gamma(h, b, I, circ)
        wmi = sphg_dir(tilt, gamma_mi, b, circ)
        wmi_ = sphg_dir(0.0, gamma_mi, b, circ)
        wh1 = sample_wh(r, I, wmi, np.stack([number(seed[k], i, 0), number(seed[k], i, 1)], axis=1))
        cos_hi1 = vdot(I, wh1)
        cos_mi1 = vdot(I, wmi)
        F1, cos_t1 = fresnel_t(cos_hi1, eta[k])
        T1 = 1.0 - F1
        scale1 = energy_scale(cos_mi1, sqrt_rough, eta[k])
        wt = refract(I, wh1, cos_t1, ie)
        phi_t = dir_phi(wt)
        gamma_mt = 2.0 * to_phi(phi_t, b, circ) - gamma_mi
        wmt = sphg_dir(-tilt, gamma_mt, b, circ)
        wmt_ = sphg_dir(0.0, gamma_mt, b, circ)
        cos_mo1 = vdot(-wt, wmi)
        cos_mi2 = vdot(-wt, wmt)
        G1o = G_o(alpha2, cos_mi1, cos_mo1)
        go = (cos_hi1 > 0.0) & visible(I, wmi, wh1) & visible(-wt, wmi, wh1) & visible(I, wmi_, wh1) \
            & visible(-wt, wmi_, wh1)
        weight = simpson * d_gamma_d_h(I, gamma_mi, b, circ)
        length = np.where(circ, 2.0 * np.cos(gamma_mi - phi_t), -chord(gamma_mi, gamma_mt + math.pi, b))
        A_t = np.exp(mu_a / cos_theta(wt)[:, None] * length[:, None])
        scale2 = energy_scale(cos_mi2, sqrt_rough, ie)
        # TT
        wh2 = -wt + ie[:, None] * o
        rcp2 = 1.0 / np.sqrt(vdot(wh2, wh2))
        wh2 = wh2 * rcp2[:, None]
        cos_mh2 = vdot(wmt, wh2)
        cos_hi2, cos_ho2, cos_mo2 = vdot(-wt, wh2), vdot(-o, wh2), vdot(-o, wmt)
        T2 = (1.0 - fresnel_cos(cos_hi2, ie)) * scale2
        D2 = D_ggx(alpha2, cos_mh2)
        G2 = G_ggx(alpha2, cos_mi2, cos_mo2)
        scalar = (weight * T1 * scale1 * T2 * D2 * G1o * G2)
        result = (scalar[:, None] * A_t / cos_mo1[:, None] * (cos_mi1 * cos_hi2 * cos_ho2 * (rcp2 * rcp2))[:, None])
        s = go & (p[k, LOBE_TT] > 0.0) & (vdot(o, wt) >= ie - 1e-5) & (cos_mh2 >= 0.0) & finite_rows(result)
        tt = (p[k, LOBE_TT] * arc_length(e2, gamma_mt))[:, None] * result
        S_tt = accumulate(n, k[s], tt[s])
        # TRT and beyond
        go &= p[k, LOBE_TRT] > 0.0
        wh2 = sample_wh(r, -wt, wmt, np.stack([number(seed[k], i, 2), number(seed[k], i, 3)], axis=1))
        cos_hi2 = vdot(-wt, wh2)
        go &= cos_hi2 > 0.0
        R2 = fresnel_cos(cos_hi2, ie)
        rest = weight[:, None] * trrt(T1, R2, A_t)
        wtr = -reflect(wt, wh2)
        tir = go & (vdot(-wtr, o) < ie - 1e-5)
        seen = go & ~tir & visible(-wt, wmt, wh2) & visible(-wtr, wmt, wh2) & visible(-wt, wmt_, wh2) \
            & visible(-wtr, wmt_, wh2)
        phi_tr = dir_phi(wtr)
        gamma_mtr = gamma_mi - 2.0 * (to_phi(phi_t, b, circ) - to_phi(phi_tr, b, circ)) + math.pi
        wmtr = sphg_dir(-tilt, gamma_mtr, b, circ)
        wmtr_ = sphg_dir(0.0, gamma_mtr, b, circ)
        wh3 = wtr + ie[:, None] * o
        rcp3 = 1.0 / np.sqrt(vdot(wh3, wh3))
        wh3 = wh3 * rcp3[:, None]
        cos_mh3 = vdot(wmtr, wh3)
        blocked = seen & ((cos_mh3 < 0.0) | ~(visible(wtr, wmtr, wh3) & visible(-o, wmtr, wh3))
                          | ~(visible(wtr, wmtr_, wh3) & visible(-o, wmtr_, wh3)))
        s = seen & ~blocked
        cos_hi3, cos_ho3, cos_mi3 = vdot(wh3, wtr), vdot(wh3, -o), vdot(wmtr, wtr)
        T3 = (1.0 - fresnel_cos(cos_hi3, ie)) * energy_scale(cos_mi3, sqrt_rough, ie)
        D3 = D_ggx(alpha2, cos_mh3)
        length = np.where(circ, 2.0 * np.abs(np.cos(phi_tr - gamma_mt)), chord(gamma_mtr, gamma_mt, b))
        A_tr = np.exp(mu_a / cos_theta(wtr)[:, None] * -length[:, None])
        cos_mo2 = vdot(wmt, -wtr)
        G2o = G_o(alpha2, cos_mi2, cos_mo2)
        G3 = G_ggx(alpha2, cos_mi3, vdot(wmtr, -o))
        scalar = weight * T1 * scale1 * R2 * scale2 * T3 * D3 * G1o * G2o * G3
        result = (scalar[:, None] * A_t * A_tr / (cos_mo1 * cos_mo2)[:, None]
                  * (cos_mi1 * cos_mi2 * cos_hi3 * cos_ho3 * (rcp3 * rcp3))[:, None])
        good = s & finite_rows(result)
        S_trt = accumulate(n, k[good], (p[k[good], LOBE_TRT] * arc_length(e2[good], gamma_mtr[good]))[:, None]
                           * result[good])
        S_trrt = accumulate(n, k[tir | blocked | s], rest[tir | blocked | s])
        cos_i, cos_o = cos_theta(wi), cos_theta(wo)
        M = longitudinal(wi[:, 1], cos_i, wo[:, 1], cos_o, 4.0 * rough)
        out = ((S_tt + S_trt) * (inv_eta * inv_eta)[:, None]
               + S_trrt * (M * (1.0 / (2.0 * math.pi)) * (2.0 / math.pi))[:, None]) * (2.0 / 3.0 * res)[:, None]
    return np.where(live[:, None], out, 0.0)


def sample_huang(params, wo, u) -> BsdfSample:
    """One path traced through the fibre per hit (Cycles' bsdf_hair_huang_sample): its direction, its weight (the
    lobes' energy, the chosen lobe's colour) and pdf 1; pdf 0 where the path was blocked."""
    n = len(wo)
    u2 = np.array(u[:, 2] if u.shape[1] > 2 else np.full(n, 0.5), np.float64)
    seed = seed_of(wo[:, 0], wo[:, 1], wo[:, 2], u[:, 0], u[:, 1], u2)
    draws = [number(seed, 0, j) for j in range(8)]
    p = params
    wi = to_local(p, wo)
    b, circ, rough, eta = p[:, B], p[:, B] == 1.0, p[:, ROUGH], p[:, ETA]
    inv_eta = 1.0 / eta
    alpha2, sqrt_rough = rough * rough, np.sqrt(rough)
    with np.errstate(all="ignore"):
        radius = radius_of(b, wi)
        h = np.where(near_field(p, radius), p[:, H] / radius, u[:, 1] * 2.0 - 1.0)
        gamma_mi = h_to_gamma(h, b, wi, circ)
        wmi_ = sphg_dir(0.0, gamma_mi, b, circ)
        st, ct = np.sin(p[:, TILT]), np.cos(p[:, TILT])
        wmi = np.stack([wmi_[:, 0] * ct, st, wmi_[:, 2] * ct], axis=1)
        cos_mi1 = vdot(wmi, wi)
        ok = ~((cos_mi1 < 0.0) | (vdot(wmi_, wi) < 0.0))
        wh1 = sample_wh(rough, wi, wmi, np.stack([u2, draws[0]], axis=1))
        wr = -reflect(wi, wh1)
        ok &= visible(wi, wmi_, wh1)
        R1, cos_t1 = fresnel_t(vdot(wi, wh1), eta)
        scale1 = energy_scale(cos_mi1, sqrt_rough, eta)
        R = p[:, LOBE_R] * R1 * scale1 * visible(wr, wmi_, wh1) * G_o(alpha2, cos_mi1, vdot(wmi, wr))
        wt = refract(wi, wh1, cos_t1, inv_eta)
        phi_t = dir_phi(wt)
        gamma_mt = 2.0 * to_phi(phi_t, b, circ) - gamma_mi
        wmt = sphg_dir(-p[:, TILT], gamma_mt, b, circ)
        wmt_ = sphg_dir(0.0, gamma_mt, b, circ)
        wh2 = sample_wh(rough, -wt, wmt, np.stack([draws[1], draws[2]], axis=1))
        wtr = -reflect(wt, wh2)
        TT, TRT, TRRT = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        cos_mi2 = vdot(-wt, wmt)
        inner = ok & (cos_mi2 > 0.0) & visible(-wt, wmi_, wh1) & visible(-wt, wmt_, wh2)
        mu_a = p[:, SIGMA:SIGMA + 3]
        length = np.where(circ, 2.0 * np.cos(phi_t - gamma_mi), -chord(gamma_mi, gamma_mt + math.pi, b))
        A_t = np.exp(mu_a / cos_theta(wt)[:, None] * length[:, None])
        R2, cos_t2 = fresnel_t(vdot(-wt, wh2), inv_eta)
        T1 = (1.0 - R1) * scale1 * G_o(alpha2, cos_mi1, vdot(wmi, -wt))
        T2 = 1.0 - R2
        scale2 = energy_scale(cos_mi2, sqrt_rough, inv_eta)
        wtt = refract(-wt, wh2, cos_t2, eta)
        s = inner & (vdot(wmt, -wtt) > 0.0) & (T2 > 0.0) & visible(-wtt, wmt_, wh2)
        tt = (p[:, LOBE_TT] * T1)[:, None] * A_t * (T2 * scale2 * G_o(alpha2, cos_mi2, vdot(wmt, -wtt)))[:, None]
        TT = np.where(s[:, None], tt, 0.0)
        phi_tr = dir_phi(wtr)
        gamma_mtr = gamma_mi - 2.0 * (to_phi(phi_t, b, circ) - to_phi(phi_tr, b, circ)) + math.pi
        wmtr = sphg_dir(-p[:, TILT], gamma_mtr, b, circ)
        wh3 = sample_wh(rough, wtr, wmtr, np.stack([draws[3], draws[4]], axis=1))
        R3, cos_t3 = fresnel_t(vdot(wtr, wh3), inv_eta)
        wtrt = refract(wtr, wh3, cos_t3, eta)
        cos_mi3 = vdot(wmtr, wtr)
        deep = inner & (cos_mi3 > 0.0)
        length = np.where(circ, 2.0 * np.abs(np.cos(phi_tr - gamma_mt)), chord(gamma_mt, gamma_mtr, b))
        A_tr = np.exp(mu_a / cos_theta(wtr)[:, None] * -length[:, None])
        TR = ((T1 * R2 * scale2)[:, None] * A_t * A_tr
              * (energy_scale(cos_mi3, sqrt_rough, inv_eta) * G_o(alpha2, cos_mi2, vdot(wmt, -wtr)))[:, None])
        T3 = 1.0 - R3
        flat3 = wmtr * np.array([1.0, 0.0, 1.0])
        s = deep & (T3 > 0.0) & visible(wtr, flat3, wh3) & visible(-wtrt, flat3, wh3)
        TRT = np.where(s[:, None], p[:, LOBE_TRT, None] * TR * (T3 * G_o(alpha2, cos_mi3, vdot(wmtr, -wtrt)))[:, None],
                       0.0)
        z = np.maximum(draws[5], 1e-5)
        fac = 1.0 + 4.0 * rough * np.log(z + (1.0 - z) * np.exp(-0.5 / rough))
        sin_o = -fac * wi[:, 1] + np.sqrt(np.maximum(1.0 - fac * fac, 0.0)) * np.cos(2.0 * math.pi * draws[6]) \
            * cos_theta(wi)
        cos_o = np.sqrt(np.maximum(1.0 - sin_o * sin_o, 0.0))
        phi_o = 2.0 * math.pi * draws[7]
        wtrrt = np.stack([np.sin(phi_o) * cos_o, sin_o, np.cos(phi_o) * cos_o], axis=1)
        A_avg = np.sqrt(A_t * A_tr)
        T_avg = np.maximum(0.5 * (T2 + T3), 1e-5)
        A_res = A_avg * T_avg[:, None] / (1.0 - A_avg * (1.0 - T_avg)[:, None])
        trrt_ = TR * A_res * (R3 * G_o(alpha2, cos_mi3, vdot(wmtr, -reflect(wtr, wh3))))[:, None]
        TRRT = np.where(deep[:, None], trrt_, 0.0)
        r = np.where(ok, R, 0.0)
        TT, TRT, TRRT = (np.where(ok[:, None], x, 0.0) for x in (TT, TRT, TRRT))
        tt, trt, rest = (x.sum(axis=1) / 3.0 for x in (TT, TRT, TRRT))
        total = ((r + tt) + trt) + rest
        pick = u[:, 0] * total
        lobe = np.where(pick < r, 0, np.where(pick < r + tt, 1, np.where(pick < (r + tt) + trt, 2, 3)))
        local = np.select([lobe[:, None] == 0, lobe[:, None] == 1, lobe[:, None] == 2], [wr, wtt, wtrt], wtrrt)
        colour = np.select([lobe[:, None] == 0, lobe[:, None] == 1, lobe[:, None] == 2],
                           [np.ones((n, 3)), TT / tt[:, None], TRT / trt[:, None]], TRRT / rest[:, None])
        weight = colour * total[:, None]
        good = (total != 0.0) & ok & finite_rows(weight) & finite_rows(local)
    return BsdfSample(np.where(good[:, None], to_global(p, local), 0.0), np.where(good[:, None], weight, 0.0),
                      np.where(good, 1.0, 0.0))


# The node's inputs: the Principled Hair BSDF's (hair.py), then Huang's own: Aspect Ratio, the lobe scales
# Reflection, Transmission, Secondary Reflection, the curve's normal (the major axis, not named "normal": that input
# is a node's own Normal), and the half pixel's width over the strand's radius (0: unknown, the far field).
HUANG_INPUTS = PRINCIPLED_HAIR_INPUTS + ("aspect_ratio", "reflection", "transmission", "secondary_reflection",
                                         "major_axis", "pixel_coverage", "surface_tangent")
HUANG_DEFAULTS = PRINCIPLED_HAIR_DEFAULTS + (0.85, 1.0, 1.0, 1.0, (0.0, 0.0, 0.0), 0.0, (0.0, 0.0, 0.0))


def huang_params(p: np.ndarray, N: np.ndarray, wo: np.ndarray, surface=None) -> tuple:
    """Huang's closure rows (n, PARAMS) from the node's inputs p (n, NODE_PARAMS) at hits with the round normal N and
    view wo (n, 3), as Cycles' svm node and bsdf_hair_huang_setup compute them; and where the hit lies outside the
    elliptical fibre's projected width (n,) bool (Cycles makes it transparent there). surface: (n, 3) a triangle's
    dPdu towards the viewer's side (hair.surface_tangent; zero on curves), Cycles' Y there (a round fibre), or None."""
    n = len(p)
    random = p[:, 16]
    roughness = p[:, 9] * (1.0 + 2.0 * (random - 0.5) * p[:, 14])
    sigma = hair_sigma(p, roughness)
    Y = safe_normalize(p[:, 20:23])
    mesh = np.zeros(n, bool) if surface is None else np.any(surface != 0.0, axis=1)
    if mesh.any():                   # (a triangle: Cycles' Y is its dPdu)
        Y = np.where(mesh[:, None], safe_normalize(surface), Y)
    none = ~np.any(Y != 0.0, axis=1) | mesh
    if (none & ~mesh).any():         # (a degenerate triangle: a tangent across the normal, Primer's own choice)
        Y = np.where((none & ~mesh)[:, None], vectors.orthonormal_frame(N)[0], Y)
    X = safe_normalize(vectors.cross(Y, wo))
    h = -vdot(X, N)
    b = p[:, 23]
    axis = p[:, 27:30]
    elliptic = (b != 1.0) & ~none
    A = safe_normalize(vectors.cross(Y, safe_normalize(vectors.cross(axis, Y))))
    flip = elliptic & (b > 1.0)
    b = np.where(flip, 1.0 / np.where(b == 0.0, 1.0, b), b)
    minor = safe_normalize(vectors.cross(Y, A))
    A = np.where(flip[:, None], safe_normalize(vectors.cross(minor, Y)), A)
    A = np.where(elliptic[:, None], A, X)
    bad = ~np.any(A != 0.0, axis=1) | ~np.all(np.isfinite(A), axis=1)
    if bad.any():
        A = np.where(bad[:, None], vectors.orthonormal_frame(Y)[0], A)
    Z = safe_normalize(vectors.cross(A, Y))
    radius = radius_of(b, np.stack([vdot(wo, A), vdot(wo, Y), vdot(wo, Z)], axis=1))
    out = np.zeros((n, PARAMS))
    out[:, SIGMA:SIGMA + 3] = sigma
    out[:, ROUGH] = np.clip(roughness, 0.001, 1.0)
    out[:, TILT] = -p[:, 13]
    out[:, ETA] = p[:, 12]
    out[:, B] = b
    out[:, H] = h
    out[:, LOBE_R:LOBE_TRT + 1] = np.maximum(p[:, 24:27], 0.0)
    out[:, AXIS_X:AXIS_X + 3], out[:, AXIS_Y:AXIS_Y + 3] = A, Y
    coverage = p[:, 30]
    out[:, COVERAGE] = np.where(coverage > 0.0, coverage, 1.0)
    return out, np.abs(h) >= radius


class HuangHairNode(Node):
    """Principled Hair BSDF, Huang's model (Blender's ShaderNodeBsdfHairPrincipled, model 'HUANG'): one HuangHair
    closure of the node's weight, its absorption parametrised as Chiang's (Roughness in Radial Roughness's place),
    Roughness scaled by Random Roughness, IOR, Offset, Aspect Ratio with the major axis along the curve's normal,
    the lobe scales; none where all three lobes are 0; a hit outside the elliptical fibre is transparent."""

    name = "PRINCIPLED_HAIR_HUANG"
    lets_light_through = True
    inputs, defaults = HUANG_INPUTS, HUANG_DEFAULTS

    @staticmethod
    def setup(b, weight, p):
        """One HuangHair closure per hit (huang_params), its normal the hit's; on a triangle Cycles' bsdf->N, its
        frame's X (hair.fibre_normal)."""
        p = per_hit_rows(p, len(weight))
        surface = surface_tangent(b, p[:, 31:34])
        weight = through_own_fibre(b, weight, surface)
        rows, outside = huang_params(p, b.N, b.wo, surface)
        keep = np.any(p[:, 24:27] > 0.0, axis=1)
        b.transparency += np.where((outside & keep)[:, None], weight, 0.0)
        weight = np.where((outside | ~keep)[:, None], 0.0, weight)
        b.add(HuangHair.kind, weight, rows, N=fibre_normal(b.N, surface, rows[:, AXIS_X:AXIS_X + 3]))


def huang_links() -> dict:
    """The graph links Huang's node reads on curves beyond hair.curve_links: `major_axis`, the tubes' rotation-minimising
    normal ("curve_normal", per vertex) in world space, the elliptical fibre's major axis; and `pixel_coverage`, half
    the camera ray's footprint over the strand's radius (Cycles' 0.5 dP / radius: footprint / Curves Info's
    Thickness) on camera rays, 0 on others (the far field)."""
    from .graph import GraphNode, Link
    normal = Link(GraphNode("ATTRIBUTE", {"attribute": "curve_normal"}, {}, "curve normal"), "Vector")
    world = Link(GraphNode("VECTOR_TRANSFORM", {"type": "VECTOR", "from": "OBJECT", "to": "WORLD"},
                           {"Vector": normal}, "curve normal in world space"), "Vector")
    footprint = Link(GraphNode("RAY_FOOTPRINT", {}, {}, "ray footprint"), "Value")
    thickness = Link(GraphNode("CURVES_INFO", {}, {}, "curve thickness"), "Thickness")
    camera = Link(GraphNode("LIGHT_PATH", {}, {}, "camera ray"), "Is Camera Ray")
    half_pixel = Link(GraphNode("MATH", {"operation": "DIVIDE"}, {"0": footprint, "1": thickness}), "Value")
    coverage = Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": camera, "1": half_pixel}), "Value")
    return {"major_axis": world, "pixel_coverage": coverage}
