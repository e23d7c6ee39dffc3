"""Phase functions: how a scattering medium sends the light it scatters on, the volume's BSDF.

A phase function p(wo, wi) is a density over the sphere of directions (it integrates to 1): the share of the light
arriving from wi that a scattering event sends towards wo. With a BSDF's conventions (wo towards the viewer, wi
towards the light) it depends only on the angle theta by which the light turns, between its direction of travel
before the event, -wi, and after it, wo: cos theta = dot(-wo, wi). Cycles' Volume Scatter and Volume Coefficients
nodes (Blender 4.3+) offer five in their Phase menu (src/kernel/closure/volume_util.h), each a class here:

- Henyey-Greenstein (`HenyeyGreenstein`, anisotropy g; also the Principled Volume's):
      p = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^1.5)
  g > 0 scatters forward (light goes on roughly straight), g < 0 backward, g = 0 evenly (1 / 4 pi);
- Fournier-Forand (`FournierForand`, Backscatter B and IOR n: ocean water's particles): with
  delta = 4 sin^2(theta/2) / (3 (n - 1)^2), v from B (the share scattered backwards) and delta(180 deg),
      p = [v (1 - delta) - (1 - delta^v) + (delta (1 - delta^v) - v (1 - delta)) / sin^2(theta/2)]
          / (4 pi (1 - delta)^2 delta^v)  +  c (3 cos^2 theta - 1) / (16 pi)
  sampled by Newton's method on its cdf (Cycles' phase_fournier_forand_newton);
- Draine (`Draine`, anisotropy g and alpha): HG times (1 + alpha cos^2 theta), normalised by
  1 + alpha (1 + 2 g^2) / 3 (alpha = 0: HG; g = 0, alpha = 1: Rayleigh); its cdf inverted in closed form;
- Rayleigh (`Rayleigh`): 3 (1 + cos^2 theta) / (16 pi), small particles (air); its cdf inverted by a cube root;
- Mie (`Mie`, droplet Diameter d in micrometres): Jendersie and d'Eon's fit, (1 - w) HG(g_HG) + w Draine(g_D, alpha)
  with the four numbers fitted from d (`mie_parameters`), as Cycles' phase_mie_fitted_parameters (two closures there,
  one mixture here: the same density, sampled by picking a lobe with probability w).

Every `sample` draws from p itself, so eval / pdf = 1 (Cycles: "perfect importance sampling"). A medium carries its
phase function as a kind (PHASE_HENYEY_GREENSTEIN ...) and PHASE_PARAMETERS numbers (`Phase.parameters`, read back
by `phase_of`); `Phases` evaluates and samples rows of mixed kinds, as the media hand them to the integrators. The
C twin is phase.c (phase_eval, phase_sample), held to this file by primer_phase_rows (`compiled_rows`).
"""
from __future__ import annotations

import math
from typing import ClassVar, NamedTuple

import numpy as np

from .. import vectors
from ..native import schema

# The phase functions' kinds (C: PHASE_HENYEY_GREENSTEIN ...), in the order of the Phase menu's Blender identifiers.
PHASE = schema.constants("PHASE", ["HENYEY_GREENSTEIN", "FOURNIER_FORAND", "DRAINE", "RAYLEIGH", "MIE"],
                         "a medium's phase function (core/volumes/phase.py)")
PHASE_PARAMETERS = schema.constant("PHASE_PARAMETERS", 4, "the numbers a medium's phase function carries")
PHASE_LOBES = schema.constant("PHASE_LOBES", 8, "the most phase functions a heterogeneous medium's point mixes")
# A Draine or HG anisotropy's clamp (Cycles' setup: no delta function), and FF's Backscatter and IOR clamps.
G_LIMIT = 1.0 - 1e-3


class PhaseSample(NamedTuple):
    """Directions sampled from a phase function: wi (n, 3) unit, pdf (n,) (the weight p / pdf is 1)."""

    wi: np.ndarray
    pdf: np.ndarray


def clamp_g(g):
    """An anisotropy clamped as Cycles' HG and Draine setups clamp it: |g| <= 1 - 1e-3, its sign kept."""
    return np.sign(g) * np.minimum(np.abs(g), G_LIMIT)


def cosines(wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """cos theta = dot(-wo, wi) (n,) float64 of unit directions wo, wi (n, 3)."""
    return np.einsum("ij,ij->i", -wo, wi)


def around(wo: np.ndarray, cos_theta: np.ndarray, u1: np.ndarray) -> np.ndarray:
    """Directions wi (n, 3) at angle theta (cos_theta (n,)) from -wo (n, 3), at azimuth 2 pi u1 (n,) about it."""
    cos_theta = np.clip(cos_theta, -1.0, 1.0)
    sin_theta = np.sqrt(np.maximum(1.0 - cos_theta * cos_theta, 0.0))
    phi = 2.0 * np.pi * u1
    axis = -wo                                           # wi at theta = 0: light that goes on straight to the viewer
    T, B = vectors.orthonormal_frame(axis)
    return (sin_theta * np.cos(phi))[:, None] * T + (sin_theta * np.sin(phi))[:, None] * B + cos_theta[:, None] * axis


def _rows(x, n: int) -> np.ndarray:
    """x (a float or (n,)) as (n,) float64."""
    return np.broadcast_to(np.asarray(x, np.float64), (n,))


class Phase:
    """A phase function: its kind (PHASE[...]), its Blender Phase menu identifier, and eval / pdf / sample over n
    rows (its numbers floats or (n,) float64 each)."""

    kind: ClassVar[int] = -1
    blender: ClassVar[str] = ""

    def eval_cos(self, cos_theta: np.ndarray) -> np.ndarray:
        """p (n,) float64 at cos theta (n,)."""
        raise NotImplementedError

    def sample_cos(self, u0: np.ndarray) -> np.ndarray:
        """cos theta (n,) drawn from p by the unit numbers u0 (n,)."""
        raise NotImplementedError

    def eval(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """p(wo, wi) (n,) float64 for unit directions wo (towards the viewer) and wi (towards the light), (n, 3)."""
        return self.eval_cos(cosines(wo, wi))

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """The solid-angle pdf (n,) of `sample` choosing wi: p itself."""
        return self.eval(wo, wi)

    def sample(self, wo: np.ndarray, u: np.ndarray) -> PhaseSample:
        """Directions wi (n, 3) towards the light for viewers along wo (n, 3), from unit-square numbers u (n, 2):
        the angle from u[:, 0] (the cdf's inverse), the azimuth uniform (u[:, 1]) around the light's direction of
        travel -wo; pdf (n,) = p there."""
        cos_theta = self.sample_cos(np.asarray(u[:, 0], np.float64))
        return PhaseSample(around(wo, cos_theta, u[:, 1]), self.eval_cos(cos_theta))

    def parameters(self, n: int) -> np.ndarray:
        """The numbers (n, PHASE_PARAMETERS) float64 a medium carries for it (phase_of reads them back)."""
        raise NotImplementedError

    def mean_cosine(self, n: int = 1) -> np.ndarray:
        """The mean cosine <cos theta> (n,) float64 (the anisotropy a mixture of media averages)."""
        raise NotImplementedError


class HenyeyGreenstein(Phase):
    """The Henyey-Greenstein phase function of anisotropy g (n,) float64 or a float, |g| < 1."""

    kind: ClassVar[int] = PHASE["HENYEY_GREENSTEIN"]
    blender: ClassVar[str] = "HENYEY_GREENSTEIN"

    def __init__(self, g):
        self.g = g

    def eval_cos(self, cos_theta):
        """Cycles' phase_henyey_greenstein (1 / 4 pi where |g| < 1e-3)."""
        g = np.asarray(self.g, np.float64)
        return np.where(np.abs(g) < 1e-3, 0.25 / np.pi, henyey_greenstein(cos_theta, g))

    def sample_cos(self, u0):
        """The cdf's inverse (uniform where |g| < 1e-3)."""
        g = _rows(self.g, len(u0))
        isotropic = np.abs(g) < 1e-3
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u0)
            cos_theta = np.where(isotropic, 1.0 - 2.0 * u0, (1.0 + g * g - s * s) / (2.0 * g))
        return np.clip(cos_theta, -1.0, 1.0)

    def sample(self, wo, u):
        """As Phase.sample, its pdf HG's formula at the angle (as before the Phase menu, bit for bit)."""
        g = _rows(self.g, len(wo))
        cos_theta = self.sample_cos(np.asarray(u[:, 0], np.float64))
        return PhaseSample(around(wo, cos_theta, u[:, 1]), henyey_greenstein(cos_theta, g))

    def eval(self, wo, wi):
        """HG's formula at dot(-wo, wi) (n,) (also where |g| < 1e-3: it is 1 / 4 pi to 1e-3 there)."""
        return henyey_greenstein(cosines(wo, wi), self.g)

    def parameters(self, n):
        """[g, 0, 0, 0] per row."""
        out = np.zeros((n, PHASE_PARAMETERS))
        out[:, 0] = _rows(self.g, n)
        return out

    def mean_cosine(self, n=1):
        """<cos theta> = g."""
        return _rows(self.g, n).copy()


class FournierForand(Phase):
    """The Fournier-Forand phase function of particles of IOR n (> 1) scattering a share B (< 1/2) backwards, kept
    as Cycles' three coefficients (n, v, c) (phase_fournier_forand_coeffs); `of(B, ior)` clamps as its setup."""

    kind: ClassVar[int] = PHASE["FOURNIER_FORAND"]
    blender: ClassVar[str] = "FOURNIER_FORAND"

    def __init__(self, n, v, c):
        self.n, self.v, self.c = n, v, c

    @classmethod
    def of(cls, backscatter, ior) -> "FournierForand":
        """From the node's Backscatter and IOR (floats or (n,)), clamped as volume_fournier_forand_setup: B =
        min(|B|, 1/2 - 1e-3), IOR >= 1 + 1e-3."""
        B = np.minimum(np.abs(np.asarray(backscatter, np.float64)), 0.5 - 1e-3)
        n = np.maximum(np.asarray(ior, np.float64), 1.0 + 1e-3)
        d90, d180 = ff_delta(n, 0.5), ff_delta(n, 1.0)
        v = -np.log(2.0 * B * (d90 - 1.0) + 1.0) / np.log(d90)
        return cls(n, v, (d180 ** -v - 1.0) / (d180 - 1.0))

    def _parts(self, cos_theta):
        """delta, delta^v, sin^2(theta/2) (n,) at cos theta (n,)."""
        h = 0.5 * (1.0 - cos_theta)
        delta = ff_delta(self.n, h)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return delta, delta ** self.v, h

    def _pf(self, cos_theta, delta, pow_delta_v, h):
        """Cycles' phase_fournier_forand_impl: p (n,) from the parts (the Taylor form where |1 - delta| < 1e-3)."""
        v = np.asarray(self.v, np.float64)
        m_delta, m_pow = 1.0 - delta, 1.0 - pow_delta_v
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            near = (v * ((v - 1.0) - (v + 1.0) / h) / (8.0 * np.pi)
                    + v * (v + 1.0) * m_delta * (2.0 * (v - 1.0) - (2.0 * v + 1.0) / h) / (24.0 * np.pi))
            far = (v * m_delta - m_pow + (delta * m_pow - v * m_delta) / h) / (4.0 * np.pi * m_delta ** 2 * pow_delta_v)
        pf = np.where(np.abs(m_delta) < 1e-3, near, far)
        return pf + np.asarray(self.c, np.float64) / (16.0 * np.pi) * (3.0 * cos_theta * cos_theta - 1.0)

    def eval_cos(self, cos_theta):
        """Cycles' phase_fournier_forand: 0 where |cos theta| >= 1 (theta = 0 is its pole)."""
        cos_theta = np.asarray(cos_theta, np.float64)
        inside = np.abs(cos_theta) < 1.0
        safe = np.where(inside, cos_theta, 0.0)
        return np.where(inside, self._pf(safe, *self._parts(safe)), 0.0)

    def sample_cos(self, u0):
        """Newton's method on the cdf (the share scattered by less than theta) from 50 degrees, 20 steps at most,
        never stepping past cos theta = 1 (Cycles' phase_fournier_forand_newton), all rows at once; never at 1 (the
        float just below it instead)."""
        n = len(u0)
        v, c = _rows(self.v, n), _rows(self.c, n)
        cos_theta = np.full(n, 0.64278760968)
        going = np.ones(n, bool)
        for _ in range(20):
            if not going.any():
                break
            x = cos_theta[going]
            part = FournierForand(_rows(self.n, n)[going], v[going], c[going])
            delta, pow_delta_v, h = part._parts(x)
            m_delta, m_pow = 1.0 - delta, 1.0 - pow_delta_v
            vg = v[going]
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                cdf = np.where(np.abs(m_delta) < 1e-3, 1.0 + vg * (1.0 - h) * (1.0 - 0.5 * (vg + 1.0) * m_delta),
                               (1.0 - pow_delta_v * delta - m_pow * h) / (m_delta * pow_delta_v))
                cdf = cdf + c[going] / 8.0 * x * (1.0 - x * x)
                step = x + (cdf - u0[going]) / (2.0 * np.pi * part._pf(x, delta, pow_delta_v, h))
            step = np.where(step >= 1.0, np.maximum(0.5 * (x + 1.0), 0.99), step)
            done = (np.abs(x - step) < 1e-6) | (step == 1.0)
            rows = np.flatnonzero(going)
            cos_theta[rows] = step
            going[rows[done]] = False
        return np.minimum(cos_theta, np.nextafter(1.0, 0.0))     # (its pole: Cycles' pdf 0 there, a lost sample)

    def parameters(self, n):
        """[n, v, c, 0] per row."""
        out = np.zeros((n, PHASE_PARAMETERS))
        out[:, 0], out[:, 1], out[:, 2] = _rows(self.n, n), _rows(self.v, n), _rows(self.c, n)
        return out

    def mean_cosine(self, n=1):
        """<cos theta> by quadrature (cos_quadrature; no closed form): 2 pi times the integral of p cos over cos."""
        x, w = cos_quadrature()
        out = np.empty(n)
        params = self.parameters(n)
        for i in range(n):
            one = FournierForand(*params[i, :3])
            out[i] = 2.0 * np.pi * np.sum(w * x * one.eval_cos(x))
        return out


class Draine(Phase):
    """Draine's phase function of anisotropy g (|g| < 1) and alpha (>= 0), floats or (n,) float64."""

    kind: ClassVar[int] = PHASE["DRAINE"]
    blender: ClassVar[str] = "DRAINE"

    def __init__(self, g, alpha):
        self.g, self.alpha = g, alpha

    def eval_cos(self, cos_theta):
        """Cycles' phase_draine: Rayleigh where |g| < 1e-3 and alpha > 0.999, HG where |alpha| < 1e-3."""
        g, a = np.asarray(self.g, np.float64), np.asarray(self.alpha, np.float64)
        fac = 1.0 + g * g - 2.0 * g * cos_theta
        with np.errstate(divide="ignore", invalid="ignore"):
            p = ((1.0 - g * g) * (1.0 + a * cos_theta * cos_theta)
                 / ((1.0 + a * (1.0 + 2.0 * g * g) / 3.0) * 4.0 * np.pi * fac * np.sqrt(fac)))
        p = np.where(np.abs(a) < 1e-3, HenyeyGreenstein(g).eval_cos(cos_theta), p)
        return np.where((np.abs(g) < 1e-3) & (a > 0.999), rayleigh(cos_theta), p)

    def sample_cos(self, u0):
        """The cdf's closed-form inverse (Jendersie and d'Eon's, as Cycles' phase_draine_sample_cos; the cube root
        form where |g| < 1e-2), Rayleigh's and HG's in their special cases."""
        n = len(u0)
        g, a = _rows(self.g, n), _rows(self.alpha, n)
        out = np.empty(n)
        is_rayleigh = (np.abs(g) < 1e-3) & (a > 0.999)
        is_hg = ~is_rayleigh & (np.abs(a) < 1e-3)
        small = ~is_rayleigh & ~is_hg & (np.abs(g) < 1e-2)
        full = ~is_rayleigh & ~is_hg & ~small
        out[is_rayleigh] = Rayleigh().sample_cos(u0[is_rayleigh])
        out[is_hg] = HenyeyGreenstein(g[is_hg]).sample_cos(u0[is_hg])
        if small.any():
            ia, x = 1.0 / a[small], u0[small]
            b2 = (3.0 + a[small]) * ia * (0.5 - x)
            inv_u = -1.0 / np.cbrt(b2 + np.sqrt(b2 * b2 + ia * ia * ia))
            out[small] = 1.0 / inv_u - inv_u / a[small]
        if full.any():
            out[full] = draine_sample_cos(g[full], a[full], u0[full])
        return out

    def parameters(self, n):
        """[g, alpha, 0, 0] per row."""
        out = np.zeros((n, PHASE_PARAMETERS))
        out[:, 0], out[:, 1] = _rows(self.g, n), _rows(self.alpha, n)
        return out

    def mean_cosine(self, n=1):
        """<cos theta> = g (1 + alpha (3 + 2 g^2) / 5) / (1 + alpha (1 + 2 g^2) / 3) (Draine 2003, eq. 6)."""
        g, a = _rows(self.g, n), _rows(self.alpha, n)
        return g * (1.0 + a * (3.0 + 2.0 * g * g) / 5.0) / (1.0 + a * (1.0 + 2.0 * g * g) / 3.0)


class Rayleigh(Phase):
    """Rayleigh's phase function, 3 (1 + cos^2 theta) / (16 pi): no numbers."""

    kind: ClassVar[int] = PHASE["RAYLEIGH"]
    blender: ClassVar[str] = "RAYLEIGH"

    def eval_cos(self, cos_theta):
        """3 (1 + cos^2 theta) / (16 pi)."""
        return rayleigh(np.asarray(cos_theta, np.float64))

    def sample_cos(self, u0):
        """The cdf's inverse by a cube root (Cycles' phase_rayleigh_sample): a = 2 - 4 u0, cos theta = 1/x - x with
        x = -(sqrt(1 + a^2) + a)^(-1/3)."""
        a = 2.0 - 4.0 * np.asarray(u0, np.float64)
        inv_u = -1.0 / np.cbrt(np.sqrt(1.0 + a * a) + a)
        return 1.0 / inv_u - inv_u

    def parameters(self, n):
        """No numbers: zeros."""
        return np.zeros((n, PHASE_PARAMETERS))

    def mean_cosine(self, n=1):
        """<cos theta> = 0 (symmetric forwards and backwards)."""
        return np.zeros(n)


class Mie(Phase):
    """Jendersie and d'Eon's fit of Mie scattering by water droplets: (1 - w) HG(g_HG) + w Draine(g_D, alpha), each
    a float or (n,) float64; `of(diameter)` fits them from the droplet diameter in micrometres."""

    kind: ClassVar[int] = PHASE["MIE"]
    blender: ClassVar[str] = "MIE"

    def __init__(self, g_hg, g_d, alpha, w):
        self.g_hg, self.g_d, self.alpha, self.w = g_hg, g_d, alpha, w

    @classmethod
    def of(cls, diameter) -> "Mie":
        """The mixture of diameter d (float or (n,)): mie_parameters, the lobes' anisotropies clamped as Cycles'
        HG and Draine setups clamp them."""
        g_hg, g_d, alpha, w = mie_parameters(diameter)
        return cls(clamp_g(g_hg), clamp_g(g_d), alpha, w)

    def _lobes(self):
        """The HG and Draine lobes."""
        return HenyeyGreenstein(self.g_hg), Draine(self.g_d, self.alpha)

    def eval_cos(self, cos_theta):
        """(1 - w) HG + w Draine."""
        hg, draine = self._lobes()
        w = np.asarray(self.w, np.float64)
        return (1.0 - w) * hg.eval_cos(cos_theta) + w * draine.eval_cos(cos_theta)

    def sample_cos(self, u0):
        """Draine's lobe where u0 < w (u0 / w its number), HG's otherwise ((u0 - w) / (1 - w)): Cycles picks one
        of its two closures by their weights the same way."""
        n = len(u0)
        g_hg, g_d, a, w = (_rows(x, n) for x in (self.g_hg, self.g_d, self.alpha, self.w))
        pick = u0 < w
        out = np.empty(n)
        with np.errstate(divide="ignore", invalid="ignore"):
            out[pick] = Draine(g_d[pick], a[pick]).sample_cos(u0[pick] / w[pick])
            out[~pick] = HenyeyGreenstein(g_hg[~pick]).sample_cos(
                np.minimum((u0[~pick] - w[~pick]) / (1.0 - w[~pick]), 1.0))
        return out

    def parameters(self, n):
        """[g_HG, g_D, alpha, w] per row."""
        return np.stack([_rows(x, n) for x in (self.g_hg, self.g_d, self.alpha, self.w)], axis=1)

    def mean_cosine(self, n=1):
        """(1 - w) g_HG + w <cos theta> of the Draine lobe."""
        w = _rows(self.w, n)
        return (1.0 - w) * _rows(self.g_hg, n) + w * Draine(self.g_d, self.alpha).mean_cosine(n)


PHASES = (HenyeyGreenstein, FournierForand, Draine, Rayleigh, Mie)
PHASE_BY_BLENDER = {cls.blender: cls for cls in PHASES}


def of_node(phase: str, inputs: dict) -> Phase:
    """The phase function a Volume Scatter or Volume Coefficients node sets up from its Phase menu identifier and
    constant inputs (keys anisotropy, ior, backscatter, alpha, diameter), as Cycles'
    svm_alloc_closure_volume_scatter."""
    get = lambda key, default: float(np.mean(inputs.get(key, default)))            # noqa: E731
    if phase == "FOURNIER_FORAND":
        return FournierForand.of(get("backscatter", 0.1), get("ior", 1.33))
    if phase == "DRAINE":
        return Draine(float(clamp_g(get("anisotropy", 0.0))), get("alpha", 0.5))
    if phase == "RAYLEIGH":
        return Rayleigh()
    if phase == "MIE":
        return Mie.of(get("diameter", 20.0))
    return HenyeyGreenstein(float(clamp_g(get("anisotropy", 0.0))))


def parameters_at(kind: int, anisotropy, ior, backscatter, alpha, diameter) -> np.ndarray:
    """The numbers (n, PHASE_PARAMETERS) float64 of phase function `kind` set up at n points from a closure's inputs
    there ((n,) float64 each), as of_node sets them up from constants (Cycles' svm_alloc_closure_volume_scatter runs
    at every shading point; C: phase.c phase_setup)."""
    n = len(anisotropy)
    if kind == PHASE["FOURNIER_FORAND"]:
        return FournierForand.of(backscatter, ior).parameters(n)
    if kind == PHASE["DRAINE"]:
        return Draine(clamp_g(anisotropy), np.asarray(alpha, np.float64)).parameters(n)
    if kind == PHASE["RAYLEIGH"]:
        return Rayleigh().parameters(n)
    if kind == PHASE["MIE"]:
        return Mie.of(diameter).parameters(n)
    return HenyeyGreenstein(clamp_g(anisotropy)).parameters(n)


def phase_of(kind: int, parameters: np.ndarray) -> Phase:
    """The phase function of one kind and its numbers (n, PHASE_PARAMETERS) (Phase.parameters' inverse)."""
    p = np.asarray(parameters, np.float64).reshape(-1, PHASE_PARAMETERS)
    if kind == PHASE["FOURNIER_FORAND"]:
        return FournierForand(p[:, 0], p[:, 1], p[:, 2])
    if kind == PHASE["DRAINE"]:
        return Draine(p[:, 0], p[:, 1])
    if kind == PHASE["RAYLEIGH"]:
        return Rayleigh()
    if kind == PHASE["MIE"]:
        return Mie(p[:, 0], p[:, 1], p[:, 2], p[:, 3])
    return HenyeyGreenstein(p[:, 0])


class Phases:
    """n rows of phase functions of mixed kinds: kind (n,) int64 and parameters (n, PHASE_PARAMETERS) float64 (HG's
    first number its anisotropy), evaluated and sampled kind by kind."""

    def __init__(self, kind: np.ndarray, parameters: np.ndarray):
        self.kind = np.asarray(kind, np.int64)
        self.parameters = np.asarray(parameters, np.float64).reshape(-1, PHASE_PARAMETERS)

    @classmethod
    def henyey_greenstein(cls, g: np.ndarray) -> "Phases":
        """Rows of HG of anisotropies g (n,)."""
        g = np.asarray(g, np.float64).reshape(-1)
        return cls(np.zeros(len(g), np.int64), HenyeyGreenstein(g).parameters(len(g)))

    def rows(self, index) -> "Phases":
        """The rows `index`."""
        return Phases(self.kind[index], self.parameters[index])

    def _each(self, f, n: int, width: int = 0) -> np.ndarray:
        """f(phase, rows) per kind present, its results scattered back into (n,) or (n, width)."""
        out = np.zeros((n, width) if width else n)
        for kind in np.unique(self.kind):
            rows = np.flatnonzero(self.kind == kind)
            out[rows] = f(phase_of(int(kind), self.parameters[rows]), rows)
        return out

    def eval(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """p(wo, wi) (n,) float64 row by row (as Phase.eval)."""
        return self._each(lambda phase, rows: phase.eval(wo[rows], wi[rows]), len(self.kind))

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """The pdf of `sample` choosing wi: p itself."""
        return self.eval(wo, wi)

    def sample(self, wo: np.ndarray, u: np.ndarray) -> PhaseSample:
        """Directions wi (n, 3) and pdf (n,) row by row (as Phase.sample)."""
        n = len(self.kind)
        wi, pdf = np.zeros((n, 3)), np.zeros(n)
        for kind in np.unique(self.kind):
            rows = np.flatnonzero(self.kind == kind)
            ps = phase_of(int(kind), self.parameters[rows]).sample(wo[rows], u[rows])
            wi[rows], pdf[rows] = ps.wi, ps.pdf
        return PhaseSample(wi, pdf)


class PhaseMix(Phases):
    """n scattering points' mixtures of up to PHASE_LOBES phase functions, as Cycles keeps each volume closure at a
    point: kinds (n, L) int64, lobes (n, L, PHASE_PARAMETERS) float64, weights (n, L) float64 (each closure's sigma_s
    summed over channels; 0: no lobe, after the others). eval is the weight-averaged p (Cycles'
    _volume_shader_phase_eval_mis: light samples weigh by it); sample picks one lobe by weight
    (volume_shader_phase_pick, its number u[:, 0] rescaled) and returns that lobe's pdf (Cycles' phase ray:
    eval / pdf 1, its MIS pdf that lobe's). C: phase.c's Phase with `lobes` set. kind and parameters: the first
    lobe's."""

    def __init__(self, kinds: np.ndarray, lobes: np.ndarray, weights: np.ndarray):
        self.kinds = np.asarray(kinds, np.int64)
        self.lobes = np.asarray(lobes, np.float64)
        self.weights = np.asarray(weights, np.float64)
        super().__init__(self.kinds[:, 0], self.lobes[:, 0])

    def rows(self, index) -> "PhaseMix":
        """The rows `index`."""
        return PhaseMix(self.kinds[index], self.lobes[index], self.weights[index])

    def eval(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """sum of w p / sum of w (n,), lobe by lobe in order (as phase.c's phase_eval)."""
        n = len(self.kinds)
        total, weighted = np.zeros(n), np.zeros(n)
        for lobe in range(self.kinds.shape[1]):
            w = self.weights[:, lobe]
            some = np.flatnonzero(w > 0.0)
            if len(some):
                p = Phases(self.kinds[some, lobe], self.lobes[some, lobe]).eval(wo[some], wi[some])
                weighted[some] = weighted[some] + p * w[some]
                total[some] = total[some] + w[some]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(total > 0.0, weighted / np.where(total > 0.0, total, 1.0), 0.0)

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """The light samples' pdf of the phase ray: the mixture's (Cycles' _volume_shader_phase_eval_mis)."""
        return self.eval(wo, wi)

    def sample(self, wo: np.ndarray, u: np.ndarray) -> PhaseSample:
        """A lobe picked by weight (u[:, 0] rescaled as Cycles' volume_shader_phase_pick), sampled: wi (n, 3) and
        that lobe's pdf (n,)."""
        n, L = self.kinds.shape
        x = np.array(u[:, 0], np.float64)
        picked = np.zeros(n, np.int64)
        total = self.weights[:, 0].copy()
        for lobe in range(1, L):
            w = self.weights[:, lobe]
            total = total + w
            with np.errstate(invalid="ignore", divide="ignore"):
                threshold = np.where(total > 0.0, w / np.where(total > 0.0, total, 1.0), 0.0)
                below = x < threshold
                x = np.where(below, x / np.where(below, threshold, 1.0), (x - threshold) / (1.0 - threshold))
            picked = np.where(below, lobe, picked)
        rows = np.arange(n)
        one = Phases(self.kinds[rows, picked], self.lobes[rows, picked])
        return one.sample(wo, np.stack([x, u[:, 1]], axis=1))


def henyey_greenstein(cos_theta: np.ndarray, g) -> np.ndarray:
    """(1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^1.5) (n,) float64."""
    denom = 1.0 + g * g - 2.0 * g * cos_theta
    return (1.0 - g * g) / (4.0 * np.pi * denom * np.sqrt(denom))


def rayleigh(cos_theta: np.ndarray) -> np.ndarray:
    """3 (1 + cos^2 theta) / (16 pi) (n,) float64."""
    return (0.1875 / np.pi) * (1.0 + cos_theta * cos_theta)


def ff_delta(n, sin_half_sqr):
    """Fournier-Forand's delta = 4 sin^2(theta/2) / (3 (n - 1)^2)."""
    return 4.0 * np.asarray(sin_half_sqr, np.float64) / (3.0 * (np.asarray(n, np.float64) - 1.0) ** 2)


def draine_sample_cos(g: np.ndarray, a: np.ndarray, u0: np.ndarray) -> np.ndarray:
    """Draine's cdf inverted in closed form (the roots of its quartic, as the paper's HLSL and Cycles'
    phase_draine_sample_cos write them), for |g| >= 1e-2, alpha > 0: cos theta (n,)."""
    g2 = g * g
    g3, g4 = g * g2, g2 * g2
    g6 = g2 * g4
    t1a = a * (g4 - 1.0)
    t2 = -1296.0 * (g2 - 1.0) * (a - a * g2) * t1a * (4.0 * g2 + a * (1.0 + g2) ** 2)
    t9 = 2.0 + g2 + g3 * (1.0 + 2.0 * g2) * (2.0 * u0 - 1.0)
    t3 = 3.0 * g2 * (1.0 + g * (2.0 * u0 - 1.0)) + a * t9
    t4a = 432.0 * t1a ** 3 + t2 + 432.0 * (a * (1.0 - g2)) * t3 * t3
    t10 = a * (2.0 * g4 - g2 - g6)
    t4b = 144.0 * t10
    with np.errstate(invalid="ignore", divide="ignore"):
        t4 = t4a + np.sqrt(-4.0 * t4b ** 3 + t4a * t4a)
        inv_t4p3 = 1.0 / np.cbrt(t4)
        cbrt2 = 2.0 ** (1.0 / 3.0)
        t6 = (2.0 * t1a + 48.0 * cbrt2 * t10 * inv_t4p3 + 1.0 / (3.0 * cbrt2 * inv_t4p3)) / (a * (1.0 - g2))
        t5 = 6.0 * (1.0 + g2) + t6
        t7 = 6.0 * (1.0 + g2) - (8.0 * t3) / (a * (g2 - 1.0) * np.sqrt(t5)) - t6
        return (1.0 + g2 - 0.25 * (np.sqrt(t7) - np.sqrt(t5)) ** 2) / (2.0 * g)


def mie_parameters(diameter) -> tuple:
    """Jendersie and d'Eon's fit of water droplets' Mie scattering from the diameter d (micrometres, float or (n,)):
    (g_HG, g_D, alpha, w) float64 each, in four ranges of d (their supplement's eqs. 7-22, as Cycles'
    phase_mie_fitted_parameters; exact sin, cos, log and exp where Cycles uses its fast approximations)."""
    d = np.maximum(np.asarray(diameter, np.float64), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_d = np.log(d)
        log_log = np.log(log_d)
        # d <= 0.1 (eqs. 11-14)
        tiny = (13.8 * d * d, 1.1456 * d * np.sin(9.29044 * d), np.full_like(d, 250.0), 0.252977 - 312.983 * d ** 4.3)
        # 0.1 < d < 1.5 (eqs. 15-18)
        a = (log_d - 0.238604) * (log_d + 1.00667)
        b = 0.507522 - 0.15677 * log_d
        c = 1.19692 * np.cos(a / b) + 1.37932 * log_d + 0.0625835
        small = (0.862 - 0.143 * log_d * log_d, 0.379685 * np.cos(c) + 0.344213, np.full_like(d, 250.0),
                 0.146209 * np.cos(3.38707 * log_d + 2.11193) + 0.316072 + 0.0778917 * log_d)
        # 1.5 <= d < 5 (eqs. 19-22)
        mid = (0.0604931 * log_log + 0.940256, 0.500411 - 0.081287 / (-2.0 * log_d + np.tan(log_d) + 1.27551),
               7.30354 * log_d + 6.31675,
               0.026914 * (log_d - np.cos(5.68947 * (log_log - 0.0292149))) + 0.3764)
        # d >= 5 (eqs. 7-10)
        large = (np.exp(-0.0990567 / (d - 1.67154)), np.exp(-2.20679 / (d + 3.91029) - 0.428934),
                 np.exp(3.62489 - 8.29288 / (d + 5.52825)), np.exp(-0.599085 / (d - 0.641583) - 0.665888))
    ranges = [d <= 0.1, (d > 0.1) & (d < 1.5), (d >= 1.5) & (d < 5.0)]
    return tuple(np.select(ranges, [tiny[i], small[i], mid[i]], large[i]) for i in range(4))


def cos_quadrature(n: int = 512) -> tuple:
    """Nodes x and weights (n,) float64 of a quadrature over cos theta in [-1, 1] that resolves a forward pole:
    Gauss-Legendre in s = log((1 - cos theta) / 2) over [-60, 0] (FF's pole at cos theta = 1 is integrable; what
    lies within 1e-26 of it is left out), cached."""
    if n not in _QUADRATURE:
        t, w = np.polynomial.legendre.leggauss(n)
        s = 30.0 * (t - 1.0)
        _QUADRATURE[n] = (1.0 - 2.0 * np.exp(s), 30.0 * w * 2.0 * np.exp(s))
    return _QUADRATURE[n]


_QUADRATURE: dict = {}


PhaseRowsArgs = schema.function("primer_phase_rows", "phase_rows", schema.record(
    "PhaseRowsArgs", "primer_phase_rows' arguments: Phases.eval and Phases.sample for n rows (phase.c).", [
        ("n", schema.I64, ""),
        ("kind", schema.ptr(schema.I64), "(n,) each row's PHASE_..."),
        ("parameters", schema.ptr(schema.F64), "(n, PHASE_PARAMETERS)"),
        ("wo", schema.ptr(schema.F64), "(n, 3) unit, towards the viewer"),
        ("wi", schema.ptr(schema.F64), "(n, 3) unit, towards the light: where eval is taken"),
        ("u", schema.ptr(schema.F64), "(n, 2) unit-square numbers for sample"),
        ("eval", schema.out(schema.F64), "(n,) p(wo, wi)"),
        ("sampled", schema.out(schema.F64), "(n, 3) the sampled directions"),
        ("pdf", schema.out(schema.F64), "(n,) their pdf"),
    ]))


def compiled_rows(phases: Phases, wo: np.ndarray, wi: np.ndarray, u: np.ndarray) -> tuple:
    """phase.c's phase_eval at (wo, wi) and phase_sample from u for each row of `phases` (n rows; wo, wi (n, 3),
    u (n, 2)): (eval (n,), PhaseSample), to hold against Phases.eval and Phases.sample."""
    from ..native import library
    n = len(phases.kind)
    out_eval, sampled, pdf = np.empty(n), np.empty((n, 3)), np.empty(n)
    library.call("primer_phase_rows", PhaseRowsArgs(
        n=n, kind=library.contiguous(phases.kind, np.int64),
        parameters=library.contiguous(phases.parameters, np.float64),
        wo=library.contiguous(wo, np.float64), wi=library.contiguous(wi, np.float64),
        u=library.contiguous(u, np.float64), eval=out_eval, sampled=sampled, pdf=pdf))
    return out_eval, PhaseSample(sampled, pdf)
