"""Ray Visibility: the kinds of rays an object may hide from, as bits, and the holdout flag.

They are WorldGeometry.instance_hidden's bits (core/geometry), a light sample's `hidden` (core/lights), the
integrators' ray kinds (core/integrators/direct.py ray_kind) and C's HIDDEN_FROM_* (generated from these by
tools/make_boundary.py); they sit here, below every part, because geometry, lights and integrators all read them.
"""
from __future__ import annotations

from .native import schema

# The rays an object may hide from (WorldGeometry.instance_hidden bits): Object > Visibility > Ray Visibility. A
# ray of one kind passes the objects hidden from that kind as if they were not there. In the same flags: the object
# is a holdout (Object > Visibility > Holdout), a hole in the film for camera paths.
(HIDDEN_FROM_CAMERA, HIDDEN_FROM_SHADOW, HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION,
 HOLDOUT) = (schema.constant(name, value, "the rays an object hides from (Ray Visibility), and the holdout flag")
             for name, value in (("HIDDEN_FROM_CAMERA", 1), ("HIDDEN_FROM_SHADOW", 2), ("HIDDEN_FROM_DIFFUSE", 4),
                                 ("HIDDEN_FROM_GLOSSY", 8), ("HIDDEN_FROM_TRANSMISSION", 16), ("HOLDOUT", 32)))
