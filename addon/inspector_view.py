"""How the ray inspector shows a PixelRecord (core/teaching/inspector.py): lines, points, panel rows, picking.

Pure functions, no bpy and no gpu: addon/inspector.py hands their output to
Blender's `gpu` module and panels, and tests check them without a GPU.
"""
from __future__ import annotations

import math
from typing import NamedTuple, Optional

import numpy as np

# Colours (RGBA, 0..1) of what the 3D viewport shows.
PRIMARY = (1.0, 0.85, 0.2, 1.0)          # camera ray, from the near clip plane to I
MISSED = (1.0, 0.85, 0.2, 0.35)          # camera ray that hit nothing (drawn dim, fixed length)
SHADING_NORMAL = (0.25, 0.6, 1.0, 1.0)   # N, interpolated: used for N.L
FACE_NORMAL = (0.95, 0.35, 0.95, 1.0)    # Ng, the triangle's own: decides whether a light can be visible
UNOCCLUDED = (0.3, 1.0, 0.35, 1.0)       # shadow ray that reached its light
OCCLUDED = (1.0, 0.2, 0.15, 1.0)         # shadow ray that something blocked
NOT_CAST = (0.6, 0.6, 0.6, 0.6)          # no shadow ray: the light is behind N or the face (drawn dashed)
HIT_POINT = (1.0, 1.0, 1.0, 1.0)

DASHES = 12                              # dashes on a "not cast" line


class Segment(NamedTuple):
    """One straight line to draw: start, end (3,) float64 world points, RGBA colour, what it shows."""

    start: np.ndarray
    end: np.ndarray
    color: tuple
    part: str          # "primary" | "missed" | "N" | "Ng" | "unoccluded" | "occluded" | "not cast"


class Marker(NamedTuple):
    """One point to draw: (3,) float64 world point, RGBA colour, what it marks."""

    point: np.ndarray
    color: tuple
    part: str          # "I" | "light"


def shadow_state(light) -> str:
    """Return "unoccluded", "occluded" or "not cast" for a LightRecord."""
    if not light.cast:
        return "not cast"
    return "occluded" if light.occluded else "unoccluded"


SHADOW_COLORS = {"unoccluded": UNOCCLUDED, "occluded": OCCLUDED, "not cast": NOT_CAST}


def dashed(start: np.ndarray, end: np.ndarray, dashes: int = DASHES) -> list:
    """Return the visible pieces [(start, end), ...] of a dashed line: `dashes` pieces with equal gaps between."""
    pieces = 2 * dashes - 1
    return [(start + (end - start) * (2 * i / pieces), start + (end - start) * ((2 * i + 1) / pieces))
            for i in range(dashes)]


def scale_of(record) -> float:
    """Return a length that suits the picture: the camera ray's length to I (or 1 when nothing was hit)."""
    if record.hit and math.isfinite(record.t) and record.t > 0:
        return float(np.linalg.norm(record.I - record.origin))
    return 1.0


def overlay_segments(record, normal_length: float = 0.0, ray_length: float = 0.0, primary: bool = True,
                     normals: bool = True, shadow_rays: bool = True) -> list:
    """Return the Segments that show `record` in the 3D viewport.

    normal_length: length of the N and Ng lines (0: a fifth of the camera ray's length);
    ray_length: length drawn for rays without an end, a missed camera ray or a sun's
    shadow ray (0: the camera ray's length). Shadow rays are drawn from their offset origin to
    where they stop; a light behind N or the face gets a dashed line from I to the light.
    """
    scale = scale_of(record)
    normal_length = normal_length if normal_length > 0 else 0.2 * scale
    ray_length = ray_length if ray_length > 0 else scale
    segments = []
    # 1. The camera ray.
    if primary and record.valid:
        if record.hit:
            segments.append(Segment(record.origin, record.I, PRIMARY, "primary"))
        else:
            segments.append(Segment(record.origin, record.origin + ray_length * record.direction, MISSED, "missed"))
    if not record.hit:
        return segments
    # 2. The two normals at I.
    if normals:
        segments.append(Segment(record.I, record.I + normal_length * record.N, SHADING_NORMAL, "N"))
        segments.append(Segment(record.I, record.I + normal_length * record.Ng, FACE_NORMAL, "Ng"))
    # 3. One shadow ray per light.
    if shadow_rays:
        for light in record.lights:
            state = shadow_state(light)
            far = light.light_point if light.light_point is not None else None
            if state == "not cast":
                end = far if far is not None else record.I + ray_length * light.L
                segments += [Segment(a, b, NOT_CAST, state) for a, b in dashed(record.I, end)]
                continue
            end = light.shadow_end if np.isfinite(light.shadow_end).all() else \
                light.shadow_origin + ray_length * light.L
            segments.append(Segment(light.shadow_origin, end, SHADOW_COLORS[state], state))
    return segments


def overlay_markers(record, shadow_rays: bool = True) -> list:
    """Return the Markers of `record`: the hit point I, and each light point a shadow ray aims at."""
    if not record.hit:
        return []
    markers = [Marker(record.I, HIT_POINT, "I")]
    if shadow_rays:
        markers += [Marker(light.light_point, SHADOW_COLORS[shadow_state(light)], "light")
                    for light in record.lights if light.light_point is not None]
    return markers


def marker_segments(markers: list, size: float) -> list:
    """Return each Marker as a small 3D cross of three Segments of length `size` (points need no point size)."""
    segments = []
    for marker in markers:
        for axis in np.eye(3):
            segments.append(Segment(marker.point - 0.5 * size * axis, marker.point + 0.5 * size * axis,
                                    marker.color, marker.part))
    return segments


# ----------------------------------------------------------------------------
# The panel's numbers
# ----------------------------------------------------------------------------

def number(value: Optional[float]) -> str:
    """Format a scalar for the panel: 5 significant digits, "inf", or "-" for None."""
    if value is None:
        return "-"
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return f"{value:.5g}"


def vector(values) -> str:
    """Format a (3,) vector for the panel: (x, y, z) with 4 decimals."""
    if values is None:
        return "-"
    return "(" + ", ".join(f"{float(c):.4f}" for c in values) + ")"


def colour(values) -> str:
    """Format an RGB triple for the panel, 5 significant digits each."""
    return "(" + ", ".join(number(float(c)) for c in values) + ")"


def panel_sections(record, height: Optional[int] = None) -> list:
    """Return the panel's content: [(title, [(label, text), ...]), ...] for `record`.

    height: the image height in pixels, to show Blender's row number (from the bottom) as well.
    """
    pixel = [("Pixel", f"{record.x}, {record.y} (row from the top)")]
    if height is not None:
        pixel.append(("Blender Y", f"{height - 1 - record.y} (row from the bottom)"))
    camera = pixel + [("Ray origin", vector(record.origin)), ("D", vector(record.direction))]
    if getattr(record, "lens", None) is not None:
        camera.insert(len(pixel), ("Lens point", vector(record.lens) + " on the aperture (depth of field)"))
    if not record.valid:
        return [("Camera ray", camera + [("Hit", "outside the fisheye's image circle: black")])]
    if not record.hit:
        return [("Camera ray", camera + [("Hit", "nothing: the pixel shows the world"),
                                         ("Pixel colour", colour(record.radiance))])]
    sections = [("Camera ray", camera + [
        ("Object", f"{record.object_name or '?'} (triangle {record.triangle})"),
        ("t", number(record.t)),
        ("I", vector(record.I)),
        ("N", vector(record.N) + (" smooth" if record.smooth else " flat")),
        ("Ng", vector(record.Ng)),
        ("u, v", f"{record.u:.4f}, {record.v:.4f}"),
        ("Albedo", colour(record.albedo)),
        ("Shadow offset", record.shadow_method),
    ])]
    for light in record.lights:
        state = shadow_state(light)
        shadow = state if state != "not cast" else f"not cast: {light.reason}"
        rows = [
            ("L", vector(light.L)),
            ("r", number(light.distance)),
            ("N·L", number(light.n_dot_l)),
            ("Ng·L", number(light.ng_dot_l)),
            ("1/r²", number(light.inverse_square)),
            ("E normal", colour(light.irradiance)),
            ("Shadow ray", shadow),
            ("Contribution", colour(light.contribution)),
        ]
        if light.sampled:
            rows.append(("Sample", "one, at the light's centre"))
            rows.append(("pdf", number(light.pdf)))
        rows.append(("MIS weight", number(light.mis_weight)))
        sections.append((f"{light.kind.title()} '{light.name}'", rows))
    if getattr(record, "bsdf_sample", None) is not None:
        wi, pdf, found = record.bsdf_sample
        sections.append(("BSDF sample", [("ωi", vector(wi)), ("pdf", number(pdf) if pdf != float("inf") else "delta"),
                                         ("Light found (MIS-weighted)", colour(found))]))
    scattering = getattr(record, "scattering", ())
    if scattering:
        sections.append(("Medium", [(f"Scattered ({point.kind})", vector(point.P)) for point in scattering]))
    material = getattr(record, "material", None)
    if material is not None:
        rows = [("Name", material.name), ("UV", vector(material.uv) if material.uv is not None else "no UV map")]
        if material.tangent_frame is not None:
            T, B, _ = material.tangent_frame
            rows += [("Tangent T", vector(T)), ("Bitangent B", vector(B))]
        for texture in material.textures:
            rows.append((f"Texel '{texture.image}'", f"at {number(texture.x)}, {number(texture.y)}: "
                                                     f"{colour(texture.rgba[:3])} α {number(texture.rgba[3])}"))
        for node in getattr(material, "nodes", ()):
            value = number(node.value[0]) if len(node.value) == 1 else (colour(node.value) if node.kind == "color"
                                                                        else vector(node.value))
            rows.append((f"Node '{node.node}' {node.output}", value))
        for closure in material.closures:
            alpha = "" if closure.alpha is None else f", α {number(closure.alpha)}"
            rows.append((f"Closure {closure.bsdf.lower()}", f"{colour(closure.weight)}, sampling weight "
                                                             f"{number(closure.sample_weight)}{alpha}"))
        sections.append(("Material", rows))
    sections.append(("Pixel", [("Sum", colour(record.radiance)),
                               ("Formula", "Σ albedo/π · E · max(N·L, 0) · V")]))
    if record.warnings:
        sections.append(("Notes", [("", note) for note in record.warnings]))
    return sections


# ----------------------------------------------------------------------------
# Picking: from the Image Editor to render pixels
# ----------------------------------------------------------------------------

def image_uv_to_pixel(u: float, v: float, image_size: tuple, full_size: tuple, border: tuple) -> tuple:
    """Return the render pixel (x, y), row 0 at the top, under image coordinates (u, v) of a render.

    u, v: the Image Editor's view coordinates (0..1 across the shown image, v upwards, as Blender's
    rows run bottom-up); image_size: (w, h) of the shown image, or (0, 0) if unknown; full_size:
    (W, H) of the frame; border: (x, y, w, h) rendered rectangle, y from the bottom (addon/export.py).
    The shown image is the whole frame, or just the border when rendered with "crop to border".
    Raises ValueError outside the image or when the image does not match the render settings.
    """
    W, H = full_size
    bx, by, bw, bh = border
    iw, ih = (int(image_size[0]), int(image_size[1])) if image_size else (0, 0)
    if iw <= 0 or ih <= 0:
        iw, ih = W, H
    if (iw, ih) == (W, H):
        x0, y0 = 0, 0                     # the whole frame
    elif (iw, ih) == (bw, bh):
        x0, y0 = bx, by                   # a cropped border render
    else:
        raise ValueError(f"the image is {iw}x{ih} pixels but the scene renders {W}x{H}: render again")
    if not (0.0 <= u < 1.0 and 0.0 <= v < 1.0):
        raise ValueError("the click is outside the image")
    column = min(iw - 1, int(math.floor(u * iw)))
    row_from_bottom = min(ih - 1, int(math.floor(v * ih)))
    return x0 + column, H - 1 - (y0 + row_from_bottom)
