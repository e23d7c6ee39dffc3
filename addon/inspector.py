"""The ray inspector in Blender: pick a pixel, see its rays in the 3D viewport and its numbers in a panel.

- `PRIMER_OT_inspect_pixel` (primer.inspect_pixel) exports the evaluated scene and runs
  core.teaching.inspector.inspect_pixel for the pixel typed in `scene.primer_inspector`.
- `PRIMER_OT_pick_pixel` (primer.pick_pixel), started from the Image Editor's sidebar, inspects
  every pixel clicked on a render until Esc or a right-click.
- A SpaceView3D draw handler draws the last record with the `gpu` module (not in background mode).
- Panels (3D viewport and Image Editor sidebars, "Primer" tab; Render properties) list the numbers.

The record is kept here as plain Python (`state`); what is drawn and listed comes from the pure
functions of addon/inspector_view.py.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Optional

import bpy
from bpy.props import BoolProperty, FloatProperty, IntProperty, PointerProperty

from . import export, inspector_view
from .ui import PrimerOnly

log = logging.getLogger("primer")


@dataclass
class InspectorState:
    """The last inspection: its record (core.teaching.inspector.PixelRecord), the scene it belongs to, the frame height."""

    record: object = None
    scene_name: str = ""
    height: Optional[int] = None
    error: str = ""


state = InspectorState()


class PrimerInspectorSettings(bpy.types.PropertyGroup):
    """The pixel to inspect and what to draw, stored on the scene as `scene.primer_inspector`."""

    x: IntProperty(name="X", default=0, min=0, description="Pixel column, from the left (0 is the left edge)")
    y: IntProperty(name="Y", default=0, min=0,
                   description="Pixel row, from the TOP (0 is the top row, as in Primer's core; "
                               "Blender's image editor counts rows from the bottom)")
    show_overlay: BoolProperty(name="Show in Viewport", default=True,
                               description="Draw the inspected rays in the 3D viewport")
    show_primary: BoolProperty(name="Camera Ray", default=True, description="Draw the camera ray, up to the hit")
    show_normals: BoolProperty(name="Normals", default=True,
                               description="Draw the shading normal N (blue) and the face normal Ng (pink)")
    show_shadow_rays: BoolProperty(name="Shadow Rays", default=True,
                                   description="Draw one shadow ray per light: green unoccluded, red occluded, "
                                               "grey dashed when none was cast (light behind the surface)")
    normal_length: FloatProperty(name="Normal Length", default=0.0, min=0.0, soft_max=10.0, unit="LENGTH",
                                 description="Length of the drawn normals; 0: a fifth of the camera ray's length")
    line_width: FloatProperty(name="Line Width", default=2.0, min=1.0, max=10.0,
                              description="Width of the drawn lines in pixels")


# ----------------------------------------------------------------------------
# Inspecting
# ----------------------------------------------------------------------------

def inspect(context, x: int, y: int):
    """Export the evaluated scene, inspect pixel (x, y) (row 0 at the top), store and return the record.

    Raises export.ExportError or ValueError with a message for Blender's report.
    """
    from ..core.teaching import inspector as core_inspector

    depsgraph = context.evaluated_depsgraph_get()
    exported = export.export_scene(depsgraph)
    record = core_inspector.inspect_pixel(exported.scene, exported.settings, x, y)
    state.record = record
    state.scene_name = context.scene.name
    state.height = exported.full_size[1]
    state.error = ""
    return record


def redraw(context) -> None:
    """Ask every 3D viewport, Image Editor and Properties editor to redraw (nothing to do in background mode)."""
    for window in context.window_manager.windows:
        for area in window.screen.areas:
            if area.type in {"VIEW_3D", "IMAGE_EDITOR", "PROPERTIES"}:
                area.tag_redraw()


def summary(record) -> str:
    """Return a one-line report of a record."""
    if not record.hit:
        return f"Primer: pixel ({record.x}, {record.y}) hits nothing"
    states = ", ".join(f"{light.name}: {inspector_view.shadow_state(light)}" for light in record.lights)
    return (f"Primer: pixel ({record.x}, {record.y}) hits '{record.object_name}' at t = {record.t:.4g}"
            + (f"; {states}" if states else ""))


def run_inspection(operator, context, x: int, y: int) -> set:
    """Inspect (x, y) for an operator: store the pixel, report the result or the problem, redraw."""
    settings = context.scene.primer_inspector
    settings.x, settings.y = x, y
    try:
        record = inspect(context, x, y)
    except (export.ExportError, ValueError) as error:
        state.error = str(error)
        log.error("ray inspector: %s", error)
        operator.report({"ERROR"}, f"Primer: {error}")
        redraw(context)
        return {"CANCELLED"}
    except ImportError as error:
        state.error = f"a library Primer needs is missing ({error})"
        operator.report({"ERROR"}, f"Primer: {state.error}")
        return {"CANCELLED"}
    except Exception as error:          # a clear report, never a traceback in Blender's face
        log.exception("ray inspector failed")
        state.error = f"inspection failed: {error}"
        operator.report({"ERROR"}, f"Primer: {state.error}")
        return {"CANCELLED"}
    operator.report({"INFO"}, summary(record))
    redraw(context)
    return {"FINISHED"}


class PRIMER_OT_inspect_pixel(bpy.types.Operator):
    """Trace the ray through one pixel and show its hit, normals, shadow rays and numbers"""

    bl_idname = "primer.inspect_pixel"
    bl_label = "Inspect Pixel"
    bl_options = {"REGISTER"}

    x: IntProperty(name="X", default=-1, min=-1, description="Pixel column from the left; -1: the scene's "
                                                             "Ray Inspector X", options={"SKIP_SAVE"})
    y: IntProperty(name="Y", default=-1, min=-1, description="Pixel row from the top; -1: the scene's "
                                                             "Ray Inspector Y", options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def execute(self, context):
        settings = context.scene.primer_inspector
        x = self.x if self.x >= 0 else settings.x
        y = self.y if self.y >= 0 else settings.y
        return run_inspection(self, context, x, y)


DIAGRAM_IMAGE = "Primer Ray Diagram"


def ray_diagram(context, row: int, size: int = 512):
    """Draw the 2D ray diagram of pixel row `row` (from the top) into the image DIAGRAM_IMAGE; return the image."""
    from ..core.teaching import diagram
    exported = export.export_scene(context.evaluated_depsgraph_get())
    drawn = diagram.ray_diagram(exported.scene, exported.settings, row, size=size)
    image = bpy.data.images.get(DIAGRAM_IMAGE)
    if image is None or tuple(image.size) != (size, size):
        if image is not None:
            bpy.data.images.remove(image)
        image = bpy.data.images.new(DIAGRAM_IMAGE, size, size, float_buffer=True)
    image.pixels.foreach_set(drawn.image[::-1].ravel())      # Blender's rows run bottom-up
    image.update()
    return image


class PRIMER_OT_ray_diagram(bpy.types.Operator):
    """Draw the scene from above, cut at the camera's height, with the rays of one row of pixels: camera rays,
    shadow rays, reflected and refracted rays, each in its own colour (image "Primer Ray Diagram")"""

    bl_idname = "primer.ray_diagram"
    bl_label = "Ray Diagram"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def execute(self, context):
        row = context.scene.primer_inspector.y
        try:
            image = ray_diagram(context, row)
        except (export.ExportError, ValueError) as error:
            self.report({"ERROR"}, f"Primer: {error}")
            return {"CANCELLED"}
        except Exception as error:          # a clear report, never a traceback in Blender's face
            log.exception("ray diagram failed")
            self.report({"ERROR"}, f"Primer: ray diagram failed: {error}")
            return {"CANCELLED"}
        for window in context.window_manager.windows:
            for area in window.screen.areas:
                if area.type == "IMAGE_EDITOR":
                    area.spaces.active.image = image
        self.report({"INFO"}, f"Primer: ray diagram of row {row} in image '{image.name}'")
        return {"FINISHED"}


def _window_region(area):
    """Return the main (WINDOW) region of an area, or None."""
    for region in area.regions:
        if region.type == "WINDOW":
            return region
    return None


def _inside(region, event) -> bool:
    """Whether the mouse is over `region` (regions may overlap: the sidebar floats over the image)."""
    mx, my = event.mouse_x - region.x, event.mouse_y - region.y
    return region.width > 1 and region.height > 1 and 0 <= mx < region.width and 0 <= my < region.height


class PRIMER_OT_pick_pixel(bpy.types.Operator):
    """Click pixels of the render in the Image Editor to inspect their rays; Esc or right-click ends"""

    bl_idname = "primer.pick_pixel"
    bl_label = "Pick Pixels"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        area = context.area
        return (area is not None and area.type == "IMAGE_EDITOR" and context.space_data.image is not None
                and _window_region(area) is not None)

    def invoke(self, context, event):
        self._area = context.area
        context.window_manager.modal_handler_add(self)
        context.window.cursor_modal_set("EYEDROPPER")
        self._area.header_text_set("Primer ray inspector: click a pixel of the render | Esc / right-click: done")
        return {"RUNNING_MODAL"}

    def finish(self, context):
        """Restore the cursor and header."""
        context.window.cursor_modal_restore()
        self._area.header_text_set(None)

    def modal(self, context, event):
        if event.type in {"ESC", "RIGHTMOUSE"} and event.value == "PRESS":
            self.finish(context)
            return {"FINISHED"}
        if event.type != "LEFTMOUSE" or event.value != "PRESS":
            return {"PASS_THROUGH"}         # panning and zooming keep working
        region = _window_region(self._area)
        mx, my = event.mouse_x - region.x, event.mouse_y - region.y
        if not _inside(region, event) or any(_inside(other, event) for other in self._area.regions
                                             if other.type != "WINDOW"):
            return {"PASS_THROUGH"}         # a click elsewhere: another editor, the header, the sidebar
        # 1. Region pixel -> image coordinates (0..1 across the image, v upwards).
        u, v = region.view2d.region_to_view(mx, my)
        # 2. Image coordinates -> render pixel, row 0 at the top.
        scene = context.scene
        full = export.frame_size(scene.render)
        image = self._area.spaces.active.image
        border = export.border_rectangle(scene.render, *full)
        size = tuple(image.size) if image is not None else (0, 0)
        if min(size) <= 0:              # size unknown: the image Blender would render now
            cropped = scene.render.use_border and scene.render.use_crop_to_border
            size = tuple(border[2:]) if cropped else full
        try:
            x, y = inspector_view.image_uv_to_pixel(u, v, size, full, border)
        except ValueError as error:
            self.report({"WARNING"}, f"Primer: {error}")
            return {"RUNNING_MODAL"}
        # 3. Inspect it.
        run_inspection(self, context, x, y)
        return {"RUNNING_MODAL"}


# ----------------------------------------------------------------------------
# Drawing in the 3D viewport (gpu)
# ----------------------------------------------------------------------------

_draw_handle = None
_draw_failed = False


def draw_overlay():
    """SpaceView3D POST_VIEW callback: draw the last record's rays, normals and points."""
    global _draw_failed
    record = state.record
    scene = bpy.context.scene
    if record is None or scene is None or scene.name != state.scene_name:
        return
    settings = scene.primer_inspector
    if not settings.show_overlay:
        return
    try:
        segments = inspector_view.overlay_segments(record, settings.normal_length, 0.0, settings.show_primary,
                                                   settings.show_normals, settings.show_shadow_rays)
        markers = inspector_view.overlay_markers(record, settings.show_shadow_rays)
        size = 0.04 * inspector_view.scale_of(record)
        _draw(segments + inspector_view.marker_segments(markers, size), settings.line_width)
    except Exception:                   # never let a drawing error repeat on every redraw
        if not _draw_failed:
            log.exception("ray inspector: drawing failed")
        _draw_failed = True


def _draw(segments: list, line_width: float) -> None:
    """Draw Segments as wide lines on top of the scene, one batch per colour."""
    import gpu
    from gpu_extras.batch import batch_for_shader

    by_color: dict = {}
    for segment in segments:
        by_color.setdefault(segment.color, []).extend([tuple(segment.start), tuple(segment.end)])
    gpu.state.blend_set("ALPHA")
    gpu.state.depth_test_set("NONE")
    shader = gpu.shader.from_builtin("POLYLINE_UNIFORM_COLOR")
    shader.bind()
    shader.uniform_float("viewportSize", gpu.state.viewport_get()[2:])
    shader.uniform_float("lineWidth", line_width)
    for color, coords in by_color.items():
        shader.uniform_float("color", color)
        batch_for_shader(shader, "LINES", {"pos": coords}).draw(shader)
    gpu.state.blend_set("NONE")


# ----------------------------------------------------------------------------
# Panels
# ----------------------------------------------------------------------------

def draw_inspector(layout, context, pick: bool = False) -> None:
    """Draw the inspector's controls and the last record's numbers into `layout`."""
    settings = context.scene.primer_inspector
    row = layout.row(align=True)
    row.prop(settings, "x")
    row.prop(settings, "y", text="Y (from top)")
    row = layout.row(align=True)
    row.operator(PRIMER_OT_inspect_pixel.bl_idname, icon="VIEWZOOM")
    if pick:
        row.operator(PRIMER_OT_pick_pixel.bl_idname, icon="EYEDROPPER")
    layout.operator(PRIMER_OT_ray_diagram.bl_idname, icon="SNAP_PERPENDICULAR")
    col = layout.column(heading="Draw", align=True)
    col.prop(settings, "show_overlay")
    sub = col.column(align=True)
    sub.active = settings.show_overlay
    sub.prop(settings, "show_primary")
    sub.prop(settings, "show_normals")
    sub.prop(settings, "show_shadow_rays")
    sub.prop(settings, "normal_length")
    sub.prop(settings, "line_width")
    if state.error:
        layout.label(text=state.error, icon="ERROR")
    record = state.record
    if record is None or state.scene_name != context.scene.name:
        layout.label(text="No pixel inspected yet", icon="INFO")
        return
    for title, rows in inspector_view.panel_sections(record, state.height):
        box = layout.box()
        box.label(text=title)
        grid = box.grid_flow(row_major=True, columns=2, even_columns=False, align=True)
        for label, text in rows:
            grid.label(text=label)
            grid.label(text=text)


class PrimerInspectorPanel(PrimerOnly):
    """The ray inspector's panels, shown only when Primer is the render engine."""

    bl_label = "Ray Inspector"


class VIEW3D_PT_primer_inspector(PrimerInspectorPanel, bpy.types.Panel):
    """The ray inspector in the 3D viewport's sidebar (N), tab Primer."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Primer"

    def draw(self, context):
        draw_inspector(self.layout, context)


class IMAGE_PT_primer_inspector(PrimerInspectorPanel, bpy.types.Panel):
    """The ray inspector in the Image Editor's sidebar (N), tab Primer, with the pixel picker."""

    bl_space_type = "IMAGE_EDITOR"
    bl_region_type = "UI"
    bl_category = "Primer"

    def draw(self, context):
        draw_inspector(self.layout, context, pick=True)


class RENDER_PT_primer_inspector(PrimerInspectorPanel, bpy.types.Panel):
    """The ray inspector in the Render properties."""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        draw_inspector(self.layout, context)


classes = (
    PrimerInspectorSettings,
    PRIMER_OT_inspect_pixel,
    PRIMER_OT_pick_pixel,
    PRIMER_OT_ray_diagram,
    VIEW3D_PT_primer_inspector,
    IMAGE_PT_primer_inspector,
    RENDER_PT_primer_inspector,
)


def register():
    """Register the inspector's classes, scene.primer_inspector and (with a GPU) the viewport drawing."""
    global _draw_handle
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.primer_inspector = PointerProperty(type=PrimerInspectorSettings)
    if not bpy.app.background:
        _draw_handle = bpy.types.SpaceView3D.draw_handler_add(draw_overlay, (), "WINDOW", "POST_VIEW")


def unregister():
    """Undo `register`."""
    global _draw_handle
    if _draw_handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_draw_handle, "WINDOW")
        _draw_handle = None
    state.record = None
    del bpy.types.Scene.primer_inspector
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
