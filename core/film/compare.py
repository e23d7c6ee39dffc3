"""How far an image is from a reference: the project's error measure, shared by tests, tools and the bench.

The relative MSE of block means: average each image over blocks of block x block pixels (B), then
mean((B(P) - B(C))^2 / (B(C)^2 + 0.01)) over the blocks' RGB. Averaging blocks keeps the measure about
the picture rather than per-pixel noise; the 0.01 keeps dark blocks from dominating. For scale, Cycles at
256 samples against its own 512 scores about 1e-4 or less.
"""
from __future__ import annotations

import numpy as np


def block_means(image: np.ndarray, block: int = 4) -> np.ndarray:
    """The RGB means (h // block, w // block, 3) float64 of an image (H, W, >=3), its edge rows and columns
    that do not fill a block left out."""
    h, w = image.shape[0] // block * block, image.shape[1] // block * block
    rgb = np.asarray(image[:h, :w, :3], np.float64)
    return rgb.reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))


def relative_mse_of_blocks(image: np.ndarray, reference: np.ndarray, block: int = 4) -> float:
    """mean((B(P) - B(C))^2 / (B(C)^2 + 0.01)) of `image` P against `reference` C, both (H, W, >=3)."""
    P, C = block_means(image, block), block_means(reference, block)
    return float(np.mean((P - C) ** 2 / (C * C + 0.01)))
