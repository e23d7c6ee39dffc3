"""A world made of shader nodes, baked into an equirectangular image of its radiance.

Cycles evaluates the world's shader for every ray that leaves the scene, at the ray's direction D (its shading point
has P = D, N = -D: the Generated and Object coordinates are D), and bakes it into a map only to importance-sample
it. Primer bakes it once per render into an equirectangular image at the texel centres of its world lookup
(core/lights/world.py: texel centres at (i + 1/2) / W, linear in between) and then renders that image as an
environment: the same light, importance-sampled from the same map, on both kernels. Between texel centres the bake
interpolates linearly where Cycles evaluates the graph itself: a smooth sky or a blurred HDRI matches, a pattern
finer than a texel seen straight by the camera is softened (docs/blender.md gives the measured error).

A Sky Texture's sun disc, about 0.5 degrees wide and very bright, covers only some 7 texel centres 0.18 degrees apart:
summed there its light comes out 0.8 to 1.04 times the disc's (by where the centres fall). The bake leaves it out, and
`sky_suns` makes it a sun lamp of the world's.

Only the rays that light the scene are baked: a Light Path node is evaluated as for a bounce ray (Is Camera Ray 0),
so a world that shows the camera something else is reported by the add-on.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..materials import graph as graph_
from ..materials import sky as sky_
from ..materials import textures as textures_
from .sun import SunLight
from .world import uv_to_direction

# The baked image's width (its height is half): 0.18 degrees a texel.
BAKE_WIDTH = 2048
# Directions baked per pass of the node-graph program (bounds the registers' memory).
BAKE_BATCH = 1 << 16


class WorldProgram(NamedTuple):
    """A world's Background inputs compiled into one program: the program, the registers of colour (3) and strength
    (1), the textures it reads, the attribute layout, and where each Sky Texture's floats start in the program's
    float tables (by the id of its core/materials/sky.py Sky)."""

    program: "graph_.Program"
    registers: tuple
    textures: "textures_.TextureSet"
    layout: dict
    sky_starts: dict


def compile_world(color, strength) -> WorldProgram:
    """Compile the Background's color and strength (constants or graph.Links) over a world's shading point."""
    layout = graph_.layout_of({"generated", "object"})
    nodes = [(None, 1.0, {"color": color, "strength": strength})]
    images = graph_.images_of(nodes)
    index = {id(image): k for k, image in enumerate(images) if image is not None}
    compiler = graph_.Compiler(layout, lambda image: index.get(id(image), -1), material="the world")
    color_register = compiler.value(color, 3, 0.0)
    strength_register = compiler.value(strength, 1, 1.0)
    program = compiler.compile([])
    registers = tuple(register_number(compiler, r) for r in (color_register, strength_register))
    textures = textures_.TextureSet.of([image for image in images if image is not None])
    return WorldProgram(program, registers, textures, layout, dict(compiler.sky_starts))


def radiance_along(world: WorldProgram, D: np.ndarray, program=None) -> np.ndarray:
    """The world's radiance colour x strength (n, 3) float64 along directions D (n, 3) (`program`: the world's
    program with other float tables, else its own)."""
    reg = graph_.run(world.program if program is None else program, world_point(D, world.layout), world.textures)
    c, s = world.registers
    return reg[:, c:c + 3] * reg[:, s:s + 1]


def bake(color, strength, width: int = BAKE_WIDTH) -> np.ndarray:
    """The world's radiance color x strength as an equirectangular image (width / 2, width, 3) float32, row 0 at
    the bottom (v = 0), texel (i, j) at the direction of u = (j + 1/2) / width, v = (i + 1/2) / (width / 2).

    color, strength: the Background's inputs: a constant ((3,) or a float) or a graph.Link into the world's nodes.
    """
    # 1. Compile both inputs into one program over the attributes a world's shading point has.
    world = compile_world(color, strength)
    # 2. Run it at the texel centres' directions, a batch at a time.
    height = max(1, width // 2)
    u, v = np.meshgrid((np.arange(width) + 0.5) / width, (np.arange(height) + 0.5) / height)
    directions = uv_to_direction(u.ravel(), v.ravel())
    radiance = np.empty((len(directions), 3), np.float32)
    for start in range(0, len(directions), BAKE_BATCH):
        radiance[start:start + BAKE_BATCH] = radiance_along(world, directions[start:start + BAKE_BATCH])
    return radiance.reshape(height, width, 3)


def sky_suns(color, strength) -> tuple:
    """The sun discs of the world's Sky Textures as sun lamps, which the bake leaves out: ([SunLight], notes).

    Each lamp shines from the disc's centre with its angle, with the radiance the world's nodes give the disc's mean
    XYZ radiance (its limb darkening and its bottom-to-top colour integrated over the disc, core/materials/sky.py
    disc_mean_xyz): the world's radiance at the sun with that XYZ added to the sky's, less without it (exact where
    the nodes after the Sky Texture are linear in its colour, noted where they are not). A Sky Texture whose Vector is
    linked lights nothing with its sun (the add-on says so).
    """
    # 1. The Sky Textures with a disc, each once, that read the ray's direction.
    nodes = [(None, 1.0, {"color": color, "strength": strength})]
    skies = [link.node for link in graph_.links_under(nodes) if link.node.kind == "SKY"]
    skies = [node for k, node in enumerate(skies) if all(node is not other for other in skies[:k])
             and not isinstance(node.inputs.get("Vector"), graph_.Link) and node.props["sky"].size > 0.0]
    if not skies:
        return [], []
    world = compile_world(color, strength)
    lamps, notes = [], []
    for node in skies:
        # 2. The disc's mean XYZ radiance and where it is.
        model = node.props["sky"]
        mean_xyz = model.disc_mean_xyz()
        towards = sky_.sun_towards(model.elevation, model.rotation)
        # 3. The world's radiance at the sun with 0, half and all of it added to the sky's (the op's probe XYZ).
        start = world.sky_starts[id(model)]
        probes = []
        for scale in (0.0, 0.5, 1.0):
            ramps = world.program.ramps.copy()
            ramps[start + sky_.PROBE.start:start + sky_.PROBE.stop] = scale * mean_xyz
            probes.append(radiance_along(world, towards[None, :], world.program._replace(ramps=ramps))[0])
        # 4. The disc's radiance through the nodes (noted where half of it does not give half), as a sun lamp's
        #    strength S = radiance x pi sin^2(angle / 2) (core/lights/sun.py).
        radiance = probes[2] - probes[0]
        if not np.allclose(2.0 * (probes[1] - probes[0]), radiance, rtol=1e-3, atol=1e-9 * max(1.0, radiance.max())):
            notes.append(f"the world's nodes after Sky Texture '{node.name}' do not scale with its colour: Primer's "
                         "sun lamp for its disc shines with the light they give the disc's mean radiance")
        irradiance = np.maximum(radiance, 0.0) * math.pi * math.sin(0.5 * model.size) ** 2
        if irradiance.max() <= 0.0:
            continue
        lamps.append(SunLight(-towards, float(irradiance.max()), irradiance / irradiance.max(), model.size,
                              name=f"Sky Texture '{node.name}' sun"))
    return lamps, notes


def register_number(compiler: "graph_.Compiler", register: int) -> int:
    """The final number of a register the compiler handed out (constants keep theirs; computed ones, provisional
    negative numbers, follow the constants, as Compiler.compile renumbers them)."""
    return len(compiler.constants) - 1 - register if register < 0 else register


def world_point(D: np.ndarray, layout: dict) -> "graph_.ShadingPoint":
    """The shading point of the world seen along directions D (n, 3) float64, as Cycles sets it up
    (shader_setup_from_background): P and the Generated and Object coordinates D, the normal and the incoming
    direction -D, the ray's length FLT_MAX; a bounce ray (Light Path: not a camera ray)."""
    n = len(D)
    width = sum(w for _, w in layout.values())
    point = graph_.empty_point(n, width)
    attributes = np.zeros((n, width))
    for name in ("generated", "object"):
        offset, w = layout[name]
        attributes[:, offset:offset + w] = D
    return point._replace(attributes=attributes, N=-D, Ng=-D, path=graph_.light_paths(n, flags=0), I=-D, P=D,
                          uv=np.zeros((n, 2)), t=np.full(n, np.finfo(np.float32).max))
