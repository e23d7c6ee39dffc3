"""A world made of shader nodes, baked into an equirectangular image of its radiance.

Cycles evaluates the world's shader for every ray that leaves the scene, at the ray's direction D (its shading point
has P = D, N = -D: the Generated and Object coordinates are D), and bakes it into a map only to importance-sample
it. Primer bakes it once per render into an equirectangular image at the texel centres of its world lookup
(core/lights/world.py: texel centres at (i + 1/2) / W, linear in between) and then renders that image as an
environment: the same light, importance-sampled from the same map, on both kernels. Between texel centres the bake
interpolates linearly where Cycles evaluates the graph itself: a smooth sky or a blurred HDRI matches, a pattern
finer than a texel seen straight by the camera is softened (docs/blender.md gives the measured error).

Only the rays that light the scene are baked: a Light Path node is evaluated as for a bounce ray (Is Camera Ray 0),
so a world that shows the camera something else is reported by the add-on.
"""
from __future__ import annotations

import numpy as np

from ..materials import graph as graph_
from ..materials import textures as textures_
from .world import uv_to_direction

# The baked image's width (its height is half): 0.18 degrees a texel.
BAKE_WIDTH = 2048
# Directions baked per pass of the node-graph program (bounds the registers' memory).
BAKE_BATCH = 1 << 16


def bake(color, strength, width: int = BAKE_WIDTH) -> np.ndarray:
    """The world's radiance color x strength as an equirectangular image (width / 2, width, 3) float32, row 0 at
    the bottom (v = 0), texel (i, j) at the direction of u = (j + 1/2) / width, v = (i + 1/2) / (width / 2).

    color, strength: the Background's inputs: a constant ((3,) or a float) or a graph.Link into the world's nodes.
    """
    # 1. Compile both inputs into one program over the attributes a world's shading point has.
    layout = graph_.layout_of({"generated", "object"})
    nodes = [(None, 1.0, {"color": color, "strength": strength})]
    images = graph_.images_of(nodes)
    index = {id(image): k for k, image in enumerate(images) if image is not None}
    compiler = graph_.Compiler(layout, lambda image: index.get(id(image), -1), material="the world")
    color_register = compiler.value(color, 3, 0.0)
    strength_register = compiler.value(strength, 1, 1.0)
    program = compiler.compile([])
    registers = [register_number(compiler, r) for r in (color_register, strength_register)]
    textures = textures_.TextureSet.of([image for image in images if image is not None])
    # 2. Run it at the texel centres' directions, a batch at a time.
    height = max(1, width // 2)
    u, v = np.meshgrid((np.arange(width) + 0.5) / width, (np.arange(height) + 0.5) / height)
    directions = uv_to_direction(u.ravel(), v.ravel())
    radiance = np.empty((len(directions), 3), np.float32)
    for start in range(0, len(directions), BAKE_BATCH):
        D = directions[start:start + BAKE_BATCH]
        reg = graph_.run(program, world_point(D, layout), textures)
        radiance[start:start + BAKE_BATCH] = reg[:, registers[0]:registers[0] + 3] * reg[:, registers[1]:registers[1] + 1]
    return radiance.reshape(height, width, 3)


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
    return point._replace(attributes=attributes, N=-D, Ng=-D, ray=np.full(n, float(graph_.RAY_BOUNCE)), I=-D, P=D,
                          uv=np.zeros((n, 2)), t=np.full(n, np.finfo(np.float32).max))
