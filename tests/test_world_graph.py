"""A world made of shader nodes, baked into the equirectangular image Primer renders (core/lights/world_graph.py):
closed forms of the bake's directions and of the Environment Texture's lookup."""
from __future__ import annotations

import numpy as np

from core.lights import world_graph
from core.lights.world import World, bilinear_equirect, direction_to_uv, uv_to_direction
from core.materials import textures
from core.materials.graph import GraphNode, Link


def generated_axis(axis: str) -> Link:
    """A Link to one component of the Generated coordinate (in a world: of the ray's direction)."""
    coords = GraphNode("TEXCOORD", {}, {}, "Texture Coordinate")
    return Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(coords, "Generated")}, "Separate XYZ"), axis)


def test_each_texel_holds_the_graph_at_its_centres_direction():
    """Colour (Z, Z, Z) x strength 2 baked at width 64: texel (i, j) holds 2 cos(theta) of the direction of
    u = (j + 1/2) / 64, v = (i + 1/2) / 32, the centre the world's lookup reads it at."""
    image = world_graph.bake(generated_axis("Z"), 2.0, width=64)
    assert image.shape == (32, 64, 3) and image.dtype == np.float32
    v = (np.arange(32) + 0.5) / 32
    expected = 2.0 * np.cos(np.pi * (1.0 - v))                     # z = cos(theta), theta = pi (1 - v)
    assert np.allclose(image[:, :, 0], expected[:, None], atol=1e-6)
    assert np.allclose(image[:, :, 0], image[:, :, 2])


def test_the_bake_reads_azimuth_as_the_worlds_lookup_does():
    """X and Y baked: each texel centre's (x, y) is the direction whose (u, v) the world maps to that texel."""
    x, y = world_graph.bake(generated_axis("X"), 1.0, width=32), world_graph.bake(generated_axis("Y"), 1.0, width=32)
    u, v = np.meshgrid((np.arange(32) + 0.5) / 32, (np.arange(16) + 0.5) / 16)
    D = uv_to_direction(u.ravel(), v.ravel())
    assert np.allclose(x[:, :, 0].ravel(), D[:, 0], atol=1e-6) and np.allclose(y[:, :, 0].ravel(), D[:, 1], atol=1e-6)


def test_an_environment_texture_baked_at_its_own_size_gives_back_its_texels():
    """An equirectangular image through the graph's Environment Texture (Cycles' u = 1/2 - atan2(y, x) / 2 pi,
    v = 1/2 + atan2(z, |(x, y)|) / pi), baked at the image's own width: texel centres meet, so the bake is the image,
    and the world renders it as the plain environment does."""
    rng = np.random.default_rng(7)
    pixels = rng.random((16, 32, 3)).astype(np.float32)
    environment = GraphNode("ENVIRONMENT", {"image": textures.Image(pixels), "interpolation": "Linear"}, {},
                            "Environment Texture")
    baked = world_graph.bake(Link(environment, "Color"), 1.5, width=32)
    assert np.allclose(baked, 1.5 * pixels, atol=2e-5)
    D = uv_to_direction(*(rng.random((2, 200))))
    plain, graph = World(image=pixels, strength=1.5), World(image=baked)
    assert np.allclose(plain.radiance(D), graph.radiance(D), atol=3e-5)
    u, v = direction_to_uv(D)
    assert np.allclose(graph.radiance(D), 1.5 * bilinear_equirect(pixels, u, v), atol=3e-5)
