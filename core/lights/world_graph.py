"""A world made of shader nodes: compiled once into a program, baked into an equirectangular image of its radiance
for its light samples, and evaluated per ray for every ray that escapes.

Cycles evaluates the world's shader for every ray that leaves the scene, at the ray's direction D (its shading point
has P = D, N = -D: the Generated and Object coordinates are D), with the ray's path state (the Light Path node), for
each light sample of it with EMISSION alone, and bakes it into a map only to importance-sample it. Primer does the same:

- **Light samples** (and the pdf MIS weighs against): the program is baked once per render into an equirectangular
  image at the texel centres of its world lookup (core/lights/world.py: texel centres at (i + 1/2) / W, linear in
  between), evaluated as a light sample at the first bounce (EMISSION alone: every "Is ... Ray" 0, Ray Depth 1), and
  importance-sampled from the same map, on both kernels. A graph that reads Light Path's depths (which the bake
  fixes at the first bounce) is run for each light sample instead, with the path at the vertex it lights
  (World.samples_seen; core/integrators/vertex.py world_samples_seen, direct.c world_seen_block), as Cycles does.
  Between texel centres the bake interpolates linearly where Cycles evaluates the graph itself: a smooth sky or a
  blurred HDRI matches. The bake runs the program with the
  compiled runner (graph.c, `primer_world_bake`) where the library is available, else with the numpy reference
  (`graph.run`); the two agree to float rounding.
- **Rays that escape** (`World.seen`): a camera ray (straight or through transparent surfaces, which keep Cycles'
  PATH_RAY_CAMERA), a BSDF ray, a volume's phase-sampled ray runs the program for its direction with its own path
  (flags | EMISSION, as Cycles' integrator_eval_background_shader), in both kernels (world_graph.c `world_seen`):
  exact, also for a pattern finer than a texel and for a graph that shows the camera something else than it lights
  the scene with (Is Camera Ray).

A Sky Texture's sun disc, about 0.5 degrees wide and very bright, covers only some 7 texel centres 0.18 degrees apart:
summed there its light comes out 0.8 to 1.04 times the disc's (by where the centres fall). The bake and the rays that
escape leave it out (the op draws no disc in a world, core/materials/sky.py `Sky.disc_drawn`), and `sky_suns` makes
it a sun lamp of the world's. The sky itself is evaluated per ray like any other graph, in C too (core/materials/sky.c).
"""
from __future__ import annotations

import dataclasses
import hashlib
import math
from typing import NamedTuple

import numpy as np

from ..materials import graph as graph_
from ..materials import sky as sky_
from ..materials import textures as textures_
from ..native import library, schema
from ..native.schema import F32, I32, I64, out, ptr
from .sun import SunLight
from .world import uv_to_direction

# The baked image's width (its height is half): 0.18 degrees a texel.
BAKE_WIDTH = 2048
# Directions baked per pass of the node-graph program (bounds the registers' memory).
BAKE_BATCH = 1 << 16
# The Light Path outputs the bake gives as Cycles does for every light sample: every ray that escapes evaluates the
# world with its own path (World.seen), and a light sample of it in Cycles sees EMISSION alone, as the bake does
# (every "Is ... Ray" 0), and a Ray Length of FLT_MAX. The depths are the bake's only at the first bounce (Ray Depth 1,
# the others 0), where Cycles gives each light sample its vertex's depths: a world reading them runs its program for
# each light sample with that vertex's path instead (World.samples_seen, addon/export.py _baked_world).
EXACT_FOR_LIGHTING = frozenset({"Is Camera Ray", "Is Shadow Ray", "Is Diffuse Ray", "Is Glossy Ray", "Is Singular Ray",
                                "Is Reflection Ray", "Is Transmission Ray", "Is Volume Scatter Ray", "Ray Length"})


class WorldProgram(NamedTuple):
    """A world's Background inputs compiled into one program: the program, the registers of colour (3) and strength
    (1), the textures it reads, the attribute layout, and where each Sky Texture's floats start in the program's
    float tables (by the id of its core/materials/sky.py Sky)."""

    program: "graph_.Program"
    registers: tuple
    textures: "textures_.TextureSet"
    layout: dict
    sky_starts: dict

    @property
    def compiled(self) -> bool:
        """Whether graph.c can run the program (the library is there)."""
        return library.available()

    def along(self, D: np.ndarray, paths: "graph_.LightPaths") -> np.ndarray:
        """The radiance (n, 3) float64 rays D (n, 3) that escape find, each evaluated with the path that sent it
        (its graph.LightPaths; EMISSION added, as Cycles evaluates a background), negative and non-finite channels
        0 (Cycles shows a negative world black, and its film drops what is not finite)."""
        L = radiance_along(self, D, paths=paths._replace(flags=paths.flags | graph_.PATH_EMISSION))
        return np.where(np.isfinite(L), np.maximum(L, 0.0), 0.0)

    def record(self) -> "WorldGraphRecord":
        """The program as C reads it (WorldGraph), keeping its arrays alive."""
        return WorldGraphRecord(graph=graph_.program_tables([self.program], self.textures), color=self.registers[0],
                                strength=self.registers[1], generated=self.layout["generated"][0],
                                object=self.layout["object"][0], width=sum(w for _, w in self.layout.values()))


WorldGraphRecord = schema.record("WorldGraph", "A world's Background compiled into one program (core/lights/world_graph.py WorldProgram).", [
    ("graph", ptr("GraphTables"), "its one program and the images it reads"),
    ("color", I32, "the register of the colour (3)"),
    ("strength", I32, "the register of the strength"),
    ("generated", I32, "where the Generated coordinates start among a point's attributes"),
    ("object", I32, "where the Object coordinates start"),
    ("width", I32, "attribute floats per point"),
])

WorldBakeArgs = schema.function("primer_world_bake", "world_bake_rows", schema.record("WorldBakeArgs", "primer_world_bake's arguments: rows row_start .. row_end - 1 of the world's bake (world_graph.bake).", [
    ("world", ptr("WorldGraph"), "the program"),
    ("width", I64, "the image's W"),
    ("height", I64, "its H"),
    ("row_start", I64, "the first row baked"),
    ("row_end", I64, "past the last"),
    ("flags", I32, "the path's PATH_* bits the program sees"),
    ("radiance", out(F32), "(H, W, 3) colour x strength at the texel centres, rows row_start .. row_end - 1 written"),
]))


def compile_emission(color, strength, attributes: set, owner: str) -> tuple:
    """Compile an emission's color and strength (constants or graph.Links) over the shading point of `owner` (the
    world's, a lamp's), reading `attributes`: (program, (color, strength) register numbers, TextureSet, layout,
    compiler)."""
    layout = graph_.layout_of(attributes)
    nodes = [(None, 1.0, {"color": color, "strength": strength})]
    images = graph_.images_of(nodes)
    index = {id(image): k for k, image in enumerate(images) if image is not None}
    compiler = graph_.Compiler(layout, lambda image: index.get(id(image), -1), material=owner)
    color_register = compiler.value(color, 3, 0.0)
    strength_register = compiler.value(strength, 1, 1.0)
    program = compiler.compile([])
    registers = tuple(register_number(compiler, r) for r in (color_register, strength_register))
    textures = textures_.TextureSet.of([image for image in images if image is not None])
    return program, registers, textures, layout, compiler


def compile_world(color, strength) -> WorldProgram:
    """Compile the Background's color and strength (constants or graph.Links) over a world's shading point."""
    program, registers, textures, layout, compiler = compile_emission(color, strength, {"generated", "object"},
                                                                      "the world")
    return WorldProgram(program, registers, textures, layout, dict(compiler.sky_starts))


def compile_aovs(aovs, slots: dict):
    """The world's AOV Output nodes `aovs` (World.aovs: (name, Color, Value) each) that name one of the render's
    shader AOVs `slots` (core/integrators/passes.py aov_slots: name -> (first channel, 4 COLOR or 1 VALUE)) compiled
    over the world's shading point, after an AOV_START op (OUT_AOV rows, as a material's: graph.Compiler.compile):
    a WorldProgram whose colour and strength are 0, or None where no node names one (Cycles' OutputAOVNode with
    offset -1 is not compiled)."""
    wanted = [(slots[name][0], slots[name][1], color if slots[name][1] == 4 else value)
              for name, color, value in aovs if name in slots]
    if not wanted:
        return None
    layout = graph_.layout_of({"generated", "object"})
    nodes = [(None, 1.0, {"source": source}) for _, _, source in wanted]
    images = graph_.images_of(nodes)
    index = {id(image): k for k, image in enumerate(images) if image is not None}
    compiler = graph_.Compiler(layout, lambda image: index.get(id(image), -1), material="the world")
    registers = (compiler.value(np.zeros(3), 3, 0.0), compiler.value(0.0, 1, 0.0))
    program = compiler.compile([], aovs=wanted)
    textures = textures_.TextureSet.of([image for image in images if image is not None])
    return WorldProgram(program, tuple(register_number(compiler, r) for r in registers), textures, layout,
                        dict(compiler.sky_starts))


def aovs_along(world: WorldProgram, D: np.ndarray, channels: int, paths=None) -> np.ndarray:
    """What the world's AOV Output nodes (compile_aovs) write (n, channels) float64 for rays along unit D (n, 3) that
    escape, each evaluated with its graph.LightPaths `paths` (None: camera rays), EMISSION added as Cycles evaluates
    a background (integrator_eval_background_shader), by the numpy reference (graph.aov_values: a COLOR AOV its
    Color and 1 in its alpha channel, a VALUE AOV its Value)."""
    paths = graph_.light_paths(len(D)) if paths is None else paths
    reg = graph_.run(world.program, world_point(D, world.layout, paths._replace(flags=paths.flags | graph_.PATH_EMISSION)),
                     world.textures)
    values = graph_.aov_values(world.program, reg, channels)
    return np.zeros((len(D), channels)) if values is None else values


def radiance_along(world: WorldProgram, D: np.ndarray, program=None, paths=None) -> np.ndarray:
    """The world's radiance colour x strength (n, 3) float64 along directions D (n, 3) (`program`: the world's
    program with other float tables, else its own; paths: the rays' graph.LightPaths, None: a ray that lights the
    scene: a light sample at the first bounce, EMISSION alone), by the numpy reference."""
    reg = graph_.run(world.program if program is None else program, world_point(D, world.layout, paths),
                     world.textures)
    c, s = world.registers
    return reg[:, c:c + 3] * reg[:, s:s + 1]


def bake(color, strength, width: int = BAKE_WIDTH, kernels: str = "compiled") -> np.ndarray:
    """The world's radiance color x strength as an equirectangular image (width / 2, width, 3) float32, row 0 at
    the bottom (v = 0), texel (i, j) at the direction of u = (j + 1/2) / width, v = (i + 1/2) / (width / 2), for a
    light sample at the first bounce (EMISSION alone: every Is ... Ray 0, Ray Depth 1).

    color, strength: the Background's inputs: a constant ((3,) or a float) or a graph.Link into the world's nodes.
    kernels: "compiled" runs the program in C where it can (WorldProgram.compiled), "numpy" by the reference.
    """
    # 1. Compile both inputs into one program over the attributes a world's shading point has.
    world = compile_world(color, strength)
    height = max(1, width // 2)
    # 2. The same program baked the same way a moment ago (the add-on exports the scene again for each render and
    #    each viewport update): that image.
    compiled = kernels == "compiled" and world.compiled
    key = (fingerprint(world), width, compiled)
    if key in _BAKED:
        return _BAKED[key].copy()
    # 3. Run it at the texel centres' directions: in C in bands of rows on threads, or a batch at a time in numpy.
    radiance = compiled_bake(world, width, height) if compiled else reference_bake(world, width, height)
    _BAKED.clear()                                   # (one image kept: a large one costs 24 MB)
    _BAKED[key] = radiance
    return radiance.copy()


# The last bake, by (fingerprint, width, compiled).
_BAKED: dict = {}


def fingerprint(world: WorldProgram) -> bytes:
    """A digest of everything the bake of `world` reads: its program's ops, constants and tables, its registers and
    attribute layout, and its images' texels and formats."""
    digest = hashlib.blake2b(digest_size=20)
    program = world.program
    for array in (program.ops, program.constants, program.outputs, program.ramps,
                  *(np.asarray(getattr(world.textures, f.name)) for f in dataclasses.fields(world.textures))):
        array = np.ascontiguousarray(array)
        digest.update(str((array.dtype.str, array.shape)).encode())
        digest.update(array.view(np.uint8).reshape(-1))
    digest.update(repr((program.registers, world.registers, sorted(world.layout.items()))).encode())
    return digest.digest()


def reference_bake(world: WorldProgram, width: int, height: int) -> np.ndarray:
    """The bake of `world` (height, width, 3) float32 by the numpy reference (graph.run), a batch at a time."""
    u, v = np.meshgrid((np.arange(width) + 0.5) / width, (np.arange(height) + 0.5) / height)
    directions = uv_to_direction(u.ravel(), v.ravel())
    radiance = np.empty((len(directions), 3), np.float32)
    for start in range(0, len(directions), BAKE_BATCH):
        radiance[start:start + BAKE_BATCH] = radiance_along(world, directions[start:start + BAKE_BATCH])
    return radiance.reshape(height, width, 3)


def compiled_bake(world: WorldProgram, width: int, height: int, flags: int = graph_.PATH_EMISSION) -> np.ndarray:
    """The bake of `world` (height, width, 3) float32 by graph.c (world_graph.c world_bake_rows), in bands of rows,
    one per thread (the library lets Python's other threads run while it works); flags: the path's PATH_* bits."""
    radiance = np.empty((height, width, 3), np.float32)
    record = world.record()
    library.in_row_bands(height, lambda start, end: library.call("primer_world_bake", WorldBakeArgs(
        world=record, width=width, height=height, row_start=start, row_end=end, flags=flags, radiance=radiance)))
    return radiance


def sky_suns(color, strength) -> tuple:
    """The sun discs of the world's Sky Textures as sun lamps, which the bake leaves out: ([SunLight], notes).

    Each lamp shines from the disc's centre with its angle, with the radiance the world's nodes give the disc's mean
    XYZ radiance (its limb darkening and its bottom-to-top colour integrated over the disc, core/materials/sky.py
    disc_mean_xyz): the world's radiance at the sun with that XYZ added to the sky's, less without it (exact where
    the nodes after the Sky Texture are linear in its colour, noted where they are not). Rays that meet the lamp
    (the camera's, a mirror's, a glossy bounce's) see the disc itself, limb-darkened and bottom to top, through the
    nodes' XYZ-to-RGB found the same way (SunLight.limb): its mean is the lamp's, so MIS weighs the same light. A
    Sky Texture whose Vector is linked or mapped draws its disc itself (Sky.disc_drawn: the add-on says so) and
    brings no lamp.
    """
    # 1. The Sky Textures with a disc, each once, that read the ray's direction.
    nodes = [(None, 1.0, {"color": color, "strength": strength})]
    skies = [link.node for link in graph_.links_under(nodes) if link.node.kind == "SKY"]
    skies = [node for k, node in enumerate(skies) if all(node is not other for other in skies[:k])
             and not isinstance(node.inputs.get("Vector"), graph_.Link) and node.props["sky"].size > 0.0
             and not node.props["sky"].disc_drawn]
    if not skies:
        return [], []
    world = compile_world(color, strength)
    lamps, notes = [], []
    for node in skies:
        # 2. The disc's mean XYZ radiance and where it is.
        model = node.props["sky"]
        mean_xyz = model.disc_mean_xyz()
        towards = sky_.sun_towards(model.elevation, model.rotation)
        # 3. The world's radiance at the sun with 0, half and all of it added to the sky's (the op's probe XYZ), and
        #    with a hundredth of the mean's largest more of X, Y, Z each: the nodes' XYZ to RGB about the disc's
        #    colour, column by column (about it: the op clamps negative RGB, which X, Y or Z alone would give).
        start = world.sky_starts[id(model)]

        def probe(xyz: np.ndarray) -> np.ndarray:
            """The world's RGB radiance towards the sun with `xyz` added to its Sky Texture's XYZ there."""
            ramps = world.program.ramps.copy()
            ramps[start + sky_.PROBE.start:start + sky_.PROBE.stop] = xyz
            return radiance_along(world, towards[None, :], world.program._replace(ramps=ramps))[0]

        probes = [probe(scale * mean_xyz) for scale in (0.0, 0.5, 1.0)]
        step = max(float(np.max(np.abs(mean_xyz))), 1e-30) * 1e-2
        to_rgb = np.stack([(probe(mean_xyz + step * axis) - probes[2]) / step for axis in np.eye(3)], axis=1)
        # 4. The disc's radiance through the nodes (noted where half of it does not give half), as a sun lamp's
        #    strength S = radiance x pi sin^2(angle / 2) (core/lights/sun.py); rays that meet it see Cycles' disc,
        #    its bottom and top radiance through the same nodes (SunLight.limb).
        radiance = probes[2] - probes[0]
        if not np.allclose(2.0 * (probes[1] - probes[0]), radiance, rtol=1e-3, atol=1e-9 * max(1.0, radiance.max())):
            notes.append(f"the world's nodes after Sky Texture '{node.name}' do not scale with its colour: Primer's "
                         "sun lamp for its disc shines with the light they give the disc's mean radiance")
        irradiance = np.maximum(radiance, 0.0) * math.pi * math.sin(0.5 * model.size) ** 2
        if irradiance.max() <= 0.0:
            continue
        limb = np.concatenate([[model.elevation, model.rotation, model.horizon],
                               to_rgb @ (model.intensity * np.asarray(model.bottom, np.float64)),
                               to_rgb @ (model.intensity * np.asarray(model.top, np.float64))])
        lamps.append(SunLight(-towards, float(irradiance.max()), irradiance / irradiance.max(), model.size,
                              name=f"Sky Texture '{node.name}' sun", limb=limb))
    return lamps, notes


def register_number(compiler: "graph_.Compiler", register: int) -> int:
    """The final number of a register the compiler handed out (constants keep theirs; computed ones, provisional
    negative numbers, follow the constants, as Compiler.compile renumbers them)."""
    return len(compiler.constants) - 1 - register if register < 0 else register


def world_point(D: np.ndarray, layout: dict, paths=None) -> "graph_.ShadingPoint":
    """The shading point of the world seen along directions D (n, 3) float64, as Cycles sets it up
    (shader_setup_from_background): P and the Generated and Object coordinates D, the normal and the incoming
    direction -D, the ray's length FLT_MAX; the rays' graph.LightPaths `paths` (None: a light sample at the first
    bounce, EMISSION alone and no bounce counted, as Cycles' light_sample_shader_eval there and its importance bake)."""
    n = len(D)
    width = sum(w for _, w in layout.values())
    point = graph_.empty_point(n, width)
    attributes = np.zeros((n, width))
    for name in ("generated", "object"):
        offset, w = layout[name]
        attributes[:, offset:offset + w] = D
    return point._replace(attributes=attributes, N=-D, Ng=-D, path=graph_.light_paths(n, flags=graph_.PATH_EMISSION) if paths is None else paths, I=-D, P=D,
                          uv=np.zeros((n, 2)), t=np.full(n, np.finfo(np.float32).max))
