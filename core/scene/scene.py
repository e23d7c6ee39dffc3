"""The scene model: plain dataclasses of numpy arrays that the tracer reads.

Nothing here knows about Blender. The add-on fills these records from the
evaluated depsgraph; a student can build them by hand (see `core/demo_scenes.py`).

Conventions
- Float data is float64 on the Python side; it becomes float32 only at the
  Embree boundary (`core/intersect.py`), after the camera position has been
  subtracted (camera-relative rendering).
- Colours are scene-linear RGB.
- A mesh is stored once and placed any number of times by `Instance` records.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Sequence, Union

import numpy as np

from ..camera.camera import Camera

# The colour used when a triangle's material is missing (Blender's default grey).
DEFAULT_BASE_COLOR = (0.8, 0.8, 0.8)


@dataclass
class Material:
    """A diffuse (Lambert) material: it reflects base_color / pi of the irradiance."""

    base_color: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_BASE_COLOR))  # (3,) float64 in 0..1
    name: str = "Material"


@dataclass
class Mesh:
    """A triangle mesh in its own (object) space, shared by all instances that use it.

    vertices:         (v, 3) float64 object-space points
    triangles:        (t, 3) int64 vertex indices, counter-clockwise seen from the front
    smooth:           (t,) bool, True where the triangle is shaded with interpolated normals
    corner_normals:   (t, 3, 3) float64 unit normal per triangle corner, or None to
                      derive vertex normals from the geometry (`core.normals.vertex_normals`)
    material_indices: (t,) int64 index into the instance's material list
    """

    vertices: np.ndarray
    triangles: np.ndarray
    smooth: Optional[np.ndarray] = None
    corner_normals: Optional[np.ndarray] = None
    material_indices: Optional[np.ndarray] = None
    name: str = "Mesh"

    def __post_init__(self):
        self.vertices = np.asarray(self.vertices, dtype=np.float64).reshape(-1, 3)
        self.triangles = np.asarray(self.triangles, dtype=np.int64).reshape(-1, 3)
        t = len(self.triangles)
        self.smooth = (np.zeros(t, bool) if self.smooth is None
                       else np.broadcast_to(np.asarray(self.smooth, bool), (t,)).copy())
        self.material_indices = (np.zeros(t, np.int64) if self.material_indices is None
                                 else np.broadcast_to(np.asarray(self.material_indices, np.int64), (t,)).copy())
        if self.corner_normals is not None:
            self.corner_normals = np.asarray(self.corner_normals, dtype=np.float64).reshape(t, 3, 3)


@dataclass(slots=True)
class Instance:
    """One placement of a mesh: object-to-world matrix and the materials of its slots.

    mesh:      index into Scene.meshes
    matrix:    (4, 4) float64 object-to-world transform (may include negative scale)
    materials: (k,) int64 index into Scene.materials per material slot, or None
               to use the mesh's material indices as scene material indices
    """

    mesh: int
    matrix: np.ndarray = field(default_factory=lambda: np.eye(4))
    materials: Optional[np.ndarray] = None
    name: str = "Object"

    def __post_init__(self):
        # Reshape only when needed: a view is one more array object per instance (10^5 of them add up).
        self.matrix = np.asarray(self.matrix, dtype=np.float64)
        if self.matrix.shape != (4, 4):
            self.matrix = self.matrix.reshape(4, 4)
        if self.materials is not None:
            self.materials = np.asarray(self.materials, dtype=np.int64)
            if self.materials.ndim != 1:
                self.materials = self.materials.reshape(-1)


# ----------------------------------------------------------------------------
# Lights, in Cycles' units (see core/lights.py for the radiometry).
# ----------------------------------------------------------------------------

@dataclass
class PointLight:
    """A point light of `power` watts; with radius > 0 it has extent and casts soft shadows.

    position: (3,) float64 world point; color: (3,) float64 linear RGB.
    Radiant intensity of the radius-0 light: I = power / (4 pi) W/sr.
    soft_falloff (Blender's default): the radius-R light is a disk of radiance
    P / (4 pi^2 R^2) that always faces the shading point; without it, a sphere.
    """

    position: np.ndarray
    power: float = 1000.0
    color: np.ndarray = field(default_factory=lambda: np.ones(3))
    radius: float = 0.0
    soft_falloff: bool = True
    name: str = "Point"


@dataclass
class SpotLight:
    """A point light masked by Blender's spot cone.

    position:  (3,) float64 world point; direction: (3,) float64 unit spot axis (where it shines).
    spot_size: full cone angle in radians; spot_blend: 0..1 softness of the cone edge.
    frame:     (3, 3) float64 object-to-world linear map of the light (rotation times scale),
               whose -Z column is the axis, or None for an unscaled frame around `direction`.
               A non-uniform scale makes the cone elliptical, as in Blender.
    """

    position: np.ndarray
    direction: np.ndarray
    power: float = 1000.0
    color: np.ndarray = field(default_factory=lambda: np.ones(3))
    radius: float = 0.0
    soft_falloff: bool = True
    spot_size: float = math.radians(45.0)
    spot_blend: float = 0.15
    frame: Optional[np.ndarray] = None
    name: str = "Spot"


@dataclass
class SunLight:
    """A distant light: `strength` W/m^2 of irradiance on a surface facing it.

    direction: (3,) float64 unit direction in which the light travels (Blender's -Z of the sun object).
    angle: angular diameter of the sun disk in radians (0: hard shadows).
    """

    direction: np.ndarray
    strength: float = 1.0
    color: np.ndarray = field(default_factory=lambda: np.ones(3))
    angle: float = 0.0
    name: str = "Sun"


@dataclass
class AreaLight:
    """A one-sided planar emitter of `power` watts with radiance P / (pi A).

    center:    (3,) float64 world point
    axis_u:    (3,) float64 world vector spanning the full size along the light's local X
    axis_v:    (3,) float64 world vector spanning the full size along the light's local Y
    direction: (3,) float64 unit normal on the emitting side (Blender's local -Z)
    shape:     "SQUARE" | "RECTANGLE" (a parallelogram from the two axes) or "DISK" | "ELLIPSE"
    spread:    radians; below pi, Blender narrows the emission towards the normal (power kept)
    """

    center: np.ndarray
    axis_u: np.ndarray
    axis_v: np.ndarray
    direction: np.ndarray
    power: float = 100.0
    color: np.ndarray = field(default_factory=lambda: np.ones(3))
    shape: str = "SQUARE"
    spread: float = math.pi
    name: str = "Area"


Light = Union[PointLight, SpotLight, SunLight, AreaLight]


@dataclass
class RenderSettings:
    """How to render: image size, sampling and the lecture's switches.

    region: (x0, y0, x1, y1) pixel rectangle to render, y from the top row, or None for all.
    shadow_method: "robust" (error-bound offset, no user epsilon) or "epsilon" (the lecture's).
    aux: names of auxiliary buffers to return, from core.render.AUX_BUFFERS.
    instancing: "auto" stores a mesh once and traces it as Embree instances when its copies would
        exceed core.instancing.INSTANCE_TRIANGLES triangles, "always" does so for every mesh placed
        twice or more, "never" copies every placement (core/instancing.py). The image is the same.
    kernels: "compiled" runs the render loop's arithmetic in C where core/kernels.py applies (the
        same numbers, several times faster); "numpy" keeps every render on the readable numpy path.
    adaptive: render in passes and stop pixels whose noise is below adaptive_threshold
        (core/adaptive.py); samples is then the most a pixel gets. adaptive_threshold 0 and
        adaptive_min_samples 0 choose automatic values from samples.

    The lecture switches (LECTURE_SWITCHES) default to the lecture's choice; turning one
    off shows what goes wrong without it (README, "Lecture switches"):
    smooth_normals:   interpolate vertex normals with the barycentrics (False: the face normal everywhere)
    visibility_normal: "face" decides whether a light can be seen with the face normal Ng.L > 0,
                      "shading" with the interpolated N.L > 0 (light leaks through smooth low-poly meshes)
    reduce_t_max:     stop shadow rays short of the light point (False: t_max = ||P_light - I||, so a
                      surface the light sits on shadows it)
    distance_attenuation: irradiance falls off as 1/r^2 (False: point, spot and area lights do not)
    clamp_n_dot_l:    the cosine factor is max(N.L, 0) (False: N.L, negative light from behind)
    shadow_rays_for_backfacing: also trace shadow rays for lights behind the surface (True: the same
                      image, more rays; the lecture skips them, since their visibility is 0)
    """

    width: int = 640
    height: int = 480
    samples: int = 16
    seed: int = 0
    region: Optional[tuple] = None
    pixel_aspect: tuple = (1.0, 1.0)
    jitter: bool = True
    light_samples: int = 4
    shadow_method: str = "robust"
    epsilon: float = 1e-3
    terminator_fix: bool = False
    terminator_offset: float = 0.1
    camera_relative: bool = True
    transparent_background: bool = False
    threads: int = 0
    chunk_size: int = 1 << 16
    instancing: str = "auto"
    kernels: str = "compiled"
    aux: Sequence[str] = ()
    adaptive: bool = False
    adaptive_threshold: float = 0.0
    adaptive_min_samples: int = 0
    smooth_normals: bool = True
    visibility_normal: str = "face"
    reduce_t_max: bool = True
    distance_attenuation: bool = True
    clamp_n_dot_l: bool = True
    shadow_rays_for_backfacing: bool = False

    def is_lecture_default(self) -> bool:
        """Whether every lecture switch is at the lecture's choice (a fast path may then stand in)."""
        return all(getattr(self, name) == default for name, default in LECTURE_SWITCHES.items())


# The lecture switches of RenderSettings and their defaults (the lecture's choices). shadow_method and
# epsilon are lecture settings too, but every render path supports both, so they are not listed here.
LECTURE_SWITCHES = {
    "smooth_normals": True,
    "visibility_normal": "face",
    "reduce_t_max": True,
    "distance_attenuation": True,
    "clamp_n_dot_l": True,
    "shadow_rays_for_backfacing": False,
}


@dataclass
class Scene:
    """Everything the tracer needs: meshes, their instances, materials, lights, camera, world."""

    camera: Camera
    meshes: list = field(default_factory=list)
    instances: list = field(default_factory=list)
    materials: list = field(default_factory=list)
    lights: list = field(default_factory=list)
    world_color: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def add_mesh(self, mesh: Mesh, matrix=None, materials=None, name: str = "Object") -> int:
        """Store `mesh` once, place it with `matrix`, and return the mesh index (to instance it again)."""
        self.meshes.append(mesh)
        index = len(self.meshes) - 1
        self.instances.append(Instance(index, np.eye(4) if matrix is None else matrix, materials, name))
        return index

    def add_material(self, base_color, name: str = "Material") -> int:
        """Append a diffuse material and return its index."""
        self.materials.append(Material(np.asarray(base_color, dtype=np.float64), name))
        return len(self.materials) - 1
