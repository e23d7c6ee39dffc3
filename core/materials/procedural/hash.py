"""Cycles' hash functions (util/hash.h), the randomness of its procedural textures, on uint32 arrays.

Bob Jenkins' lookup3 `final` (and, for four words, `mix` first) turns 1 to 4 words into one; a float's hash is the
hash of its bits; hashes become floats in [0, 1] by (float)h x 2^-32 in float32. The vector versions hash the same
components in other orders (or with 1.0 and 2.0 appended) for their other components. Every function takes numpy
arrays (or scalars) and works elementwise; the C twin is hash.h.
"""
from __future__ import annotations

import numpy as np

U32 = np.uint32
F32 = np.float32


def _u32(x) -> np.ndarray:
    """x as uint32 (integers wrap modulo 2^32, as C's conversion of an int to uint)."""
    return np.asarray(np.asarray(x, np.int64) & 0xFFFFFFFF, U32)


def _rot(x: np.ndarray, k: int) -> np.ndarray:
    """lookup3's rot: x rotated left by k bits."""
    return (x << U32(k)) | (x >> U32(32 - k))


def _final(a, b, c) -> np.ndarray:
    """lookup3's final mix of three words; returns c."""
    c = (c ^ b) - _rot(b, 14)
    a = (a ^ c) - _rot(c, 11)
    b = (b ^ a) - _rot(a, 25)
    c = (c ^ b) - _rot(b, 16)
    a = (a ^ c) - _rot(c, 4)
    b = (b ^ a) - _rot(a, 14)
    c = (c ^ b) - _rot(b, 24)
    return c


def _mix(a, b, c) -> tuple:
    """lookup3's mix of three words."""
    a = (a - c) ^ _rot(c, 4); c = c + b
    b = (b - a) ^ _rot(a, 6); a = a + c
    c = (c - b) ^ _rot(b, 8); b = b + a
    a = (a - c) ^ _rot(c, 16); c = c + b
    b = (b - a) ^ _rot(a, 19); a = a + c
    c = (c - b) ^ _rot(b, 4); b = b + a
    return a, b, c


def _start(words: int, shape) -> np.ndarray:
    """lookup3's initial value for `words` words: 0xdeadbeef + (words << 2) + 13."""
    return np.full(shape, (0xDEADBEEF + (words << 2) + 13) & 0xFFFFFFFF, U32)


def hash_uint(kx) -> np.ndarray:
    """Cycles' hash_uint: one word (uint32 or int, elementwise)."""
    kx = _u32(kx)
    a = _start(1, kx.shape)
    with np.errstate(over="ignore"):
        return _final(a + kx, a.copy(), a.copy())


def hash_uint2(kx, ky) -> np.ndarray:
    """Cycles' hash_uint2."""
    kx, ky = np.broadcast_arrays(_u32(kx), _u32(ky))
    a = _start(2, kx.shape)
    with np.errstate(over="ignore"):
        return _final(a + kx, a + ky, a.copy())


def hash_uint3(kx, ky, kz) -> np.ndarray:
    """Cycles' hash_uint3."""
    kx, ky, kz = np.broadcast_arrays(_u32(kx), _u32(ky), _u32(kz))
    a = _start(3, kx.shape)
    with np.errstate(over="ignore"):
        return _final(a + kx, a + ky, a + kz)


def hash_uint4(kx, ky, kz, kw) -> np.ndarray:
    """Cycles' hash_uint4: mix of the first three words, then final with the fourth added."""
    kx, ky, kz, kw = np.broadcast_arrays(_u32(kx), _u32(ky), _u32(kz), _u32(kw))
    a = _start(4, kx.shape)
    with np.errstate(over="ignore"):
        a, b, c = _mix(a + kx, a + ky, a + kz)
        return _final(a + kw, b, c)


def uint_to_float(h) -> np.ndarray:
    """Cycles' uint_to_float_incl: (float)h x (1 / (float)0xFFFFFFFF), float32 in [0, 1]."""
    return np.asarray(h, U32).astype(F32) * F32(1.0 / 4294967296.0)


def float_bits(x) -> np.ndarray:
    """A float32's bits as uint32 (Cycles' __float_as_uint)."""
    return np.array(x, F32).view(U32)


def hash_float(x) -> np.ndarray:
    """Cycles' hash_float_to_float: float32 in [0, 1]."""
    return uint_to_float(hash_uint(float_bits(x)))


def hash_float2(x, y) -> np.ndarray:
    """Cycles' hash_float2_to_float."""
    x, y = np.broadcast_arrays(np.asarray(x, F32), np.asarray(y, F32))
    return uint_to_float(hash_uint2(float_bits(x), float_bits(y)))


def hash_float3(x, y, z) -> np.ndarray:
    """Cycles' hash_float3_to_float."""
    x, y, z = np.broadcast_arrays(np.asarray(x, F32), np.asarray(y, F32), np.asarray(z, F32))
    return uint_to_float(hash_uint3(float_bits(x), float_bits(y), float_bits(z)))


def hash_float4(x, y, z, w) -> np.ndarray:
    """Cycles' hash_float4_to_float."""
    x, y, z, w = np.broadcast_arrays(*(np.asarray(v, F32) for v in (x, y, z, w)))
    return uint_to_float(hash_uint4(float_bits(x), float_bits(y), float_bits(z), float_bits(w)))


def hash_float_to_float3(w) -> np.ndarray:
    """Cycles' hash_float_to_float3: (n, 3) float32."""
    return np.stack([hash_float(w), hash_float2(w, 1.0), hash_float2(w, 2.0)], axis=-1)


def hash_float2_to_float3(x, y) -> np.ndarray:
    """Cycles' hash_float2_to_float3: (n, 3) float32."""
    return np.stack([hash_float2(x, y), hash_float3(x, y, 1.0), hash_float3(x, y, 2.0)], axis=-1)


def hash_float3_to_float3(x, y, z) -> np.ndarray:
    """Cycles' hash_float3_to_float3: (n, 3) float32."""
    return np.stack([hash_float3(x, y, z), hash_float4(x, y, z, 1.0), hash_float4(x, y, z, 2.0)], axis=-1)


def hash_float4_to_float3(x, y, z, w) -> np.ndarray:
    """Cycles' hash_float4_to_float3: (n, 3) float32 (the words in the orders xyzw, zxwy, wzyx)."""
    return np.stack([hash_float4(x, y, z, w), hash_float4(z, x, w, y), hash_float4(w, z, y, x)], axis=-1)


def _i32(x: np.ndarray) -> np.ndarray:
    """uint32 bits read as int32."""
    return x.view(np.int32)


def hash_pcg(k: np.ndarray) -> np.ndarray:
    """Cycles' hash_pcg2d_i .. hash_pcg4d_i (PCG, "Hash Functions for GPU Rendering", signed so that OSL has it too):
    k (n, d) integers, d 2 to 4 -> (n, d) int64 in [0, 2^31). The arithmetic wraps at 32 bits; the shift by 16 is
    an arithmetic (sign-extending) shift of the signed words."""
    v = [_u32(k[:, j]).copy() for j in range(k.shape[1])]
    d = len(v)
    with np.errstate(over="ignore"):
        v = [x * U32(1664525) + U32(1013904223) for x in v]

        def rounds(v):
            if d == 2:
                v[0] = v[0] + v[1] * U32(1664525)
                v[1] = v[1] + v[0] * U32(1664525)
            elif d == 3:
                v[0] = v[0] + v[1] * v[2]
                v[1] = v[1] + v[2] * v[0]
                v[2] = v[2] + v[0] * v[1]
            else:
                v[0] = v[0] + v[1] * v[3]
                v[1] = v[1] + v[2] * v[0]
                v[2] = v[2] + v[0] * v[1]
                v[3] = v[3] + v[1] * v[2]
            return v

        v = rounds(v)
        v = [x ^ (_i32(x) >> np.int32(16)).view(U32) for x in v]
        v = rounds(v)
    return np.stack([(x & U32(0x7FFFFFFF)).astype(np.int64) for x in v], axis=1)


def hash_int_to_float(k: np.ndarray) -> np.ndarray:
    """Cycles' hash_int2_to_float2 .. hash_int4_to_float4: (n, d) float32 in [0, 1], (float)h x 2^-31."""
    return hash_pcg(k).astype(np.uint32).astype(F32) * F32(1.0 / 2147483648.0)


def hash_int_to_float3(k: np.ndarray) -> np.ndarray:
    """Cycles' hash_int2_to_float3 (the 3D hash of (x, y, 0)), hash_int3_to_float3, hash_int4_to_float3 (the first
    three of the 4D hash): (n, 3) float32."""
    if k.shape[1] == 2:
        k = np.concatenate([k, np.zeros((len(k), 1), k.dtype)], axis=1)
    return hash_int_to_float(k)[:, :3]
