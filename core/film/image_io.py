"""Image files: scene-linear float EXR, or sRGB-encoded 8-bit PNG, through OpenImageIO."""
from __future__ import annotations

import os

import numpy as np


def linear_to_srgb(linear: np.ndarray) -> np.ndarray:
    """Return the sRGB encoding (IEC 61966-2-1) of scene-linear values, clamped to 0..1."""
    x = np.clip(np.nan_to_num(linear), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_to_linear(encoded: np.ndarray) -> np.ndarray:
    """Return scene-linear values of sRGB-encoded ones in 0..1."""
    x = np.asarray(encoded, np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def write_image(path: str, rgba: np.ndarray) -> None:
    """Write a (H, W, 4) scene-linear image, row 0 at the top.

    .exr: linear 32-bit float; .png and other 8-bit formats: sRGB-encoded, alpha kept linear.
    """
    import OpenImageIO as oiio

    rgba = np.asarray(rgba, np.float32)
    height, width, channels = rgba.shape
    ext = os.path.splitext(path)[1].lower()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    if ext == ".exr":
        spec = oiio.ImageSpec(width, height, channels, oiio.FLOAT)
        pixels = rgba
    else:
        spec = oiio.ImageSpec(width, height, channels, oiio.UINT8)
        encoded = rgba.astype(np.float64).copy()
        encoded[..., :3] = linear_to_srgb(encoded[..., :3])
        encoded[..., 3:] = np.clip(encoded[..., 3:], 0.0, 1.0)
        pixels = np.round(encoded * 255.0).astype(np.uint8)
    out = oiio.ImageOutput.create(path)
    if out is None:
        raise OSError(f"cannot write {path}: {oiio.geterror()}")
    try:
        if not out.open(path, spec) or not out.write_image(pixels):
            raise OSError(f"cannot write {path}: {out.geterror()}")
    finally:
        out.close()


def read_image(path: str) -> np.ndarray:
    """Read an image as float32 (H, W, C), row 0 at the top; 8-bit files are decoded from sRGB to linear."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(f"cannot read {path}: {oiio.geterror()}")
    try:
        spec = inp.spec()
        pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
    finally:
        inp.close()
    pixels = np.asarray(pixels, np.float32).reshape(spec.height, spec.width, spec.nchannels)
    if spec.format != oiio.FLOAT and spec.format != oiio.HALF:
        pixels = pixels.copy()
        pixels[..., :3] = srgb_to_linear(pixels[..., :3])
    return pixels
