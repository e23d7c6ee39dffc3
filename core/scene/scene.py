"""The scene model: plain dataclasses of numpy arrays that the tracer reads.

Nothing here knows about Blender. The add-on fills these records from the
evaluated depsgraph; a student can build them by hand (see `sample_scenes/scenes.py`).

Conventions
- Float data is float64 on the Python side; it becomes float32 only at the
  Embree boundary (`core/geometry/intersect.py`), after the camera position has been
  subtracted (camera-relative rendering).
- Colours are scene-linear RGB.
- A mesh is stored once and placed any number of times by `Instance` records.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..camera.camera import Camera
from ..lights import AreaLight, Light, PointLight, SpotLight, SunLight, World  # noqa: F401 (the scene's light records)
from ..materials import DEFAULT_BASE_COLOR, Material  # noqa: F401 (the scene's material record)
from ..lights.linking import ALL_SETS


@dataclass
class Mesh:
    """A triangle mesh in its own (object) space, shared by all instances that use it.

    vertices:         (v, 3) float64 object-space points
    triangles:        (t, 3) int64 vertex indices, counter-clockwise seen from the front
    smooth:           (t,) bool, True where the triangle is shaded with interpolated normals
    corner_normals:   (t, 3, 3) float64 unit normal per triangle corner, or None to
                      derive vertex normals from the geometry (`core.normals.vertex_normals`); float32 when given
                      float32 (Blender's own normals: half the memory, 36 bytes a triangle), which its readers
                      widen to float64 (exactly: the numbers are those of a float64 copy)
    material_indices: (t,) int64 index into the instance's material list
    attributes:       per-corner data the materials read (core/materials/graph.py): name -> (t, 3, w)
    curve_info:       the Curves Info node's values per vertex of curves made tubes (core/geometry/curves.py
                      curves_info), or the Point Info's per vertex of a point cloud's spheres (core/geometry/points.py
                      point_info): name ("curve:intercept", "point_centre", ...) -> (v,) or (v, w) float64; made
                      attributes where read
                      float64, e.g. "uv:UVMap" (w 3, z 0), "color:Col" (RGBA; "attr:Col" an Attribute node's), "tangent:UVMap" (object-space
                      tangent and bitangent sign), "generated", "object"; an empty name after the colon is the
                      mesh's active map
    """

    vertices: np.ndarray
    triangles: np.ndarray
    smooth: Optional[np.ndarray] = None
    corner_normals: Optional[np.ndarray] = None
    material_indices: Optional[np.ndarray] = None
    name: str = "Mesh"
    attributes: dict = field(default_factory=dict)
    curve_info: dict = field(default_factory=dict)

    def __post_init__(self):
        self.vertices = np.asarray(self.vertices, dtype=np.float64).reshape(-1, 3)
        self.triangles = np.asarray(self.triangles, dtype=np.int64).reshape(-1, 3)
        t = len(self.triangles)
        self.smooth = (np.zeros(t, bool) if self.smooth is None
                       else np.broadcast_to(np.asarray(self.smooth, bool), (t,)).copy())
        self.material_indices = (np.zeros(t, np.int64) if self.material_indices is None
                                 else np.broadcast_to(np.asarray(self.material_indices, np.int64), (t,)).copy())
        if self.corner_normals is not None:
            given = np.asarray(self.corner_normals)
            kept = np.float32 if given.dtype == np.float32 else np.float64
            self.corner_normals = given.astype(kept, copy=False).reshape(t, 3, 3)


@dataclass(slots=True)
class Instance:
    """One placement of a mesh: object-to-world matrix and the materials of its slots.

    mesh:      index into Scene.meshes
    matrix:    (4, 4) float64 object-to-world transform (may include negative scale)
    materials: (k,) int64 index into Scene.materials per material slot, or None
               to use the mesh's material indices as scene material indices
    random:    the Object Info node's Random (0..1); None: Cycles' value for an object named `name`
    pass_index: Blender's Object > Relations > Pass Index, what the Object Index pass shows
    visible_camera, visible_shadow: Blender's Object > Visibility > Ray Visibility > Camera and Shadow: camera
               rays (and shadow rays) pass the object as if it were not there; it still lights the scene and
               is seen by every other ray
    visible_diffuse, visible_glossy, visible_transmission: Ray Visibility > Diffuse, Glossy, Transmission: the
               rays of diffuse reflections (glossy reflections, refractions) pass the object, and its emission
               lights no diffuse (glossy, refracting) closure by light samples either, as in Cycles
    visible_volume_scatter: Ray Visibility > Volume Scatter: the rays a medium's scattering sends (phase rays) pass
               the object, and its emission lights no scattering point by light samples, as in Cycles
    is_holdout: Object > Visibility > Holdout: where camera rays (also through Transparent surfaces) meet the
               object the film is clear (colour 0, alpha 0); every other ray sees it as usual
    is_shadow_catcher: Object > Visibility > Shadow Catcher: the camera sees only the shadows (and light) other
               objects cast on it, as Cycles shows it (core/integrators/catcher.py); every other ray sees it as usual
    asset:     the name of the object's topmost parent (Cryptomatte's asset); "" for the object's own name
    color:     Object > Viewport Display > Color, RGBA (the Object Info node's Color and Alpha)
    light_set, shadow_set: its receiver light set and blocker shadow set (0..63, core/lights/linking.py): which
               emitters light it, and for which emitters it casts shadows
    light_membership, shadow_membership: as an emitter (an emissive material), the receiver sets it lights and the
               blocker sets that cast its shadows (64-bit masks; ALL_SETS: not linked)
    terminator_offset: Object > Shading > Shadow Terminator > Geometry Offset: how far (0..1 of the way, by how
               grazing the light is) Cycles lifts the shadow rays of its smooth triangles towards the curved surface
               their normals describe; None: the render's RenderSettings.terminator_offset
    terminator_shading: Shadow Terminator > Shading Offset (0..1): Cycles bends the cosine of the light its closures
               reflect so that it reaches 0 before the terminator (core/materials/closures.py terminator_term)
    (Both only with RenderSettings.terminator_fix, the lecture's switch for Cycles' shadow terminator.)
    caustics_caster, caustics_receiver: Object > Shading > Caustics > Cast / Receive Shadow Caustics (Cycles'
               is_caustics_caster, is_caustics_receiver): where a caustics light's shadow rays from a receiver meet a
               caster's refractive closures, the light path through them is found (core/integrators/mnee.py)
    ao_distance: Object > Visibility > Fast GI Approximation > AO Distance: how far Fast GI's (Replace) rays leaving
               it look (0: the render's RenderSettings.ao_distance)
    attributes: the Attribute node's Object and Instancer attributes of this object, name -> RGBA (4,) (Cycles'
               object attributes, looked up at export; Scene.instance_attributes orders them), or None: none
    dupli_generated, dupli_uv: an instance's Generated (3,) and UV (2,) From Instancer (the Texture Coordinate node):
               the point of its instancer it was placed at (Cycles' dupli_generated, 0.5 orco - 0.5, and dupli_uv);
               None: (0, 0, 0), (0, 0), as for an object that is no instance
    texspace:  (location (3,), size (3,)) its mesh's texture space (Blender's texspace_location, texspace_size): the
               Generated coordinates a heterogeneous medium it holds reads, (P_object - location) / (2 size) + 0.5
               (core/volumes/media.py per_object); None: the material's volume_space's
    motion:    its object-to-world matrices (4, 4) at s >= 2 evenly spaced times over the shutter (Cycles' object
               motion steps, open to close), when it moves over it; () still. A moving instance is traced as an Embree
               instance of its own placed at each ray's time (core/geometry/geometry.py build_geometry).
    deformation: its mesh's object-space vertex positions (v, 3) at s >= 2 evenly spaced times over the shutter
               (Cycles' deformation motion: the same vertices, moved by modifiers or shape keys), when they move;
               () rigid. Traced as an instance of its own whose vertices Embree interpolates at each ray's time.
    deformation_normals: with a deformation, its mesh's object-space unit vertex normals (v, 3) at the same times
               (Cycles' motion vertex normals, read where the mesh's normals are per vertex), whose linear
               interpolation at each ray's time gives its smooth triangles' corner normals then; () the smooth
               normals stay the frame's (Mesh.corner_normals).
    vector_motion: its object-to-world matrices (4, 4) at the frames before and after the one rendered, (before,
               after), when the Vector pass is written and it moves between them (core/integrators/passes.py); ()
               still.
    vector_deformation: its mesh's object-space vertex positions (v, 3) float64 at the frames before and after the
               one rendered, (before, after), when the Vector pass is written and they deform between them (Cycles'
               motion vertex positions); either None (or of another vertex count: the topology changed) where that
               frame's vertices are the mesh's own, as Cycles copies them there (passes.with_vector_deformation); ()
               rigid.
    """

    mesh: int
    matrix: np.ndarray = field(default_factory=lambda: np.eye(4))
    materials: Optional[np.ndarray] = None
    name: str = "Object"
    random: Optional[float] = None
    pass_index: int = 0
    visible_camera: bool = True
    visible_shadow: bool = True
    visible_diffuse: bool = True
    visible_glossy: bool = True
    visible_transmission: bool = True
    visible_volume_scatter: bool = True
    is_holdout: bool = False
    is_shadow_catcher: bool = False
    asset: str = ""
    color: tuple = (1.0, 1.0, 1.0, 1.0)
    light_set: int = 0
    shadow_set: int = 0
    light_membership: int = ALL_SETS
    shadow_membership: int = ALL_SETS
    terminator_offset: Optional[float] = None
    terminator_shading: float = 0.0
    ao_distance: float = 0.0
    caustics_caster: bool = False
    caustics_receiver: bool = False
    attributes: Optional[dict] = None
    dupli_generated: Optional[tuple] = None
    dupli_uv: Optional[tuple] = None
    texspace: Optional[tuple] = None
    motion: tuple = ()
    deformation: tuple = ()
    deformation_normals: tuple = ()
    vector_motion: tuple = ()
    vector_deformation: tuple = ()

    def __post_init__(self):
        # Reshape only when needed: a view is one more array object per instance (10^5 of them add up).
        self.matrix = np.asarray(self.matrix, dtype=np.float64)
        if self.matrix.shape != (4, 4):
            self.matrix = self.matrix.reshape(4, 4)
        if self.materials is not None:
            self.materials = np.asarray(self.materials, dtype=np.int64)
            if self.materials.ndim != 1:
                self.materials = self.materials.reshape(-1)


@dataclass
class Scene:
    """Everything the tracer needs: meshes, their instances, materials, lights, camera, world.

    world_color: a background colour seen by camera rays only (it lights nothing); world: a World
    (core/lights/world.py) that lights the scene as Cycles' world does, when given.
    default_material: the surface of triangles without a material: the lecture's grey Lambert surface,
    unless a scene from Blender says Cycles' default surface (core/materials DEFAULT_SURFACE).
    lightgroups: the light group (View Layer > Light Groups) each source belongs to, by name ("" for none):
    {"lights": [one per lights entry], "instances": [one per instances entry], "world": the world's}; the
    groups a render writes are RenderSettings.light_groups (core/integrators/lightgroups.py)
    instance_attributes: the names of the Attribute node's Object and Instancer attributes the materials read, in the
    order of their columns of the instances' Object Info (geometry.instance_info; Instance.attributes)
    vector_cameras: the camera at the frames before and after the one rendered, (before, after), for the Vector pass
    (core/integrators/passes.py); () the camera's own
    """

    camera: Camera
    meshes: list = field(default_factory=list)
    instances: list = field(default_factory=list)
    materials: list = field(default_factory=list)
    lights: list = field(default_factory=list)
    world_color: np.ndarray = field(default_factory=lambda: np.zeros(3))
    world: Optional[World] = None
    default_material: Material = field(default_factory=Material)
    lightgroups: dict = field(default_factory=lambda: {"lights": [], "instances": [], "world": ""})
    instance_attributes: list = field(default_factory=list)
    vector_cameras: tuple = ()

    def the_world(self) -> World:
        """The world: `world` when given (it lights the scene unless told not to), else a background of
        `world_color` that camera rays see and that lights nothing (the lecture's world)."""
        if self.world is not None:
            return self.world
        return World(color=np.asarray(self.world_color, np.float64)[:3], camera=True, lights=False)

    def add_mesh(self, mesh: Mesh, matrix=None, materials=None, name: str = "Object") -> int:
        """Store `mesh` once, place it with `matrix`, and return the mesh index (to instance it again)."""
        self.meshes.append(mesh)
        index = len(self.meshes) - 1
        self.instances.append(Instance(index, np.eye(4) if matrix is None else matrix, materials, name))
        return index

    def add_material(self, base_color, name: str = "Material", bsdf: str = "DIFFUSE") -> int:
        """Append a material (diffuse unless `bsdf` names another BSDF) and return its index."""
        self.materials.append(Material(np.asarray(base_color, dtype=np.float64), name, bsdf))
        return len(self.materials) - 1
