"""Cycles' Sky Texture (core/materials/sky.py) and its sun lamp (core/lights/world_graph.py sky_suns): closed forms of
an empty atmosphere, of the sky's symmetry about the sun, of the sun disc's mean radiance, of Preetham's zenith and of
Hosek / Wilkie's fitted curves at their ends; the compiled op (core/materials/sky.c) against the reference, for every
model, in a world's bake and on a surface (its disc drawn)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.lights import world_graph
from core.materials import sky
from core.materials.graph import GraphNode, Link


def test_an_empty_atmosphere_transmits_everything_and_scatters_nothing():
    """Air, aerosol and ozone 0: the transmittance to the top of the atmosphere is 1 at every altitude and angle, the
    sky black, and the sun's edges the sun's spectral irradiance over the disc's solid angle, to XYZ."""
    atmosphere = sky.Atmosphere(0.0, 0.0, 0.0)
    cos_zenith, altitude = np.linspace(-1.0, 1.0, 7), np.linspace(0.0, 1.0, 7)
    assert np.array_equal(atmosphere.transmittance(cos_zenith, altitude), np.ones((7, 4)))
    assert not sky.multiple_scattering_table(0.3, 100.0, 0.0, 0.0, 0.0, width=16, height=8).any()
    size = 0.01
    bottom, top = sky.multiple_scattering_sun(0.3, size, 100.0, 0.0, 0.0, 0.0)
    expected = sky.MS_SUN @ sky.MS_TO_XYZ / (2.0 * math.pi * (1.0 - math.cos(0.5 * size)))
    assert np.allclose(bottom, expected, rtol=1e-12) and np.allclose(top, expected, rtol=1e-12)


def test_an_atmosphere_dims_the_sun_more_near_the_horizon():
    """Earth's atmosphere: the sun's light is dimmed, and more through the longer path at a low elevation."""
    atmosphere = sky.Atmosphere(1.0, 1.0, 1.0)
    low, high = atmosphere.transmittance(np.array([0.1, 0.9]), np.zeros(2))
    assert (high < 1.0).all() and (low < high).all()


@pytest.mark.parametrize("kind", sky.SKY_TYPES)
def test_the_sky_is_symmetric_about_the_suns_vertical_plane(kind):
    """Directions mirrored in the vertical plane through the sun (the tables compute one half and mirror it; the
    lookup turns by the sun's rotation) see the same sky, for a sun rotated by an odd angle. (Single scattering's
    texels sit at longitudes 2 pi x / W - pi, half a texel off the lookup's centres, as in Cycles: symmetric to
    within that half texel, 0.35 degrees at its 512 columns; multiple scattering's exactly, here at 128 columns; Hosek /
    Wilkie's to the float32 rounding of its sun's angles, as Cycles passes them.)"""
    elevation, rotation = math.radians(20.0), math.radians(-130.0)
    if kind == "MULTIPLE_SCATTERING":
        e, r = sky.wrapped_sun(elevation, rotation)
        model = sky.Sky(kind, e, r, table=sky.multiple_scattering_table(e, 100.0, 1.0, 1.0, 1.0, 128, 64))
    else:
        model = sky.precompute(kind, elevation, rotation, sun_direction=(0.3, -0.5, 0.4))
    sun = sky.sun_towards(model.elevation, model.rotation) if kind not in ("PREETHAM", "HOSEK_WILKIE") else \
        np.array([0.3, -0.5, 0.4]) / np.linalg.norm([0.3, -0.5, 0.4])
    rng = np.random.default_rng(3)
    D = rng.normal(size=(200, 3))
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    normal = np.cross([0.0, 0.0, 1.0], sun)
    normal /= np.linalg.norm(normal)
    mirrored = D - 2.0 * (D @ normal)[:, None] * normal
    floats = model.floats()
    tolerance = {"SINGLE_SCATTERING": 2e-3, "HOSEK_WILKIE": 1e-5}.get(kind, 1e-9)
    assert np.allclose(sky.evaluate(floats, D), sky.evaluate(floats, mirrored), rtol=tolerance, atol=1e-9)


# (elevation, altitude m, air, aerosol, ozone): a low sun over the default sky, a sun just below the horizon seen from
# a hill through thin air and thick aerosols, a high sun from 50 km in clean air, the ground's observer (clamped to 1 m).
TABLE_SETTINGS = [(0.3, 100.0, 1.0, 1.0, 1.0), (-0.05, 2000.0, 0.5, 3.0, 2.0), (1.2, 50000.0, 2.0, 0.0, 0.0),
                  (0.01, 0.0, 1.0, 1.0, 1.0)]


@pytest.mark.parametrize("settings", TABLE_SETTINGS)
def test_the_compiled_scattering_tables_are_the_references(settings):
    """core/materials/sky_tables.c computes each scattering model's table (32 x 16 here; the full 512 x 256 costs the
    reference 14 s) and the multiple-scattering atmosphere's transmittance table as the numpy reference does, step by
    step in double: to a relative 1e-9 (measured: 2.6e-15 where numpy calls libm's exp; 8.5e-11 where numpy's own
    AVX-512 exp serves it, a few ulps apart, summed over the march; the transmittance to the bit)."""
    xyz, transmittance = sky.compiled_multiple_scattering_xyz(*settings, width=32, height=16)
    reference = sky.multiple_scattering_xyz(*settings, width=32, height=16)
    assert reference.max() > 0.0
    np.testing.assert_allclose(xyz, reference, rtol=1e-9, atol=0.0)
    np.testing.assert_allclose(transmittance, sky.Atmosphere(*settings[2:]).precompute().table, rtol=1e-9, atol=0.0)
    reference = sky.single_scattering_xyz(*settings, width=32, height=16)
    assert reference.max() > 0.0
    np.testing.assert_allclose(sky.compiled_single_scattering_xyz(*settings, width=32, height=16), reference,
                               rtol=1e-9, atol=0.0)


def test_the_sun_is_where_the_wrapped_angles_put_it():
    """An elevation past the zenith (100 degrees) is the sun at 80 degrees seen from the other side (rotation + 180);
    rotation turns the sun clockwise seen from above (Cycles' 2 pi - rotation): from +Y at 0 to +X at 90 degrees."""
    over = sky.sun_towards(*sky.wrapped_sun(math.radians(100.0), 0.4))
    under = sky.sun_towards(*sky.wrapped_sun(math.radians(80.0), 0.4 + math.pi))
    assert np.allclose(over, under, atol=1e-6)
    assert np.allclose(sky.sun_towards(*sky.wrapped_sun(0.0, 0.5 * math.pi)), [1.0, 0.0, 0.0], atol=1e-6)
    assert np.allclose(sky.sun_towards(*sky.wrapped_sun(0.0, 0.0)), [0.0, 1.0, 0.0], atol=1e-6)


def test_the_sun_discs_mean_radiance_is_its_limb_darkened_centre_colour():
    """A small disc of radiance linear from bottom to top times 1 - 0.6 (1 - sqrt(1 - r^2)) averages, over its
    cone, 0.8 (the limb darkening's mean over a disc: 1 - 0.6 / 3) times the mean of bottom and top (at the horizon,
    where the disc's elevations are symmetric about its centre's; higher up to second order in its size)."""
    bottom, top = np.array([1.0, 2.0, 3.0]), np.array([3.0, 2.0, 1.0])
    mean = sky.disc_mean_xyz(0.0, 1.0, 0.0095, 2.0, bottom, top, -1.0)
    assert np.allclose(mean, 2.0 * 0.8 * 0.5 * (bottom + top), rtol=1e-5), mean
    assert np.allclose(sky.disc_mean_xyz(0.5, 1.0, 0.0095, 2.0, bottom, top, -1.0), mean, rtol=5e-4)


def test_the_sky_suns_lamp_gives_the_irradiance_of_the_disc_through_the_worlds_strength():
    """The lamp of a Sky Texture times Strength 0.5: it shines from the disc's direction with the disc's angle and the
    irradiance of its radiance over the cone: 0.5 x RGB(disc's mean XYZ) x solid angle (Primer's sun: radiance
    S / (pi sin^2 a/2), integrated over 2 pi (1 - cos a/2))."""
    model = sky.precompute("SINGLE_SCATTERING", math.radians(30.0), 0.7)
    node = GraphNode("SKY", {"sky": model}, {}, "Sky Texture")
    lamps, notes = world_graph.sky_suns(Link(node, "Color"), 0.5)
    assert notes == [] and len(lamps) == 1
    lamp = lamps[0]
    assert np.allclose(-lamp.direction, sky.sun_towards(model.elevation, model.rotation))
    assert lamp.angle == pytest.approx(model.size)
    rgb = 0.5 * sky.xyz_to_rgb_clamped(model.disc_mean_xyz()[None, :])[0]
    half = 0.5 * model.size
    shines = lamp.strength * np.asarray(lamp.color) / (math.pi * math.sin(half) ** 2) * 2.0 * math.pi \
        * (1.0 - math.cos(half))
    assert np.allclose(shines, rgb * 2.0 * math.pi * (1.0 - math.cos(half)), rtol=1e-6)


@pytest.mark.parametrize("kind, degrees", [("SINGLE_SCATTERING", 30.0), ("MULTIPLE_SCATTERING", 0.2)])
def test_rays_that_meet_the_sky_suns_lamp_see_the_limb_darkened_disc_whose_light_is_the_lamps(kind, degrees):
    """A ray that meets the lamp of a Sky Texture (times Strength 0.5; a 2 degree disc, at 30 degrees, and at 0.2
    degrees, the earth's edge cutting it) sees the disc as the op draws it, 0.5 x RGB(disc_xyz) (limb-darkened,
    bottom to top), on both kernels; over a fine grid of the sky around it that radiance integrates to the lamp's
    irradiance, so its light samples and the rays that meet it carry the same light (MIS weighs one light)."""
    from core.lights.base import compiled_hit
    model = sky.precompute(kind, math.radians(degrees), 0.7, sun_size=math.radians(2.0))
    lamps, notes = world_graph.sky_suns(Link(GraphNode("SKY", {"sky": model}, {}, "Sky Texture"), "Color"), 0.5)
    lamp = lamps[0]
    sun = sky.sun_towards(model.elevation, model.rotation)
    t = np.cross([0.0, 0.0, 1.0], sun)
    t /= np.linalg.norm(t)
    b = np.cross(sun, t)
    a = np.linspace(-0.6 * model.size, 0.6 * model.size, 601)
    x, y = (g.ravel() for g in np.meshgrid(a, a))
    D = sun + x[:, None] * t + y[:, None] * b
    length = np.linalg.norm(D, axis=1)
    D /= length[:, None]
    escaping = (np.zeros((len(D), 3)), D, np.full(len(D), np.inf))
    seen, compiled = lamp.hit(*escaping), compiled_hit(lamp, *escaping)
    drawn = 0.5 * sky.xyz_to_rgb_clamped(sky.disc_xyz(D, model.elevation, model.rotation, model.size, model.intensity,
                                                      model.bottom, model.top, model.horizon))
    assert notes == [] and np.allclose(seen.radiance, drawn, rtol=1e-9, atol=1e-12 * drawn.max())
    assert np.array_equal(compiled.hit, seen.hit) and np.allclose(compiled.radiance, seen.radiance, rtol=1e-12)
    integral = ((a[1] - a[0]) ** 2 / length ** 3) @ seen.radiance
    irradiance = lamp.strength * np.asarray(lamp.color)
    assert np.allclose(integral, irradiance, rtol=1e-3, atol=1e-9 * irradiance.max()), (integral, irradiance)
    assert drawn[np.argmax(drawn[:, 1])].max() > 1.1 * irradiance.max() / (2.0 * math.pi * (1.0 - math.cos(
        0.5 * model.size)))                                  # (the centre brighter than the mean: not uniform)


def test_a_sky_without_its_disc_brings_no_lamp():
    """sun_disc off: Cycles draws no disc, so no lamp; the bake still holds the sky."""
    model = sky.precompute("SINGLE_SCATTERING", math.radians(30.0), 0.7, sun_disc=False)
    lamps, _ = world_graph.sky_suns(Link(GraphNode("SKY", {"sky": model}, {}, "Sky"), "Color"), 1.0)
    assert lamps == []


def test_preethams_sky_at_the_zenith_is_the_zenith_colour():
    """Straight up (theta 0, gamma the sun's zenith angle) Perez' function equals its normalisation, so the sky is
    Preetham's zenith luminance Y_z = 0.06 ((4.0453 T - 4.9710) tan chi - 0.2155 T + 2.4192) and chromaticity
    (x_z, y_z), chi = (4/9 - T/120)(pi - 2 theta_s), as XYZ = (x/y Y, Y, (1 - x - y)/y Y)."""
    T, theta = 3.0, math.radians(40.0)
    numbers = sky.preetham(np.array([0.0, math.sin(theta), math.cos(theta)]), T)
    chi = (4.0 / 9.0 - T / 120.0) * (math.pi - 2.0 * theta)
    Y = 0.06 * ((4.0453 * T - 4.9710) * math.tan(chi) - 0.2155 * T + 2.4192)
    t3, t2, t1 = theta ** 3, theta ** 2, theta
    x = ((0.00166 * t3 - 0.00375 * t2 + 0.00209 * t1) * T * T
         + (-0.02903 * t3 + 0.06377 * t2 - 0.03202 * t1 + 0.00394) * T
         + (0.11693 * t3 - 0.21196 * t2 + 0.06052 * t1 + 0.25886))
    y = ((0.00275 * t3 - 0.00610 * t2 + 0.00317 * t1) * T * T
         + (-0.04214 * t3 + 0.08970 * t2 - 0.04153 * t1 + 0.00516) * T
         + (0.15346 * t3 - 0.26756 * t2 + 0.06670 * t1 + 0.26688))
    xyz = sky.preetham_xyz(numbers, np.array([[0.0, 0.0, 1.0]]))[0]
    assert np.allclose(xyz, [x / y * Y, Y, (1.0 - x - y) / y * Y], rtol=1e-12)


def hosek_at_zenith(numbers: np.ndarray, channel: int, gamma: float) -> float:
    """Hosek and Wilkie's radiance of one channel straight up (theta 0), gamma from the sun, written out."""
    A, B, C, D, E, F, G, H, I = numbers[5 + 9 * channel:14 + 9 * channel]
    c = math.cos(gamma)
    mie = (1.0 + c * c) / (1.0 + I * I - 2.0 * I * c) ** 1.5
    return numbers[2 + channel] * (1.0 + A * math.exp(B / 1.01)) * (C + D * math.exp(E * gamma) + F * c * c + G * mie
                                                                     + H)


@pytest.mark.parametrize("turbidity, albedo", [(3.0, 0.0), (7.0, 1.0), (2.5, 0.5)])
def test_hosek_wilkie_at_the_zenith_and_the_horizon_are_the_ends_of_its_fitted_curves(turbidity, albedo):
    """The Bezier curves over the sun's elevation end at their control points: the sun at the zenith gives each
    channel's last control point and at the horizon its first, of the dataset's turbidity and albedo (their
    bilinear blend between them); the sky straight up is then the model's function at theta 0, written out, x 2 pi /
    683, through the XYZ to RGB matrix."""
    from core.materials import hosek_data
    whole, rest = int(turbidity), turbidity - int(turbidity)
    weights = {(a, t): (albedo if a else 1.0 - albedo) * (rest if t > whole else 1.0 - rest)
               for a in (0, 1) for t in (whole, whole + 1) if t <= 10}
    for direction, control in (((0.0, 0.0, 1.0), 5), ((0.0, 1.0, 0.0), 0)):
        numbers = sky.hosek(np.array(direction), turbidity, albedo)
        for k in range(3):
            radiance = sum(w * hosek_data.RADIANCES[k, a, t - 1, control] for (a, t), w in weights.items())
            parameters = sum(w * hosek_data.CONFIGURATIONS[k, a, t - 1, control] for (a, t), w in weights.items())
            assert numbers[2 + k] == pytest.approx(radiance, rel=1e-6)
            assert np.allclose(numbers[5 + 9 * k:14 + 9 * k], parameters, rtol=1e-6, atol=1e-6)
    sun_theta = math.radians(50.0)
    numbers = sky.hosek(np.array([0.0, math.sin(sun_theta), math.cos(sun_theta)]), turbidity, albedo)
    xyz = np.array([hosek_at_zenith(numbers, k, sun_theta) for k in range(3)])
    floats = sky.Sky("HOSEK_WILKIE", numbers=numbers).floats()
    expected = np.maximum(sky.XYZ_TO_RGB @ xyz, 0.0) * 2.0 * math.pi / 683.0
    assert np.allclose(sky.evaluate(floats, np.array([[0.0, 0.0, 1.0]]))[0], expected, rtol=1e-5)


def test_hosek_wilkie_reads_the_sun_below_the_horizon_at_the_horizon():
    """Cycles clamps the sun's zenith angle to pi / 2 before cooking the model: a sun below the horizon gives the
    numbers of the sun on it (its azimuth kept)."""
    below = sky.hosek(np.array([0.3, 0.8, -0.2]), 4.0, 0.3)
    on = sky.hosek(np.array([0.3, 0.8, 0.0]), 4.0, 0.3)
    assert below[1] == pytest.approx(0.5 * math.pi) and np.allclose(below, on, rtol=1e-6)


@pytest.mark.parametrize("kind", sky.SKY_TYPES)
def test_the_compiled_sky_op_bakes_a_world_as_the_reference_does(kind):
    """A world of each model (the disc left to its lamp) baked by graph.c and by numpy: the same float32 texels."""
    model = sky.precompute(kind, 0.5, -2.2, sun_direction=(0.5, -0.4, 0.3), turbidity=3.3)
    color = Link(GraphNode("SKY", {"sky": model}, {}, "Sky"), "Color")
    compiled = world_graph.bake(color, 1.0, width=128, kernels="compiled")
    reference = world_graph.bake(color, 1.0, width=128, kernels="numpy")
    assert reference.max() > 0.01 and reference.std() > 0.0
    np.testing.assert_allclose(compiled, reference, rtol=1e-6, atol=1e-12)


def test_a_sky_texture_on_a_surface_renders_alike_on_both_kernels_its_disc_drawn():
    """Each model as a plane's emission, read at a vector from the plane's Generated coordinates, (2 u - 1, 2 v - 1,
    0.3) as it is and normalised, a large sun disc (0.4 rad) among the normalised directions: the two kernels agree to
    the bit, and the scattering models show the disc towards the sun (brighter than the same sky without it)."""
    from test_procedural import assert_both_kernels_agree
    generated = Link(GraphNode("TEXCOORD", {}, {}), "Generated")
    vector = Link(GraphNode("VECTOR_MATH", {"operation": "MULTIPLY_ADD"},
                            {"Vector": generated, "Vector_001": (2.0, 2.0, 0.0), "Vector_002": (-1.0, -1.0, 0.3)}),
                  "Vector")
    unit = Link(GraphNode("VECTOR_MATH", {"operation": "NORMALIZE"}, {"Vector": vector}), "Vector")
    links = []
    for kind in sky.SKY_TYPES:
        for drawn, direction in ((True, unit), (False, unit), (True, vector)):
            model = sky.precompute(kind, 0.5, 0.0, sun_size=0.4, sun_direction=(0.2, 0.6, 0.4), disc_drawn=drawn)
            links.append(Link(GraphNode("SKY", {"sky": model}, {"Vector": direction}, kind), "Color"))
    assert_both_kernels_agree(links, generated=True)
    D = sky.sun_towards(*sky.wrapped_sun(0.5, 0.0))[None, :]
    for kind in ("MULTIPLE_SCATTERING", "SINGLE_SCATTERING"):
        with_disc, without = (sky.evaluate(sky.precompute(kind, 0.5, 0.0, sun_size=0.4, disc_drawn=d).floats(), D)
                              for d in (True, False))
        assert (with_disc > 10.0 * without).all(), (with_disc, without)


def test_nodes_that_do_not_scale_the_skys_colour_are_noted_for_its_sun():
    """The sky multiplied by itself (a Mix Multiply of A = B = sky) does not scale with its colour: the lamp then
    carries the light those nodes give the disc's mean radiance, and the add-on is told so."""
    model = sky.precompute("SINGLE_SCATTERING", math.radians(30.0), 0.7)
    color = Link(GraphNode("SKY", {"sky": model}, {}, "Sky Texture"), "Color")
    props = {"data_type": "RGBA", "blend_type": "MULTIPLY", "clamp_factor": True, "clamp_result": False}
    squared = Link(GraphNode("MIX", props, {"Factor": 1.0, "A": color, "B": color}, "Multiply"), "Result")
    lamps, notes = world_graph.sky_suns(squared, 1.0)
    assert len(lamps) == 1 and len(notes) == 1 and "Sky Texture" in notes[0], notes


def test_the_discs_mean_radiance_times_its_solid_angle_is_its_radiance_integrated_over_the_sky():
    """The disc at 30 degrees of elevation (bottom and top differ) integrated by brute force over a fine grid of the
    sky around it (directions on the tangent plane, weighted by the solid angle of each cell, cos^3 of its offset)
    equals its mean radiance times the cone's solid angle 2 pi (1 - cos(size / 2))."""
    elevation, rotation, size = math.radians(30.0), 0.9, 0.0095
    bottom, top = np.array([1.0, 2.0, 4.0]), np.array([3.0, 2.0, 1.0])
    sun = sky.sun_towards(elevation, rotation)
    t = np.cross([0.0, 0.0, 1.0], sun)
    t /= np.linalg.norm(t)
    b = np.cross(sun, t)
    n, reach = 801, 0.6 * size
    a = np.linspace(-reach, reach, n)
    x, y = (g.ravel() for g in np.meshgrid(a, a))
    D = sun + x[:, None] * t + y[:, None] * b
    length = np.linalg.norm(D, axis=1)
    D /= length[:, None]
    cell = (a[1] - a[0]) ** 2 / length ** 3
    integral = cell @ sky.disc_xyz(D, elevation, rotation, size, 1.0, bottom, top, -1.0)
    expected = sky.disc_mean_xyz(elevation, rotation, size, 1.0, bottom, top, -1.0) * 2.0 * math.pi \
        * (1.0 - math.cos(0.5 * size))
    assert np.allclose(integral, expected, rtol=2e-4), (integral, expected)


def test_the_xyz_matrix_takes_d65_white_to_rgb_white():
    """Cycles' XYZ to scene-linear matrix (Blender's configuration: XYZ with a D65 white to Linear Rec.709) takes the
    D65 white point (chromaticity x 0.3127, y 0.3290; luminance 1) to (1, 1, 1)."""
    x, y = 0.3127, 0.3290
    assert np.allclose(sky.XYZ_TO_RGB @ [x / y, 1.0, (1.0 - x - y) / y], 1.0, atol=1e-6)
