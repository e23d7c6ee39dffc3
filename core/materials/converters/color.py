"""Cycles' colour models (util/color.h rgb_to_hsv, hsv_to_rgb, rgb_to_hsl, hsl_to_rgb) in float32, for Separate and
Combine Color (color.h is the C twin)."""
from __future__ import annotations

import numpy as np

from .base import F32

COLOR_MODES = ("RGB", "HSV", "HSL")
ZERO, ONE = F32(0.0), F32(1.0)


def rgb_to_hsv(c: np.ndarray) -> np.ndarray:
    """Cycles' rgb_to_hsv of (n, 3) float32."""
    cmax, cmin = c.max(axis=1), c.min(axis=1)
    delta = cmax - cmin
    with np.errstate(all="ignore"):
        s = np.where(cmax != ZERO, delta / np.where(cmax != ZERO, cmax, ONE), ZERO).astype(F32)
        d = np.where(s != ZERO, delta, ONE)[:, None]
        k = (cmax[:, None] - c) / d
    h = np.where(c[:, 0] == cmax, k[:, 2] - k[:, 1],
                 np.where(c[:, 1] == cmax, F32(2.0) + k[:, 0] - k[:, 2], F32(4.0) + k[:, 1] - k[:, 0])) / F32(6.0)
    h = np.where(h < ZERO, h + ONE, h)
    return np.stack([np.where(s != ZERO, h, ZERO), s, cmax], axis=1).astype(F32)


def hsv_to_rgb(hsv: np.ndarray) -> np.ndarray:
    """Cycles' hsv_to_rgb of (n, 3) float32."""
    h, s, v = hsv[:, 0], hsv[:, 1], hsv[:, 2]
    h = np.where(h == ONE, ZERO, h) * F32(6.0)
    i = np.floor(h)
    f = h - i
    p, q, t = v * (ONE - s), v * (ONE - s * f), v * (ONE - s * (ONE - f))
    choices = [np.stack(x, axis=1) for x in ((v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q))]
    out = choices[5]
    for k in range(4, -1, -1):
        out = np.where((i == k)[:, None], choices[k], out)
    return np.where((s != ZERO)[:, None], out, np.stack([v, v, v], axis=1)).astype(F32)


def rgb_to_hsl(c: np.ndarray) -> np.ndarray:
    """Cycles' rgb_to_hsl of (n, 3) float32."""
    cmax, cmin = c.max(axis=1), c.min(axis=1)
    l = np.minimum(ONE, (cmax + cmin) / F32(2.0))                      # noqa: E741
    grey = cmax == cmin
    delta = np.where(grey, ONE, cmax - cmin)
    with np.errstate(all="ignore"):
        s = np.where(l > F32(0.5), delta / (F32(2.0) - cmax - cmin), delta / (cmax + cmin))
        h = np.where(cmax == c[:, 0], (c[:, 1] - c[:, 2]) / delta + np.where(c[:, 1] < c[:, 2], F32(6.0), ZERO),
                     np.where(cmax == c[:, 1], (c[:, 2] - c[:, 0]) / delta + F32(2.0),
                              (c[:, 0] - c[:, 1]) / delta + F32(4.0)))
    h, s = np.where(grey, ZERO, h), np.where(grey, ZERO, s)
    return np.stack([h / F32(6.0), s, l], axis=1).astype(F32)


def hsl_to_rgb(hsl: np.ndarray) -> np.ndarray:
    """Cycles' hsl_to_rgb of (n, 3) float32."""
    h, s, l = hsl[:, 0], hsl[:, 1], hsl[:, 2]                         # noqa: E741
    h6 = h * F32(6.0)
    nr = np.clip(np.abs(h6 - F32(3.0)) - ONE, ZERO, ONE)
    ng = np.clip(F32(2.0) - np.abs(h6 - F32(2.0)), ZERO, ONE)
    nb = np.clip(F32(2.0) - np.abs(h6 - F32(4.0)), ZERO, ONE)
    chroma = (ONE - np.abs(F32(2.0) * l - ONE)) * s
    half = F32(0.5)
    return np.stack([(nr - half) * chroma + l, (ng - half) * chroma + l, (nb - half) * chroma + l], axis=1).astype(F32)

