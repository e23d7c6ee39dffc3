"""A file made for Cycles renders with its own settings: which of Primer's render settings follow `scene.cycles`.

Render > Settings (`scene.primer.settings_source`) chooses where Primer's render settings that Cycles also has come
from: samples, noise threshold and min samples, adaptive sampling, seed and animated seed, the bounce limits, Min
Light Bounces, clamping and caustics (FOLLOWED: Primer's name -> Cycles'), and the integrator:

  CYCLES     the scene's Cycles settings (Render > Sampling, Light Paths of Cycles), and path tracing, as Cycles
             renders: switching the engine keeps the image;
  PRIMER     Primer's own (scene.primer), as its panels show them: the lecture's integrators and switches;
  AUTOMATIC  (the default) Cycles' for a scene where none of those Primer settings was ever set (a file made for
             Cycles, or a new one), Primer's own once one was (a file saved with Primer's settings, a script that
             sets scene.primer.samples). The environment variable PRIMER_SETTINGS_SOURCE (CYCLES or PRIMER) decides
             for Automatic instead, for scripts and test suites that configure scene.primer piecemeal.

Following Cycles also turns Primer's Shadow Terminator Fix on where some object has a Shadow Terminator offset
(export._cycles_terminator: Cycles lifts the shadow rays of smooth meshes by each object's Geometry Offset, 0.1 by
default, and bends shading by its Shading Offset; with the fix on Primer does the same, object by object).
The rest of Primer's settings (Light Samples, Viewport Samples, Denoise, shadow offsets, the other lecture
switches, threads, kernels) are Primer's own in every case; the pixel filter is always Cycles' (export.pixel_filter). What
Cycles would do with a followed scene that Primer does not (Cycles' Denoise) is said by unmodelled.render_notes.
"""
from __future__ import annotations

import os

# Primer's setting -> Cycles' setting of the same meaning.
FOLLOWED = {
    "samples": "samples", "seed": "seed", "animate_seed": "use_animated_seed",
    "use_adaptive_sampling": "use_adaptive_sampling", "adaptive_threshold": "adaptive_threshold",
    "adaptive_min_samples": "adaptive_min_samples",
    "max_bounces": "max_bounces", "diffuse_bounces": "diffuse_bounces", "glossy_bounces": "glossy_bounces",
    "transmission_bounces": "transmission_bounces", "transparent_bounces": "transparent_max_bounces",
    "volume_bounces": "volume_bounces",
    "min_light_bounces": "min_light_bounces",
    "caustics_reflective": "caustics_reflective", "caustics_refractive": "caustics_refractive",
    "filter_glossy": "blur_glossy",
    "sample_clamp_direct": "sample_clamp_direct", "sample_clamp_indirect": "sample_clamp_indirect",
}
# Primer's settings whose being set makes Automatic choose Primer's own: the followed ones and the integrator.
OWN_MARKS = (*FOLLOWED, "integrator")
ENVIRONMENT = "PRIMER_SETTINGS_SOURCE"


def follows_cycles(scene) -> bool:
    """Whether `scene` renders with its Cycles settings (the module docstring's rule)."""
    props = scene.primer
    cycles = getattr(scene, "cycles", None)
    if cycles is None:
        return False                                 # no Cycles add-on: nothing to follow
    source = props.settings_source
    if source == "AUTOMATIC":
        source = os.environ.get(ENVIRONMENT, "AUTOMATIC").upper()
    if source == "AUTOMATIC":
        return not any(props.is_property_set(name) for name in OWN_MARKS)
    return source == "CYCLES"


class Effective:
    """Primer's settings as a render reads them: scene.primer's, with FOLLOWED read from scene.cycles (and path
    tracing) where the scene follows Cycles."""

    def __init__(self, scene):
        """Read `scene`'s choice once."""
        self._props = scene.primer
        self._cycles = scene.cycles if follows_cycles(scene) else None

    @property
    def follows_cycles(self) -> bool:
        """Whether the followed settings come from scene.cycles."""
        return self._cycles is not None

    def __getattr__(self, name: str):
        """The setting `name`: Cycles' where followed, else Primer's own."""
        if self._cycles is not None:
            if name in FOLLOWED:
                return getattr(self._cycles, FOLLOWED[name])
            if name == "integrator":
                return "PATH"
        return getattr(self._props, name)


def effective(scene) -> Effective:
    """Return the settings `scene` renders with (Effective)."""
    return Effective(scene)
