"""Cycles' Blackbody node (kernel/svm/blackbody.h, svm_math_blackbody_color_rec709 and its fitted table in
kernel/tables.h), in float32."""
from __future__ import annotations

import numpy as np

from .base import F32, ConverterNode, as_f32

# Cycles' fit of the Rec.709 colour of a black body (normalised to luminance 1) over seven ranges of temperature:
# red and green a / T + b T + c, blue ((a T + b) T + c) T + d; the ranges start at these temperatures (K).
BLACKBODY_STARTS = np.array([800.0, 965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0], np.float32)
BLACKBODY_R = np.array([[1.61919106e+03, -2.05010916e-03, 5.02995757e+00],
                        [2.48845471e+03, -1.11330907e-03, 3.22621544e+00],
                        [3.34143193e+03, -4.86551192e-04, 1.76486769e+00],
                        [4.09461742e+03, -1.27446582e-04, 7.25731635e-01],
                        [4.67028036e+03, 2.91258199e-05, 1.26703442e-01],
                        [4.59509185e+03, 2.87495649e-05, 1.50345020e-01],
                        [3.78717450e+03, 9.35907826e-06, 3.99075871e-01]], np.float32)
BLACKBODY_G = np.array([[-4.88999748e+02, 6.04330754e-04, -7.55807526e-02],
                        [-7.55994277e+02, 3.16730098e-04, 4.78306139e-01],
                        [-1.02363977e+03, 1.20223470e-04, 9.36662319e-01],
                        [-1.26571316e+03, 4.87340896e-06, 1.27054498e+00],
                        [-1.42529332e+03, -4.01150431e-05, 1.43972784e+00],
                        [-1.17554822e+03, -2.16378048e-05, 1.30408023e+00],
                        [-5.00799571e+02, -4.59832026e-06, 1.09098763e+00]], np.float32)
BLACKBODY_B = np.array([[5.96945309e-11, -4.85742887e-08, -9.70622247e-05, -4.07936148e-03],
                        [2.40430366e-11, 5.55021075e-08, -1.98503712e-04, 2.89312858e-02],
                        [-1.40949732e-11, 1.89878968e-07, -3.56632824e-04, 9.10767778e-02],
                        [-3.61460868e-11, 2.84822009e-07, -4.93211319e-04, 1.56723440e-01],
                        [-1.97075738e-11, 1.75359352e-07, -2.50542825e-04, -2.22783266e-02],
                        [-1.61997957e-13, -1.64216008e-08, 3.86216271e-04, -7.38077418e-01],
                        [6.72650283e-13, -2.73078809e-08, 4.24098264e-04, -7.52335691e-01]], np.float32)
# Beyond the fit: the colour at 12000 K and above, and below 800 K (dim; the same as OSL's).
BLACKBODY_HOT = np.array([0.8262954810464208, 0.9945080501520986, 1.566307710274283], np.float32)
BLACKBODY_COLD = np.array([5.413294490189271, -0.20319390035873933, -0.0822535242887164], np.float32)


def blackbody(t: np.ndarray, clip: bool = True) -> np.ndarray:
    """(n, 3) float32 Rec.709 colour of temperatures t (n,) float32, negative channels clipped to 0 (the node's; the
    fit itself, negative outside Rec.709's gamut, with clip False: the Principled Volume's black body)."""
    i = np.clip(np.searchsorted(BLACKBODY_STARTS, t, side="right") - 1, 0, 6)
    r, g, b = BLACKBODY_R[i], BLACKBODY_G[i], BLACKBODY_B[i]
    with np.errstate(all="ignore"):
        inv = F32(1.0) / t
        out = np.stack([(r[:, 0] * inv + r[:, 1] * t) + r[:, 2], (g[:, 0] * inv + g[:, 1] * t) + g[:, 2],
                        ((b[:, 0] * t + b[:, 1]) * t + b[:, 2]) * t + b[:, 3]], axis=1)
    hot, cold = (t >= F32(12000.0))[:, None], (t < F32(800.0))[:, None]
    out = np.where(hot, BLACKBODY_HOT, np.where(cold, BLACKBODY_COLD, out))
    return np.maximum(out, F32(0.0)) if clip else out


class Blackbody(ConverterNode):
    """The colour of a black body at the Temperature (K) by Cycles' fit, luminance about 1 (6500 K near white);
    scene linear is Rec.709, so it is used as it is."""

    kind = "BLACKBODY"
    blender = "ShaderNodeBlackbody"
    c_name = "blackbody"
    inputs = (("Temperature", 1, 6500.0),)
    outputs = {"Color": (3, "color")}
    c_tables = {"BLACKBODY_STARTS": BLACKBODY_STARTS, "BLACKBODY_R": BLACKBODY_R, "BLACKBODY_G": BLACKBODY_G,
                "BLACKBODY_B": BLACKBODY_B, "BLACKBODY_HOT": BLACKBODY_HOT, "BLACKBODY_COLD": BLACKBODY_COLD}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """The colour (n, 3)."""
        return blackbody(as_f32(inputs[0])[:, 0]).astype(np.float64)
