"""Thin-film iridescence: the Fresnel reflectance of a dielectric coated by a film a few hundred nm thick.

Soap bubbles, oil on water and coated lenses shimmer in colours because light reflected at the film's top
face and light reflected at its bottom face interfere. The film's reflectance at one wavelength lambda is
the Airy sum over the waves that bounce m times inside it; with the amplitude coefficients r12 (ambient to
film, index n_f relative to the ambient) and r23 (film to substrate, index n_s),

    R(lambda) = |r12 + t12 t21 r23 e^(i phi) / (1 - r21 r23 e^(i phi))|^2,
    phi = 2 pi OPD / lambda + (phase flips at the faces),  OPD = 2 n_f d cos(theta_2)

(d the thickness in nm, theta_2 the angle inside the film, OPD the optical path difference). Belcour and
Barla (2017, "A practical extension to microfacet theory for the modeling of varying iridescence") write
it as a Fourier series in phi,

    R = C0 + 2 sum_m C_m cos(m phi_faces) S(m OPD),
    C0 = R12 + Rs,  C_m = (Rs - T121) (R12 R23)^(m/2),  Rs = T121^2 R23 / (1 - R12 R23),  T121 = 1 - R12,

so that an RGB renderer's mean over the spectrum weighed by a channel's colour-matching function only needs
that channel's sensitivity S(OPD) to an optical path difference (tools/thin_film_table.py computes it into
core/materials/thin_film_table.h). The faces of a dielectric only flip the phase (cos = +1 or -1: the sign
of r), each polarisation (s, p) gets its own sum, and the result is their mean; as Cycles, the sum stops at
m = 3 (the next terms are below (R12 R23)^2) and a film under 1 nm fades to none by moving its index to the
ambient's. Total internal reflection at either face reflects everything.

The Principled BSDF puts the film over its specular layer and its glass (Cycles' fresnel_iridescence with
the Generalized Schlick Fresnel): the film's reflectance is then scaled towards F0 x Specular Tint / F0
where it lies near the plain curve's F0 (`fresnel`), the artist's control of the specular colour and level.
Since Cycles 5.0 the film also covers the Principled's metal (`metal`): the metal's complex index n + ik is
estimated from its F0 and F82 colours, the film-to-metal face shifts the phase by any angle, and each term
of the series takes the complex sensitivity (the table's imaginary part too). core/materials/thin_film.c
is the compiled twin.
"""
from __future__ import annotations

import os
import re

import numpy as np

HEADER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "thin_film_table.h")
# A film thinner than this (nm) is no film: the Fresnel stays the plain one (Cycles' THINFILM_THICKNESS_CUTOFF).
THICKNESS_CUTOFF = 0.1


def _read():
    """(S (3, size), S_IM (3, size) float64, OPD_MAX nm): the header's sensitivity tables (real and imaginary
    parts) and the optical path difference at their last entry."""
    with open(HEADER) as handle:
        text = handle.read()
    size = int(re.search(r"#define THIN_FILM_TABLE_SIZE (\d+)", text).group(1))
    opd_max = float(re.search(r"#define THIN_FILM_OPD_MAX ([0-9.eE+-]+)", text).group(1))
    tables = []
    for name in ("THIN_FILM_S", "THIN_FILM_S_IM"):
        body = re.search(name + r"\[\d+\] = \{(.*?)\};", text, re.S).group(1)
        tables.append(np.array([float(x) for x in body.split(",") if x.strip()]).reshape(3, size))
    return tables[0], tables[1], opd_max


SENSITIVITY, SENSITIVITY_IM, OPD_MAX = _read()


def _lookup(table: np.ndarray, opd: np.ndarray) -> np.ndarray:
    """table (3, size) at optical path differences opd (m,) nm: (m, 3), linearly interpolated, clamped to the
    last entry beyond OPD_MAX (Cycles' lookup_table_read)."""
    size = table.shape[1]
    x = np.clip(np.nan_to_num(np.asarray(opd, np.float64) / OPD_MAX), 0.0, 1.0) * (size - 1)
    i = np.minimum(x.astype(np.int64), size - 1)
    j = np.minimum(i + 1, size - 1)
    t = (x - i)[:, None]
    return (1.0 - t) * table[:, i].T + t * table[:, j].T


def sensitivity(opd: np.ndarray) -> np.ndarray:
    """The R, G, B sensitivities (m, 3) to optical path differences opd (m,) nm (the table's real part)."""
    return _lookup(SENSITIVITY, opd)


def sensitivity_imaginary(opd: np.ndarray) -> np.ndarray:
    """The imaginary parts (m, 3) of the sensitivities at opd (m,) nm (films on metal)."""
    return _lookup(SENSITIVITY_IM, opd)


def polarized(cos_i: np.ndarray, eta: np.ndarray) -> tuple:
    """Fresnel at a dielectric face of relative index eta (m,) met at cos_i (m,) >= 0: (R_s, R_p, cos_t,
    sign_s, sign_p, tir), the s and p reflectances, the cosine behind the face, the signs (+1 or -1) of the
    amplitude coefficients r_s and r_p (the phase flip), and where light is totally reflected (m,) bool."""
    sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta)
    tir = sin_t2 >= 1.0
    cos_t = np.sqrt(np.maximum(1.0 - sin_t2, 0.0))
    r_s = (cos_i - eta * cos_t) / np.maximum(cos_i + eta * cos_t, 1e-300)
    r_p = (eta * cos_i - cos_t) / np.maximum(eta * cos_i + cos_t, 1e-300)
    return r_s * r_s, r_p * r_p, cos_t, np.where(r_s >= 0.0, 1.0, -1.0), np.where(r_p >= 0.0, 1.0, -1.0), tir


def airy(R12: np.ndarray, R23: np.ndarray, phasor: np.ndarray, opd: np.ndarray) -> np.ndarray:
    """One polarisation's reflectance (m, 3) of a film between faces of reflectances R12, R23 (m,) whose phase
    flips multiply to phasor (m,) (+1 or -1), its optical path difference opd (m,) nm: Belcour and Barla's
    series to m = 3 (module docstring)."""
    T121 = 1.0 - R12
    R123 = R12 * R23
    r123 = np.sqrt(R123)
    Rs = T121 * T121 * R23 / np.maximum(1.0 - R123, 1e-300)
    R = np.repeat((R12 + Rs)[:, None], 3, axis=1)
    Cm, turn = Rs - T121, phasor.copy()
    for m in range(1, 4):
        Cm = Cm * r123
        R += (2.0 * Cm * turn)[:, None] * sensitivity(m * opd)
        turn = turn * phasor
    return R


def iridescence(cos_i: np.ndarray, eta: np.ndarray, thickness: np.ndarray, film_ior: np.ndarray) -> np.ndarray:
    """Reflectance (m, 3) in 0..1 of a substrate of index eta (m,) under a film `thickness` (m,) nm thick of
    index film_ior (m,), both relative to the ambient medium, for light arriving at cos_i (m,)."""
    cos_i = np.abs(np.asarray(cos_i, np.float64))
    eta, thickness = np.asarray(eta, np.float64), np.asarray(thickness, np.float64)
    film = np.asarray(film_ior, np.float64)
    # Below 1 nm the film fades out: its index moves to the ambient's (1) along a smoothstep.
    x = np.clip(thickness, 0.0, 1.0)
    film = np.where(thickness < 1.0, 1.0 + (film - 1.0) * x * x * (3.0 - 2.0 * x), film)
    R12_s, R12_p, cos_2, sign12_s, sign12_p, tir12 = polarized(cos_i, film)
    R23_s, R23_p, _, sign23_s, sign23_p, tir23 = polarized(cos_2, eta / film)
    opd = 2.0 * film * thickness * cos_2
    # Light turning back inside the film flips its phase opposite to light reflected outside it (r21 = -r12).
    R_s = airy(R12_s, R23_s, -sign12_s * sign23_s, opd)
    R_p = airy(R12_p, R23_p, -sign12_p * sign23_p, opd)
    R = np.clip(0.5 * (R_s + R_p), 0.0, 1.0)
    return np.where((tir12 | tir23)[:, None], 1.0, R)


def conductor(cos_i: np.ndarray, film: np.ndarray, n: np.ndarray, k: np.ndarray, F82: np.ndarray) -> tuple:
    """A metal of index n + ik (m, 3) under a film of index film (m,), met inside the film at cos_i (m,):
    (R_s, R_p, phasor_s, phasor_p), the reflectances (m, 3), as the F82 curve through F82 (m, 3) that the
    metal's F0 relative to the film gives (Cycles' choice), and the phase shifts e^(i phi) (m, 3) complex of
    the exact amplitudes r_s = (a - w) / (a + w), r_p = (N^2 c - n1 w) / (N^2 c + n1 w), with a = n1 c and
    w = N cos_t = u + iv (Born and Wolf 14.4.1, with N = n + ik)."""
    c, n1 = cos_i[:, None], film[:, None]
    t1 = n * n - k * k - n1 * n1 * (1.0 - c * c)
    t2 = np.sqrt(t1 * t1 + (2.0 * n * k) ** 2)
    u2, v2 = np.maximum(0.5 * (t2 + t1), 0.0), np.maximum(0.5 * (t2 - t1), 0.0)
    u, v = np.sqrt(u2), np.sqrt(v2)
    # Reflectance: the F82 curve of F0 relative to the film, dipped to match F82 (as Cycles).
    n_rel, k_rel2 = n / n1, (k / n1) ** 2
    F0 = ((n_rel - 1.0) ** 2 + k_rel2) / ((n_rel + 1.0) ** 2 + k_rel2)
    f = 6.0 / 7.0
    f5 = f ** 5
    B = (7.0 / (f5 * f)) * (F0 + (1.0 - F0) * f5 - F82)
    s = np.clip(1.0 - c, 0.0, 1.0)
    s5 = s ** 5
    R = np.clip(F0 + (1.0 - F0) * s5 - B * (c * s5 * s), 0.0, 1.0)
    a = n1 * c
    re_s, im_s = a * a - u2 - v2, -2.0 * a * v
    N2_re, N2_im = n * n - k * k, 2.0 * n * k
    re_p = ((n * n + k * k) * c) ** 2 - n1 * n1 * (u2 + v2)
    im_p = 2.0 * a * (N2_im * u - N2_re * v)
    phasors = []
    for re, im in ((re_s, im_s), (re_p, im_p)):
        mag = np.sqrt(re * re + im * im)
        zero = mag == 0.0
        safe = np.where(zero, 1.0, mag)
        phasors.append(np.where(zero, 1.0, re / safe) + 1j * np.where(zero, 0.0, im / safe))
    return R, R, phasors[0], phasors[1]


def airy_complex(R12: np.ndarray, R23: np.ndarray, phasor: np.ndarray, opd: np.ndarray) -> np.ndarray:
    """`airy` for a face below the film that shifts the phase by any angle: R12 (m,), R23 (m, 3), phasor (m, 3)
    complex, opd (m,) nm -> (m, 3); each term is Re(phasor^m S*(m OPD)) with the table's complex sensitivities."""
    T121 = (1.0 - R12)[:, None]
    R123 = R12[:, None] * R23
    r123 = np.sqrt(R123)
    Rs = T121 * T121 * R23 / np.maximum(1.0 - R123, 1e-300)
    R = R12[:, None] + Rs
    Cm, turn = Rs - T121, phasor.copy()
    for m in range(1, 4):
        Cm = Cm * r123
        R += Cm * 2.0 * (turn.real * sensitivity(m * opd) + turn.imag * sensitivity_imaginary(m * opd))
        turn = turn * phasor
    return R


def metal(cos_i: np.ndarray, f0: np.ndarray, b: np.ndarray, thickness: np.ndarray,
          film_ior: np.ndarray) -> np.ndarray:
    """Reflectance (m, 3) in 0..1 of the Principled's metal (F82-tint: f0 and b (m, 3), microfacet.fresnel_f82)
    under a film `thickness` (m,) nm of index film_ior (m,), at cos_i (m,): the metal's n and k estimated from
    F0 and F82 (Gulbrandsen's artist-friendly mapping, as Cycles), the film's sum with `conductor`'s faces."""
    from . import microfacet as mf
    m = len(cos_i)
    cos_i = np.abs(np.asarray(cos_i, np.float64))
    thickness, film = np.asarray(thickness, np.float64), np.asarray(film_ior, np.float64)
    r = np.minimum(f0, 0.999)
    g = mf.fresnel_f82(np.full(m, 1.0 / 7.0), f0, b)
    root = np.sqrt(r)
    outer = (1.0 + root) / (1.0 - root)
    n = outer + ((1.0 - r) / (1.0 + r) - outer) * g
    k = np.sqrt(np.maximum((r * (n + 1.0) ** 2 - (n - 1.0) ** 2) / (1.0 - r), 0.0))
    x = np.clip(thickness, 0.0, 1.0)
    film = np.where(thickness < 1.0, 1.0 + (film - 1.0) * x * x * (3.0 - 2.0 * x), film)
    R12_s, R12_p, cos_2, sign12_s, sign12_p, tir12 = polarized(cos_i, film)
    R23_s, R23_p, phasor23_s, phasor23_p = conductor(cos_2, film, n, k, g)
    opd = 2.0 * film * thickness * cos_2
    R_s = airy_complex(R12_s, R23_s, phasor23_s * -sign12_s[:, None], opd)
    R_p = airy_complex(R12_p, R23_p, phasor23_p * -sign12_p[:, None], opd)
    return np.where(tir12[:, None], 1.0, np.clip(0.5 * (R_s + R_p), 0.0, 1.0))


def fresnel(cos_i: np.ndarray, eta: np.ndarray, f0: np.ndarray, thickness: np.ndarray,
            film_ior: np.ndarray) -> np.ndarray:
    """The Principled's iridescent Fresnel (m, 3) at cos_i (m,): `iridescence` scaled per channel by
    f0 / F0(eta) (f0 (m, 3): F0 x Specular Tint) in proportion to how close it lies to F0(eta) rather than 1
    (Cycles' Generalized Schlick with a thin film); unscaled where F0(eta) < 1e-5 or it reflects everything."""
    F = iridescence(cos_i, eta, thickness, film_ior)
    F0_real = ((eta - 1.0) / (eta + 1.0)) ** 2
    scale = (F0_real > 1e-5) & ~np.all(F == 1.0, axis=1)
    safe = np.where(scale, F0_real, 0.5)[:, None]
    s = np.clip((F - 1.0) / (safe - 1.0), 0.0, 1.0)
    scaled = F * (1.0 + (f0 / safe - 1.0) * s)
    return np.where(scale[:, None], scaled, F)
