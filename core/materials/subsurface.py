"""Subsurface scattering: the BSSRDF closure of the Principled BSDF's Subsurface Weight, as Cycles sets it up.

Light that enters skin, wax or marble scatters inside and leaves somewhere else. Cycles' Random Walk method
(kernel/closure/bssrdf.h, kernel/integrator/subsurface*.h) traces that literally: the closure is no BSDF (it
has no value for a pair of directions, so light samples at the entry point skip it), and a path that picks it

1. refracts into the surface through a rough dielectric boundary (a GGX normal seen from the viewer, index
   `ior`, roughness alpha = roughness^2; Random Walk (Skin) half the time cosine-weighted, else with alpha 1);
2. walks inside the mesh as in a homogeneous medium whose coefficients per colour channel come from the
   surface colour (`albedo`, the multiple-scattering albedo the walk should reproduce) and the scattering
   radius (the mean free path): core/integrators/subsurface.py;
3. leaves where the walk crosses the mesh again, and is lit there as a white Lambert surface (the walk's
   throughput carries the colour), the path going on from there with a diffuse bounce.

Set-up (bssrdf_setup): channels whose radius is below MIN_RADIUS scatter as a plain diffuse closure of their
weight (radius -> 0 is the diffuse look); the others keep the BSSRDF, whose sampling weight is its mean weight
times how many channels it has. Random Walk scales the radius by 1 / (4 pi), to look like the older
Christensen-Burley profile; Random Walk (Skin) by sqrt(3 (1 - alpha')) with alpha' the single-scattering albedo
a dipole of index `ior` needs for the surface colour.

Christensen-Burley (Cycles' disk projection, kernel/integrator/subsurface_disk.h) is the same closure with its DISK
slot set and the radius scaled by 1 / (4 pi) as Random Walk's: instead of a walk, the exit is found by probing the
object along a chord through a disk about the entry (core/integrators/subsurface.py disk), the radius on the disk
drawn from Burley's normalized diffusion profile (burley_*, below), and the throughput weighed by the profile at the
exit's true distance. Its sample is no direction: the entry never fails. After any diffuse bounce it is a plain
Lambert closure of its weight (Cycles' PATH_RAY_DIFFUSE_ANCESTOR rule: subsurface.burley_as_diffuse).
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from .base import BSDF, BsdfSample
from .base import BSDFFlags as F
from .lambert import Lambert
from .microfacet import sample_visible_normal
from .nodes import Node, per_hit_rows
from ..native import schema

# The closure's parameter slots.
RADIUS, ALBEDO, ANISOTROPY, IOR, ALPHA, SKIN, BUMP, DISK = 0, 3, 6, 7, 8, 9, 10, 11
# Blender's Subsurface Method (the node's subsurface_method) as the node input's number.
# RANDOM_WALK_MFP is Random Walk as Blender 5.2's Cycles renders it: the radius is the mean free path itself, not
# scaled by 1 / (4 pi) (measured: tests/test_blender_subsurface.py on bpy 5.2 matches with it, not without).
BURLEY = schema.constant("SUBSURFACE_BURLEY", 0.0, "subsurface.BURLEY: the Christensen-Burley (disk) method's number")
RANDOM_WALK = 1.0
RANDOM_WALK_SKIN = schema.constant("RANDOM_WALK_SKIN", 2.0, "subsurface.RANDOM_WALK_SKIN: the Skin method's number")
RANDOM_WALK_MFP = schema.constant("RANDOM_WALK_MFP", 3.0, "subsurface.RANDOM_WALK_MFP: Blender 5.2's Random Walk")
METHODS = {"BURLEY": BURLEY, "RANDOM_WALK": RANDOM_WALK, "RANDOM_WALK_SKIN": RANDOM_WALK_SKIN}


def method_of(name: str, blender_version: tuple) -> float:
    """The `method` number of Blender's Subsurface Method (or Falloff) `name` as the Cycles of `blender_version`
    (major, minor, ...) renders it: Random Walk without the 1 / (4 pi) radius scale from Blender 5.2 (Christensen-Burley
    keeps it there too, as Cycles' bssrdf_setup_radius)."""
    method = METHODS.get(name, RANDOM_WALK)
    if method == RANDOM_WALK and tuple(blender_version[:2]) >= (5, 2):
        return RANDOM_WALK_MFP
    return method
# Radii below this scatter as diffuse (Cycles' BSSRDF_MIN_RADIUS).
MIN_RADIUS = 1e-8
# Burley's profile is cut at BURLEY_TRUNCATE d (Cycles' choice), where its cumulative is BURLEY_TRUNCATE_CDF.
BURLEY_TRUNCATE = 16.0
BURLEY_TRUNCATE_CDF = 0.9963790093708328


def burley_radial(d: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Burley's normalized diffusion profile as a density in the distance r: 2 pi r R(r) = (e^(-r/d) + e^(-r/3d))
    / (4 d) for unit albedo (Christensen and Burley 2015, eq. 3), 0 from BURLEY_TRUNCATE d on; d, r broadcast."""
    d = np.asarray(d, np.float64)
    r = np.asarray(r, np.float64)
    safe = np.where(d > 0.0, d, 1.0)
    e3 = np.exp(-r / (3.0 * safe))
    return np.where((d > 0.0) & (r < BURLEY_TRUNCATE * d), (e3 * e3 * e3 + e3) / (4.0 * safe), 0.0)


def burley_pdf(d: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The density of the distance r sampled from the truncated profile of d (Cycles' bssrdf_burley_pdf): 0 at r = 0."""
    r = np.asarray(r, np.float64)
    return np.where(r == 0.0, 0.0, burley_radial(d, r) / BURLEY_TRUNCATE_CDF)


def burley_root(xi: np.ndarray) -> np.ndarray:
    """The distance x (in units of d) where the profile's cumulative 1 - e^(-x)/4 - 3 e^(-x/3)/4 reaches xi (n,):
    Newton's method from Cycles' fitted guess, at most 10 steps, stopped within 1e-6 (bssrdf_burley_root_find)."""
    xi = np.asarray(xi, np.float64)
    x = np.where(xi <= 0.9, np.exp(xi * xi * 2.4) - 1.0, 15.0)
    going = np.ones(len(xi), bool)
    for _ in range(10):
        e3 = np.exp(-x / 3.0)
        e = e3 * e3 * e3
        f = 1.0 - 0.25 * e - 0.75 * e3 - xi
        slope = 0.25 * e + 0.25 * e3
        going &= (np.abs(f) >= 1e-6) & (slope != 0.0)
        x = np.where(going, np.maximum(x - f / np.where(slope != 0.0, slope, 1.0), 0.0), x)
    return x


def burley_sample(radius: np.ndarray, xi: np.ndarray) -> tuple:
    """(r, h) (n,) each: a distance on the disk for the per-channel d `radius` (n, 3) and the number xi (n,) in [0, 1):
    a channel with d > 0 picked uniformly (xi reused within its share), r from its truncated profile, and the probe's
    half length h = sqrt((BURLEY_TRUNCATE d)^2 - r^2) (Cycles' bssrdf_sample)."""
    live = radius > 0.0
    channels = live.sum(axis=1)
    x = xi * channels
    rank = np.minimum(np.floor(x), np.maximum(channels - 1, 0)).astype(np.int64)
    order = np.cumsum(live, axis=1) - 1                          # each live channel's rank among the live ones
    pick = np.argmax(live & (order == rank[:, None]), axis=1)
    d = np.where(channels > 0, radius[np.arange(len(xi)), pick], 0.0)
    r = burley_root((x - rank) * BURLEY_TRUNCATE_CDF) * d
    Rm = BURLEY_TRUNCATE * d
    return r, np.sqrt(np.maximum(Rm * Rm - r * r, 0.0))


class RandomWalk(BSDF):
    """The BSSRDF closure (Cycles' Bssrdf of type Random Walk or Random Walk (Skin)): eval 0; `sample` gives the
    direction into the surface the walk starts along (weight 1, pdf inf: the closure's weight over the chance of
    picking it is the path's, as Cycles' surface_shader_bssrdf_sample_weight). Parameters: radius (3) the mean
    free path per channel, already scaled; albedo (3) the surface colour; anisotropy g; ior; alpha the entry's
    GGX roughness; skin 1 for Random Walk (Skin); bump 1 where its node's Normal is linked (the walk's exit is then
    lit with the BSSRDFs' own normals, Cycles' SD_HAS_BSSRDF_BUMP); disk 1 for Christensen-Burley (no entry
    direction: wi is -N and never fails)."""

    name: ClassVar[str] = "SUBSURFACE"
    flags: ClassVar[F] = F.SUBSURFACE | F.DIFFUSE_TYPE
    params: ClassVar[tuple] = ("radius", "albedo", "anisotropy", "ior", "alpha", "skin", "bump", "disk")

    @staticmethod
    def eval(params, N, wo, wi):
        m = len(wo)
        return np.zeros((m, 3)), np.zeros(m)

    @staticmethod
    def sample(params, N, wo, u) -> BsdfSample:
        m = len(wo)
        skin = params[:, SKIN] != 0.0
        # Skin: half the time a cosine-weighted direction into the surface (the number reused for the rest).
        diffuse = skin & (u[:, 0] < 0.5)
        ux = np.where(skin, np.where(diffuse, 2.0 * u[:, 0], 2.0 * (u[:, 0] - 0.5)), u[:, 0])
        uu = np.column_stack([np.minimum(ux, np.nextafter(1.0, 0.0)), u[:, 1]])
        wi = Lambert.sample(None, -N, wo, uu).wi
        # Else refraction through a GGX normal seen from the viewer (no shadowing term, as Cycles).
        cos_NI = np.einsum("ij,ij->i", N, wo)
        X, Y = vectors.orthonormal_frame(N)
        local_I = np.column_stack([np.einsum("ij,ij->i", X, wo), np.einsum("ij,ij->i", Y, wo), cos_NI])
        alpha = np.where(skin, 1.0, params[:, ALPHA])
        local_H = sample_visible_normal(np.where((cos_NI > 0.0)[:, None], local_I, [[0.0, 0.0, 1.0]]),
                                        np.maximum(alpha, 1e-7), uu)
        H = X * local_H[:, 0:1] + Y * local_H[:, 1:2] + N * local_H[:, 2:3]
        neta = 1.0 / params[:, IOR]
        cos_HI = np.einsum("ij,ij->i", H, wo)
        root = np.maximum(np.sqrt(np.maximum(1.0 - neta * neta * (1.0 - cos_HI * cos_HI), 0.0)), 1e-7)
        refracted = -neta[:, None] * wo + (neta * cos_HI - root)[:, None] * H
        refracted /= np.linalg.norm(refracted, axis=1)[:, None]
        wi = np.where(diffuse[:, None], wi, refracted)
        disk = params[:, DISK] != 0.0
        wi = np.where(disk[:, None], -N, wi)
        ok = diffuse | (cos_NI > 0.0) | disk
        return BsdfSample(wi, np.where(ok[:, None], 1.0, 0.0) * np.ones((m, 3)), np.where(ok, np.inf, 0.0))


def dipole_Rd(alpha_prime: np.ndarray, fourthird_A: np.ndarray) -> np.ndarray:
    """The diffuse reflectance of a dipole of single-scattering albedo alpha' (Jensen; bssrdf_dipole_compute_Rd)."""
    s = np.sqrt(3.0 * (1.0 - alpha_prime))
    return 0.5 * alpha_prime * (1.0 + np.exp(-fourthird_A * s)) * np.exp(-s)


def dipole_alpha_prime(rd: np.ndarray, fourthird_A: np.ndarray) -> np.ndarray:
    """The alpha' whose dipole reflects `rd` (any shape): 12 bisection steps, 0 below 1e-4, 0.999999 from 0.995."""
    lo, hi = np.zeros_like(rd), np.ones_like(rd)
    mid = 0.5 * (lo + hi)
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        below = dipole_Rd(mid, fourthird_A) < rd
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return np.where(rd < 1e-4, 0.0, np.where(rd >= 0.995, 0.999999, mid))


def scaled_radius(radius: np.ndarray, albedo: np.ndarray, ior: np.ndarray, skin: np.ndarray,
                  mfp=False) -> np.ndarray:
    """The walk's mean free path (n, 3) from the node's radius (n, 3): x 1 / (4 pi) (Random Walk), or for Skin
    x sqrt(3 (1 - alpha')) with alpha' the dipole's for the colour and index (bssrdf_setup_radius); the radius itself
    where `mfp` (n,) bool (RANDOM_WALK_MFP, Blender 5.2)."""
    inv_eta = 1.0 / ior
    F_dr = inv_eta * (-1.440 * inv_eta + 0.710) + 0.668 + 0.0636 * ior
    fourthird_A = ((4.0 / 3.0) * (1.0 + F_dr) / (1.0 - F_dr))[:, None]
    skin_radius = radius * np.sqrt(3.0 * (1.0 - dipole_alpha_prime(albedo, fourthird_A)))
    walk_radius = np.where(np.asarray(mfp)[..., None] if np.ndim(mfp) else mfp, radius, radius * (0.25 / math.pi))
    return np.where(skin[:, None], skin_radius, walk_radius)


def add_subsurface(b, weight: np.ndarray, radius: np.ndarray, albedo: np.ndarray, anisotropy: np.ndarray,
                   ior: np.ndarray, alpha: np.ndarray, method: np.ndarray, cutoff: float) -> None:
    """Append Cycles' BSSRDF closure of `weight` (n, 3) to the ClosureBuilder b (bssrdf_setup): radius (n, 3) the
    node's radius x scale; albedo (n, 3) the clamped surface colour; anisotropy, ior, alpha (n,) (clamped to
    0..0.9 and 1.01..3.8 here); method (n,) METHODS (BURLEY: the disk). Channels with too small a radius go to a
    Lambert closure."""
    radius = np.maximum(radius, 0.0)
    weight = np.where((np.abs(weight.mean(axis=1)) >= cutoff)[:, None], weight, 0.0)
    small = radius < MIN_RADIUS
    diffuse = np.where(small, weight, 0.0)
    kept = np.where(small, 0.0, weight)
    channels = (~small).sum(axis=1)
    if small.any():
        b.add(Lambert.kind, diffuse, N=b.glossy_N)
    ior = np.clip(ior, 1.01, 3.8)
    skin = method == RANDOM_WALK_SKIN
    p = np.zeros((len(weight), b.closures.params.shape[2]))
    p[:, RADIUS:RADIUS + 3] = np.where(small, 0.0, scaled_radius(np.where(small, 1.0, radius), albedo, ior, skin,
                                                                  method == RANDOM_WALK_MFP))
    p[:, ALBEDO:ALBEDO + 3] = albedo
    p[:, ANISOTROPY] = np.clip(anisotropy, 0.0, 0.9)
    p[:, IOR] = ior
    p[:, ALPHA] = np.where(skin, 1.0, alpha)
    p[:, SKIN] = skin
    p[:, BUMP] = b.N is not b.smooth_N              # (the node's own Normal input: a linked one)
    p[:, DISK] = method == BURLEY
    # Sampling weight: |mean weight| x the channels it scatters (as Cycles).
    b.add(RandomWalk.kind, kept, p, factor=channels.astype(np.float64), keep=channels > 0,
          N=b.glossy_N)


class SubsurfaceNode(Node):
    """Subsurface Scattering (Blender's ShaderNodeSubsurfaceScattering, Cycles' BSSRDF closure node): one BSSRDF of
    the node's weight x Color, the colour its albedo (per hit where linked), radius Radius x Scale, IOR, the entry's
    alpha its Roughness (0..1), Anisotropy, and the node's Falloff as `method` (Christensen-Burley: the disk). Its C
    setup: nodes.c subsurface_node."""

    name = "SUBSURFACE"
    inputs = ("color", "radius", "scale", "ior", "roughness", "anisotropy", "method")
    defaults = ((0.8, 0.8, 0.8), (1.0, 0.2, 0.1), 0.05, 1.4, 1.0, 0.0, RANDOM_WALK)
    slots = 2

    @staticmethod
    def setup(b, weight, p):
        """The BSSRDF closure (add_subsurface) for n hits: weight (n, 3), inputs p (n, NODE_PARAMS)."""
        from .closures import WEIGHT_CUTOFF
        p = per_hit_rows(p, len(weight))
        color = p[:, 0:3]
        add_subsurface(b, weight * color, p[:, 3:6] * p[:, 6:7], color, p[:, 9], p[:, 7], np.clip(p[:, 8], 0.0, 1.0),
                       p[:, 10], WEIGHT_CUTOFF)
