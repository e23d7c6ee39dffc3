"""Primer: an educational direct-lighting ray tracer, as a Blender render engine.

The tracer itself lives in `core/` and never imports bpy; `addon/` is the thin
Blender layer (render engine, scene export, properties, panels).
"""


def register():
    """Register Primer's render engine, settings and panels with Blender."""
    from .addon import register as register_addon
    register_addon()


def unregister():
    """Remove everything `register` added."""
    from .addon import unregister as unregister_addon
    unregister_addon()
