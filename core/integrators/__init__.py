"""Integrators: the algorithms that combine lights, materials and geometry into the light a camera sees.

INTEGRATORS is the table RenderSettings.integrator chooses from. Each integrator is a readable
Python reference (core/integrators/<name>.py) and a compiled twin (core/integrators/<name>.c).
"""
from __future__ import annotations

from .base import Context, Integrator, Radiance, Recorder
from .direct import DirectLighting
from .path import PathTracing
from .whitted import WhittedTracing

INTEGRATORS = {cls.name: cls for cls in (DirectLighting, WhittedTracing, PathTracing)}

__all__ = ["Context", "DirectLighting", "INTEGRATORS", "Integrator", "PathTracing", "Radiance", "Recorder",
           "WhittedTracing"]
