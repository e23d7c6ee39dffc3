"""What every integrator does, and what it tells the one who listens (a Recorder).

An integrator turns camera rays into radiance: where does each ray hit, and how much light leaves
that point towards the camera? It combines the parts: the geometry answers where rays hit
(core/geometry), the lights give samples with their pdfs (core/lights), the materials evaluate and
sample BSDFs (core/materials). Each integrator has two implementations: a readable Python reference
here (vectorized over a batch of rays with numpy, in the lecture's symbols I, N, L, D, t) and its
compiled twin in C beside it, which the tests hold to the same numbers.

A Recorder listens to the reference as it decides: the ray inspector keeps every value for one
pixel, the debug views sum some of them per pixel. The integrator itself carries no debug code.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, NamedTuple, Optional

import numpy as np

from ..geometry.surface import Surface
from ..lights import LightSample
from ..materials import MaterialTable
from .shadows import ShadowRays


@dataclass
class Context:
    """What an integrator reads for every chunk of a render (made once per render).

    scene:     the Scene (its lights already moved into `lights`)
    settings:  the RenderSettings
    geometry:  the WorldGeometry, camera-relative
    lights:    the usable lights, camera-relative
    materials: the MaterialTable of the scene's materials
    light_numbers: None, or (k, 2) float64 one fixed unit-square point per light, used for every hit
               instead of the light's sample pattern (the ray inspector's sample at each light's centre)
    """

    scene: object
    settings: object
    geometry: object
    lights: list
    materials: MaterialTable
    light_numbers: Optional[np.ndarray] = None
    extra: dict = field(default_factory=dict)


class Cancelled(Exception):
    """The render was asked to stop (StopFlag set): raised inside a chunk's work, which is then dropped."""


class StopFlag:
    """Whether a render was asked to stop, for every chunk to read while it works: the Python reference checks it at
    each vertex and light (`check_stop`), the compiled chunk reads `flag` before each block of samples (chunk.c), so
    that a cancel is answered within a block's time, not a chunk's.

    flag: (1,) int32, 1 once set
    """

    def __init__(self):
        """A flag not set."""
        self.flag = np.zeros(1, np.int32)

    def set(self) -> None:
        """Ask every chunk to stop."""
        self.flag[0] = 1

    def __bool__(self) -> bool:
        return bool(self.flag[0])


def check_stop(ctx: "Context") -> None:
    """Raise Cancelled if the render of `ctx` was asked to stop (Context.extra["stop"], a StopFlag)."""
    stop = ctx.extra.get("stop")
    if stop is not None and stop.flag[0]:
        raise Cancelled()


class Radiance(NamedTuple):
    """What a batch of camera rays found.

    L:       (n, 3) float64 radiance towards the camera (0 where the ray missed)
    hit:     (n,) bool which rays hit a surface
    shadow_rays: int shadow rays traced
    holdout: (n,) float64 the share of each ray's alpha that holdout objects take away (Object > Visibility >
             Holdout), and on a transparent film what its paths through clear surfaces alone bring back from the world
             (the mean of their throughput, as Cycles), or None where neither can be
    light:   (n, 8, 3) float64 each ray's contributions to the light passes (lightpasses.LIGHT_PASSES' order), or
             None where none is asked for
    groups:  (n, G, 3) float64 each ray's light by the group of its source (core/integrators/lightgroups.py), or
             None where no light group is asked for
    features: (n, 6) float64 each ray's denoising albedo and normal (core/integrators/features.py), or None
    passes:  each ray's first-hit passes (core/integrators/passes.py DataPasses), or None where none is asked for
    """

    L: np.ndarray
    hit: np.ndarray
    shadow_rays: int
    holdout: Optional[np.ndarray] = None
    light: Optional[np.ndarray] = None
    groups: Optional[np.ndarray] = None
    features: Optional[np.ndarray] = None
    passes: Optional[object] = None


class Recorder:
    """Receives the integrator's decisions as they are made; every method here ignores them.

    Subclasses keep what they need (core/integrators/debug.py, core/teaching). Arrays are for the batch the
    integrator works on: n rays, and per light the hits `rows` it cast shadow rays for.
    """

    def hits(self, O: np.ndarray, D: np.ndarray, surface: Optional[Surface], hit: np.ndarray) -> None:
        """The camera rays O, D (n, 3) float64, which hit (n,) bool, and the hits' Surface (or None)."""

    def shader(self, result) -> None:
        """The material at each hit: core/materials/closures.py ShaderResult (closures, emission)."""

    def light_sample(self, light: int, count: int, sample: LightSample, NL: np.ndarray, NgL: np.ndarray,
                     cosine: np.ndarray, face_allows: np.ndarray, lit: np.ndarray) -> None:
        """One sample (of `count`) of light `light` at every hit: N.L, Ng.L, the cosine used, whether
        the face lets the light be seen, and `lit`: whether a shadow ray is cast. All (m,) over the hits."""

    def shadow_rays(self, light: int, count: int, rows: np.ndarray, rays: ShadowRays, seen: np.ndarray) -> None:
        """The shadow rays cast for the hits `rows` (r,) int64 and whether each reached the light (r,) bool."""

    def contribution(self, light: int, rows: np.ndarray, value: np.ndarray, mis_weight: np.ndarray) -> None:
        """The radiance (r, 3) float64 that light `light`'s sample adds at the hits `rows`, with its MIS
        weight (r,) float64 against BSDF sampling (1 for a light no BSDF ray can find)."""

    def bsdf_sample(self, wi: np.ndarray, pdf: np.ndarray, found: np.ndarray) -> None:
        """The direction sampled from each hit's closures, wi (m, 3), its pdf (m,) (inf: a delta) and the
        light (m, 3) it found (lamps, emitters, the world), weighed by MIS."""

    def path_vertex(self, vertex: int, owner: np.ndarray, surface: Surface, throughput: np.ndarray,
                    L: np.ndarray) -> None:
        """A path tracer's vertex `vertex` (0: the camera's hit) of the camera rays `owner` (m,) int64, after
        it was shaded: its Surface, the path's throughput (m, 3) there and the light L (m, 3) it gathered
        (before the throughput). The shader, light-sample and BSDF-sample calls before it were this vertex's."""

    def scatter(self, kind: str, P: np.ndarray) -> None:
        """Points P (m, 3) float64 where rays through a medium scatter light towards their start (core/integrators/
        volume.py): kind "free flight" (the distance sampled from the transmittance) or "equi-angular" (a point
        chosen for a lamp)."""

    def rays(self, kind: str, O: np.ndarray, D: np.ndarray, t: np.ndarray) -> None:
        """Rays the integrator traced beyond the shadow rays: kind "camera", "reflect", "refract" or "portal" (a
        Ray Portal's ray; "portal_jump": from the hit to where a portal's ray leaves, not traced); origins
        O and unit directions D (k, 3), and how far each went, t (k,) (inf where it escaped)."""

    def roulette(self, vertex: int, owner: np.ndarray, q: np.ndarray, survived: np.ndarray) -> None:
        """Russian roulette before vertex `vertex` of the paths of camera rays `owner` (k,): the probability
        q (k,) of going on, and which went on (k,) bool."""


class Integrator:
    """The interface every integrator implements.

    name: the name RenderSettings.integrator chooses it by (core/integrators/__init__.py's table)
    """

    name: ClassVar[str] = ""

    def radiance(self, ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, pixel: np.ndarray,
                 sample: np.ndarray, recorder: Recorder) -> Radiance:
        """Return the radiance each camera ray brings back.

        O, D: (n, 3) float64 camera-relative ray origins and unit directions; t_max: (n,) float64;
        pixel, sample: (n,) int64 each ray's keys for its random numbers (core/sampling).
        """
        raise NotImplementedError
