"""The scene-linear colour space Cycles converts into (scene/shader.cpp init_xyz_transforms) with Blender's default
OpenColorIO configuration: scene linear is Linear Rec.709, whose matrix from CIE XYZ (D65) the configuration gives;
the luminance of a colour (Cycles' rgb_to_y, the RGB to BW node) is the Y row of its inverse."""
from __future__ import annotations

import numpy as np

# CIE XYZ (D65) -> Linear Rec.709, as Blender's config.ocio writes it (colorspace "Linear Rec.709").
XYZ_TO_RGB = np.array([[3.2409699, -1.5373832, -0.4986108],
                       [-0.9692436, 1.8759675, 0.0415551],
                       [0.0556301, -0.2039770, 1.0569715]])
# Cycles' rgb_to_y: the Y row of RGB -> XYZ.
RGB_TO_Y = np.linalg.inv(XYZ_TO_RGB)[1]
