"""The Blender layer of Primer: engine, scene export, settings and panels (Cycles' add-on layout)."""
from __future__ import annotations


def register():
    """Register settings first (panels and the engine read them), then the engine, then the panels."""
    import bpy
    from . import engine, inspector, properties, ui

    properties.register()
    for cls in engine.classes:
        bpy.utils.register_class(cls)
    ui.register()
    inspector.register()
    for name, handler in engine.HANDLERS:
        if handler not in getattr(bpy.app.handlers, name):
            getattr(bpy.app.handlers, name).append(handler)
    # The warm heap renders leave goes back to the system once Blender is idle (addon/engine.py).
    if not bpy.app.timers.is_registered(engine.release_memory_when_idle):
        bpy.app.timers.register(engine.release_memory_when_idle, first_interval=engine.RELEASE_CHECK, persistent=True)


def unregister():
    """Unregister in the reverse order."""
    import bpy
    from . import engine, inspector, properties, ui

    for name, handler in engine.HANDLERS:
        if handler in getattr(bpy.app.handlers, name):
            getattr(bpy.app.handlers, name).remove(handler)
    inspector.unregister()
    ui.unregister()
    for cls in reversed(engine.classes):
        bpy.utils.unregister_class(cls)
    properties.unregister()
    # Any memory the last renders kept goes back now.
    from ..core import memory
    if bpy.app.timers.is_registered(engine.release_memory_when_idle):
        bpy.app.timers.unregister(engine.release_memory_when_idle)
    memory.release()
