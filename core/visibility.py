"""Ray Visibility: the kinds of rays an object may hide from, as bits, and the holdout and shadow catcher flags.

They are WorldGeometry.instance_hidden's bits (core/geometry), a light sample's `hidden` (core/lights), the
integrators' ray kinds (core/integrators/direct.py ray_kind) and C's HIDDEN_FROM_* (generated from these by
tools/make_boundary.py); they sit here, below every part, because geometry, lights and integrators all read them.
"""
from __future__ import annotations

from .native import schema

# The rays an object may hide from (WorldGeometry.instance_hidden bits): Object > Visibility > Ray Visibility. A
# ray of one kind passes the objects hidden from that kind as if they were not there. In the same flags: the object
# is a holdout (Object > Visibility > Holdout), a hole in the film for camera paths; it is a shadow catcher
# (Object > Visibility > Shadow Catcher, core/integrators/catcher.py).
(HIDDEN_FROM_CAMERA, HIDDEN_FROM_SHADOW, HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION,
 HOLDOUT, SHADOW_CATCHER, HIDDEN_FROM_VOLUME_SCATTER) = (
    schema.constant(name, value, "the rays an object hides from (Ray Visibility), the holdout and shadow catcher flags")
    for name, value in (("HIDDEN_FROM_CAMERA", 1), ("HIDDEN_FROM_SHADOW", 2), ("HIDDEN_FROM_DIFFUSE", 4),
                        ("HIDDEN_FROM_GLOSSY", 8), ("HIDDEN_FROM_TRANSMISSION", 16), ("HOLDOUT", 32),
                        ("SHADOW_CATCHER", 64), ("HIDDEN_FROM_VOLUME_SCATTER", 128)))
# Every kind of ray: an object with all these bits is not there for any ray (the catcher-only scene of
# core/integrators/catcher.py hides every object that is not a shadow catcher so).
EVERY_RAY = (HIDDEN_FROM_CAMERA | HIDDEN_FROM_SHADOW | HIDDEN_FROM_DIFFUSE | HIDDEN_FROM_GLOSSY
             | HIDDEN_FROM_TRANSMISSION | HIDDEN_FROM_VOLUME_SCATTER)
# Ray Visibility's switches (Blender's object properties, the core Instance's fields of the same names) and the bit
# each sets when it is off.
RAY_VISIBILITY = (("visible_camera", HIDDEN_FROM_CAMERA), ("visible_shadow", HIDDEN_FROM_SHADOW),
                  ("visible_diffuse", HIDDEN_FROM_DIFFUSE), ("visible_glossy", HIDDEN_FROM_GLOSSY),
                  ("visible_transmission", HIDDEN_FROM_TRANSMISSION),
                  ("visible_volume_scatter", HIDDEN_FROM_VOLUME_SCATTER))


def hidden_bits(owner, names=tuple(name for name, _ in RAY_VISIBILITY)) -> int:
    """The HIDDEN_FROM_* bits of the Ray Visibility switches `names` that `owner` (a Blender object or a core
    Instance) has off (a switch it lacks counts as on)."""
    return sum(bit for name, bit in RAY_VISIBILITY if name in names and not getattr(owner, name, True))
