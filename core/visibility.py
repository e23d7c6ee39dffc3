"""Ray Visibility: the kinds of rays an object may hide from, as bits, and the holdout flag.

They are WorldGeometry.instance_hidden's bits (core/geometry), a light sample's `hidden` (core/lights), the
integrators' ray kinds (core/integrators/direct.py ray_kind) and triangles.c's HIDDEN_FROM_* enum; they sit
here, below every part, because geometry, lights and integrators all read them.
"""
from __future__ import annotations

# The rays an object may hide from (WorldGeometry.instance_hidden bits; triangles.c HIDDEN_FROM_*): Object >
# Visibility > Ray Visibility. A ray of one kind passes the objects hidden from that kind as if they were not there.
HIDDEN_FROM_CAMERA, HIDDEN_FROM_SHADOW = 1, 2
HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION = 4, 8, 16
# In the same flags: the object is a holdout (Object > Visibility > Holdout), a hole in the film for camera paths.
HOLDOUT = 32
