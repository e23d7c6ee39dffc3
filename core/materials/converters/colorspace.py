"""The scene-linear colour space Cycles converts into (scene/shader.cpp init_xyz_transforms) with Blender's default
OpenColorIO configuration, whose scene linear is Linear Rec.709 and which has an ACES interchange role.

Cycles then takes CIE XYZ (D65) -> scene linear as (ACES2065-1 -> scene linear, from the configuration) x (the inverse
of its own 6-digit ACES AP0 -> XYZ D65 matrix). The configuration's ACES -> scene linear is its XYZ D65 -> Linear
Rec.709 matrix after OpenColorIO's built-in ACES AP0 -> XYZ D65 (Bradford-adapted from the ACES white), which this
module derives from the primaries; the two AP0 matrices differ in their 7th digit, so XYZ_TO_RGB is the configuration's
matrix to within 5e-7. The luminance of a colour (Cycles' rgb_to_y: RGB to BW, a colour read as a float) is the Y row of
its inverse.
"""
from __future__ import annotations

import numpy as np

# CIE XYZ (D65) -> Linear Rec.709, as Blender's config.ocio writes it (colorspace "Linear Rec.709").
XYZ_D65_TO_REC709 = np.array([[3.2409699, -1.5373832, -0.4986108],
                              [-0.9692436, 1.8759675, 0.0415551],
                              [0.0556301, -0.2039770, 1.0569715]])
# Cycles' ACES AP0 -> XYZ D65 (scene/shader.cpp), rounded to 6 digits.
ACES_TO_XYZ_ROUNDED = np.array([[0.938280, -0.004451, 0.016628],
                                [0.337369, 0.729522, -0.066890],
                                [0.001174, -0.003711, 1.091595]])
ACES_PRIMARIES = ((0.7347, 0.2653), (0.0, 1.0), (0.0001, -0.0770))
ACES_WHITE, D65_WHITE = (0.32168, 0.33767), (0.3127, 0.3290)
BRADFORD = np.array([[0.8951, 0.2664, -0.1614], [-0.7502, 1.7135, 0.0367], [0.0389, -0.0685, 1.0296]])


def xyz_of(xy: tuple) -> np.ndarray:
    """The XYZ (Y = 1) of a chromaticity (x, y)."""
    x, y = xy
    return np.array([x / y, 1.0, (1.0 - x - y) / y])


def aces_to_xyz_d65() -> np.ndarray:
    """OpenColorIO's ACES AP0 -> CIE XYZ D65 (its built-in "_BFD"): the primaries' RGB -> XYZ for the ACES white,
    then Bradford's adaptation of the ACES white to D65."""
    primaries = np.stack([xyz_of(p) for p in ACES_PRIMARIES], axis=1)
    to_xyz = primaries * np.linalg.solve(primaries, xyz_of(ACES_WHITE))
    cone_from, cone_to = BRADFORD @ xyz_of(ACES_WHITE), BRADFORD @ xyz_of(D65_WHITE)
    return np.linalg.inv(BRADFORD) @ np.diag(cone_to / cone_from) @ BRADFORD @ to_xyz


# Cycles' xyz_to_r, xyz_to_g, xyz_to_b (rows) and rgb_to_y.
XYZ_TO_RGB = XYZ_D65_TO_REC709 @ aces_to_xyz_d65() @ np.linalg.inv(ACES_TO_XYZ_ROUNDED)
RGB_TO_Y = np.linalg.inv(XYZ_TO_RGB)[1]
