"""Sample clamping, as Cycles' Light Paths > Clamping: a cap on what one sample may add to a pixel.

A path that finds a small bright light through a rough bounce by chance brings back a huge value with a
tiny probability: a "firefly". Clamping caps each contribution, trading that noise for a bias (the
image gets darker where clamping bites; converged, it is no longer the right answer).

Cycles' rule, which Primer follows: each contribution c (RGB, throughput included) whose channel sum
|c_r| + |c_g| + |c_b| exceeds a limit is scaled down to that sum. The limit is 3 x the value in the UI,
so a grey contribution is clamped at the UI value per channel. "Direct" contributions use Clamp Direct:
what the camera sees itself (emission, the world, lamps) and the light a camera hit gathers (its light
samples, and the light its BSDF ray finds); every contribution after the first bounce uses Clamp
Indirect. A value of 0 switches clamping off (Primer's default: the unbiased image; Cycles' default Clamp
Indirect is 10).

Where the two renderers differ: the cap applies to each contribution an estimator makes, and Primer's are
not all Cycles' (Primer samples every lamp at each vertex, Cycles picks one lamp per sample and divides
by the chance of that pick). Primer clamps each light sample as the one-sample estimate it stands for
(its value x the light's samples per hit). Where the cap bites, the two images differ by how much their
estimators' contributions exceed it (docs/lecture.md, "Caustics switches and clamping").
"""
from __future__ import annotations

import numpy as np


def limits(settings) -> tuple:
    """(direct, indirect) caps on a contribution's channel sum: 3 x the settings' values, inf where 0 (off)."""
    def cap(value: float) -> float:
        return 3.0 * float(value) if value > 0.0 else np.inf
    return cap(settings.sample_clamp_direct), cap(settings.sample_clamp_indirect)


def scale(value: np.ndarray, throughput, limit, count=1.0) -> np.ndarray:
    """The factor (k,) that caps each contribution: min(1, limit / sum |throughput x value x count|).

    value: (k, 3) what a vertex gathers (before its path's throughput); throughput: (k, 3) or None (1);
    limit: scalar or (k,) caps (inf: none); count: the samples that one estimate was divided among (a light
    sample stands for value x count)."""
    contribution = value * count if throughput is None else value * throughput * count
    total = np.abs(contribution).sum(axis=1)
    return np.where(total > limit, np.asarray(limit, np.float64) / np.where(total > 0.0, total, 1.0), 1.0)


def clamped(value: np.ndarray, throughput, limit, count=1.0) -> np.ndarray:
    """value (k, 3) with each row capped as `scale` says."""
    return value * scale(value, throughput, limit, count)[:, None]
