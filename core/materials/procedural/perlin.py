"""Cycles' Perlin noise and its fractals (kernel/svm/noise.h, fractal_noise.h) in float32, on numpy arrays.

Perlin's gradient noise in 1 to 4 dimensions: each lattice corner's gradient is picked by hash_uint2..4 of its
integer coordinates (Cycles' lookup3 hashes, hash.py), dotted with the offset to the point, and blended with the
quintic fade 6t^5 - 15t^4 + 10t^3, as a + t (b - a) along x, then y, z (4D: along w first, then x, y, z), the order
Cycles' x86 kernels (SSE and AVX2) use. `snoise` wraps the point every 100000 (as Cycles, to keep float precision)
and scales the result to about [-1, 1] with the OSL constants. The fractals sum octaves at frequencies x lacunarity
and amplitudes x roughness (fBM, multifractal, hybrid and ridged multifractal, heterogeneous terrain), the
fractional detail blending in a last octave. Points are (n, d) float32 arrays; everything stays float32 as in
Cycles (perlin.h is the C twin, operation for operation).
"""
from __future__ import annotations

import numpy as np

from . import hash as hash_

F32 = np.float32
# The OSL scale of each dimension's Perlin noise to about [-1, 1].
SCALES = {1: F32(0.25), 2: F32(0.6616), 3: F32(0.9820), 4: F32(0.8344)}
# The fractals by Cycles' NodeNoiseType number (Blender's noise_type names).
NOISE_TYPES = ("MULTIFRACTAL", "FBM", "HYBRID_MULTIFRACTAL", "RIDGED_MULTIFRACTAL", "HETERO_TERRAIN")


def fade(t: np.ndarray) -> np.ndarray:
    """Perlin's quintic 6t^5 - 15t^4 + 10t^3 (float32), as Cycles' fade."""
    return t * t * t * (t * (t * F32(6.0) - F32(15.0)) + F32(10.0))


def lerp(a, b, t) -> np.ndarray:
    """Cycles' mix: a + t (b - a)."""
    return a + t * (b - a)


def negate_if(value: np.ndarray, condition: np.ndarray) -> np.ndarray:
    """-value where condition is non-zero."""
    return np.where(condition != 0, -value, value)


def gradient(h: np.ndarray, f: list) -> np.ndarray:
    """The dot product of the gradient picked by hash h (uint32) with the offset f (d arrays): Cycles' grad1..4."""
    d = len(f)
    if d == 1:
        h = h & 15
        g = F32(1.0) + (h & 7).astype(F32)
        return negate_if(g, h & 8) * f[0]
    if d == 2:
        h = h & 7
        u = np.where(h < 4, f[0], f[1])
        v = F32(2.0) * np.where(h < 4, f[1], f[0])
        return negate_if(u, h & 1) + negate_if(v, h & 2)
    if d == 3:
        h = h & 15
        u = np.where(h < 8, f[0], f[1])
        vt = np.where((h == 12) | (h == 14), f[0], f[2])
        v = np.where(h < 4, f[1], vt)
        return negate_if(u, h & 1) + negate_if(v, h & 2)
    h = h & 31
    u = np.where(h < 24, f[0], f[1])
    v = np.where(h < 16, f[1], f[2])
    s = np.where(h < 8, f[2], f[3])
    return negate_if(u, h & 1) + negate_if(v, h & 2) + negate_if(s, h & 4)


HASHES = {1: hash_.hash_uint, 2: hash_.hash_uint2, 3: hash_.hash_uint3, 4: hash_.hash_uint4}


def perlin(p: np.ndarray) -> np.ndarray:
    """Cycles' perlin_1d .. perlin_4d at points p (n, d) float32: (n,) float32."""
    d = p.shape[1]
    floor = np.floor(p)
    cell = floor.astype(np.int32).astype(np.int64)              # Cycles' float_to_int of the floor
    frac = p - floor
    faded = fade(frac)

    def corner(offset: tuple) -> np.ndarray:
        """The gradient's dot product at the lattice corner cell + offset (d zeros and ones)."""
        h = HASHES[d](*(cell[:, k] + offset[k] for k in range(d)))
        return gradient(h, [frac[:, k] - F32(offset[k]) if offset[k] else frac[:, k] for k in range(d)])

    def blend(axes: list, fixed: dict) -> np.ndarray:
        """The corners' values blended along `axes` in order, the other axes' offsets `fixed`."""
        if not axes:
            return corner(tuple(fixed[k] for k in range(d)))
        axis, rest = axes[0], axes[1:]
        # The first axis blended is the innermost: blend the remaining axes at each end of this one, then this one.
        low = blend(rest, {**fixed, axis: 0})
        high = blend(rest, {**fixed, axis: 1})
        return lerp(low, high, faded[:, axis])

    # Cycles blends along x first (innermost), then y, z; in 4D along w first, then x, y, z.
    order = [0, 1, 2][:d] if d < 4 else [3, 0, 1, 2]
    return blend(order[::-1], {})


def snoise(p: np.ndarray) -> np.ndarray:
    """Cycles' snoise_1d .. 4d: the point wrapped every 100000 (with half a cell added from 1e6 on), the Perlin
    noise scaled to about [-1, 1]. p (n, d) float32 -> (n,) float32."""
    correction = np.where(np.abs(p) >= F32(1000000.0), F32(0.5), F32(0.0)).astype(F32)
    q = np.fmod(p, F32(100000.0)) + correction
    return SCALES[p.shape[1]] * perlin(q)


def fbm(p, detail, roughness, lacunarity, normalize: bool) -> np.ndarray:
    """Cycles' noise_fbm: octaves of snoise summed, amplitude x roughness and frequency x lacunarity each, the
    fractional detail blending a last octave in; normalized to [0, 1] by the amplitudes' sum when asked."""
    n = len(p)
    fscale, amp = np.ones(n, F32), np.ones(n, F32)
    maxamp, total = np.zeros(n, F32), np.zeros(n, F32)
    octaves = detail.astype(np.int32)
    for i in range(int(octaves.max(initial=0)) + 1):
        on = i <= octaves
        t = snoise(fscale[:, None] * p)
        total = np.where(on, total + t * amp, total)
        maxamp = np.where(on, maxamp + amp, maxamp)
        amp = np.where(on, amp * roughness, amp)
        fscale = np.where(on, fscale * lacunarity, fscale)
    rmd = detail - np.floor(detail)
    t = snoise(fscale[:, None] * p)
    total2 = total + t * amp
    with np.errstate(divide="ignore", invalid="ignore"):
        if normalize:
            partial = lerp(F32(0.5) * total / maxamp + F32(0.5), F32(0.5) * total2 / (maxamp + amp) + F32(0.5), rmd)
            whole = F32(0.5) * total / maxamp + F32(0.5)
        else:
            partial, whole = lerp(total, total2, rmd), total
    return np.where(rmd != 0.0, partial, whole)


def multifractal(p, detail, roughness, lacunarity) -> np.ndarray:
    """Cycles' noise_multi_fractal: the product of (amplitude x snoise + 1) over the octaves."""
    n = len(p)
    value, pwr = np.ones(n, F32), np.ones(n, F32)
    octaves = detail.astype(np.int32)
    for i in range(int(octaves.max(initial=0)) + 1):
        on = i <= octaves
        value = np.where(on, value * (pwr * snoise(p) + F32(1.0)), value)
        pwr = np.where(on, pwr * roughness, pwr)
        p = np.where(on[:, None], p * lacunarity[:, None], p)
    rmd = detail - np.floor(detail)
    return np.where(rmd != 0.0, value * (rmd * pwr * snoise(p) + F32(1.0)), value)


def hetero_terrain(p, detail, roughness, lacunarity, offset) -> np.ndarray:
    """Cycles' noise_hetero_terrain: each octave's (snoise + offset) x amplitude scaled by the value so far."""
    pwr = roughness.copy()
    value = offset + snoise(p)
    p = p * lacunarity[:, None]
    octaves = detail.astype(np.int32)
    for i in range(1, int(octaves.max(initial=0)) + 1):
        on = i <= octaves
        increment = (snoise(p) + offset) * pwr * value
        value = np.where(on, value + increment, value)
        pwr = np.where(on, pwr * roughness, pwr)
        p = np.where(on[:, None], p * lacunarity[:, None], p)
    rmd = detail - np.floor(detail)
    increment = (snoise(p) + offset) * pwr * value
    return np.where(rmd != 0.0, value + rmd * increment, value)


def hybrid_multifractal(p, detail, roughness, lacunarity, offset, gain) -> np.ndarray:
    """Cycles' noise_hybrid_multi_fractal: octaves weighted by gain x the previous signal, until the weight is
    0.001 or less."""
    n = len(p)
    pwr, value, weight = np.ones(n, F32), np.zeros(n, F32), np.ones(n, F32)
    octaves = detail.astype(np.int32)
    for i in range(int(octaves.max(initial=0)) + 1):
        on = (weight > F32(0.001)) & (i <= octaves)
        weight = np.where(on, np.minimum(weight, F32(1.0)), weight)
        signal = (snoise(p) + offset) * pwr
        pwr = np.where(on, pwr * roughness, pwr)
        value = np.where(on, value + weight * signal, value)
        weight = np.where(on, weight * (gain * signal), weight)
        p = np.where(on[:, None], p * lacunarity[:, None], p)
    rmd = detail - np.floor(detail)
    last = (rmd != 0.0) & (weight > F32(0.001))
    weight = np.minimum(weight, F32(1.0))
    signal = (snoise(p) + offset) * pwr
    return np.where(last, value + rmd * weight * signal, value)


def ridged_multifractal(p, detail, roughness, lacunarity, offset, gain) -> np.ndarray:
    """Cycles' noise_ridged_multi_fractal: octaves of (offset - |snoise|)^2, each weighted by the previous signal x
    gain (clamped to [0, 1]); the fractional detail is not used."""
    pwr = roughness.copy()
    signal = offset - np.abs(snoise(p))
    signal = signal * signal
    value = signal.copy()
    octaves = detail.astype(np.int32)
    for i in range(1, int(octaves.max(initial=0)) + 1):
        on = i <= octaves
        p = np.where(on[:, None], p * lacunarity[:, None], p)
        weight = np.clip(signal * gain, F32(0.0), F32(1.0))
        s = offset - np.abs(snoise(p))
        s = s * s * weight
        signal = np.where(on, s, signal)
        value = np.where(on, value + s * pwr, value)
        pwr = np.where(on, pwr * roughness, pwr)
    return value


def fractal(kind: int, p, detail, roughness, lacunarity, offset, gain, normalize: bool) -> np.ndarray:
    """Cycles' noise_select: the fractal NOISE_TYPES[kind] at points p (n, d) float32, the rest (n,) float32."""
    name = NOISE_TYPES[kind]
    if name == "MULTIFRACTAL":
        return multifractal(p, detail, roughness, lacunarity)
    if name == "FBM":
        return fbm(p, detail, roughness, lacunarity, normalize)
    if name == "HYBRID_MULTIFRACTAL":
        return hybrid_multifractal(p, detail, roughness, lacunarity, offset, gain)
    if name == "RIDGED_MULTIFRACTAL":
        return ridged_multifractal(p, detail, roughness, lacunarity, offset, gain)
    return hetero_terrain(p, detail, roughness, lacunarity, offset)
