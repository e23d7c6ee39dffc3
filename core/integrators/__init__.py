"""Integrators: the algorithms that combine lights, materials and geometry into the light a camera sees.

INTEGRATORS is the table RenderSettings.integrator chooses from. Each integrator is a readable
Python reference (core/integrators/<name>.py) and a compiled twin (core/integrators/<name>.c).
"""
from __future__ import annotations

from .base import Cancelled, Context, Integrator, Radiance, Recorder, StopFlag
from .direct import DirectLighting
from .path import PathTracing
from .whitted import WhittedTracing

INTEGRATORS = {cls.name: cls for cls in (DirectLighting, WhittedTracing, PathTracing)}


def for_render(ctx: Context) -> Integrator:
    """The integrator that renders with ctx.settings: the one its `integrator` names, but where rays go on through
    transparent surfaces (ctx.extra["transparent"]) the direct-lighting tracer is the path tracer with no bounces
    but those (Cycles' transparent bounces, apart from Max Bounces 0), and where a material walks subsurface
    scattering (ctx.extra["subsurface"]) it is the path tracer with no bounces, which walks it (Cycles counts no
    bounce for the walk)."""
    name = ctx.settings.integrator
    if name == DirectLighting.name and (ctx.extra.get("transparent", False) or ctx.extra.get("subsurface", False)):
        return PathTracing(direct_only=True)
    return INTEGRATORS[name]()


__all__ = ["Cancelled", "Context", "DirectLighting", "INTEGRATORS", "Integrator", "PathTracing", "Radiance", "Recorder",
           "StopFlag", "WhittedTracing", "for_render"]
