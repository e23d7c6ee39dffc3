"""Several Blender scripts (each written for blender_env.run_bpy) run one after the other in one Blender process.

A Blender process and Primer's registration cost about 2.4 s of CPU before anything renders (docs/testing.md): a test
file whose tests each start one pays that per test. RUNNER (a script for run_bpy, formatted with `sources`, a dict
name -> script) runs each script in a folder <name>/ of its own and a namespace of its own, keeps what each hands to
report(), and reports {"results": {name: its values}}. Each script starts as in a process of its own, Primer not
registered: what a script leaves registered is unregistered after it (bpy 4.2 crashes at exit while a Python
RenderEngine is registered, so most scripts unregister it themselves), and the next one's load_primer registers it.
"""

RUNNER = """
import os, sys
import bpy
import blender_env
results = {{}}


def keep(**values):
    results[current] = values


real_report, blender_env.report = blender_env.report, keep
for current, source in {sources!r}.items():
    os.makedirs(current)
    os.chdir(current)
    exec(compile(source, current + ".py", "exec"), {{"__name__": "__main__"}})
    os.chdir("..")
    primer = sys.modules.get("primer")
    if primer is not None:                      # each script starts as in a process of its own: Primer unregistered
        if hasattr(bpy.types.Scene, "primer"):  # (a script that left it registered)
            primer.unregister()
        primer._registered_by_load_primer = False      # (tools/render.py load_primer: register it again)
real_report(results=results)
"""
