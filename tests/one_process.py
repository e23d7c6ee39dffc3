"""Several Blender scripts (each written for blender_env.run_bpy) run one after the other in one Blender process.

A Blender process and Primer's registration cost about 2.4 s of CPU before anything renders (docs/testing.md): a test
file whose tests each start one pays that per test. RUNNER (a script for run_bpy, formatted with `sources`, a dict
name -> script) runs each script in a folder <name>/ of its own and a namespace of its own, keeps what each hands to
report(), and reports {"results": {name: its values}}. Each script unregisters Primer at its end (bpy 4.2 crashes at
exit while a Python RenderEngine is registered); the next one's fresh_scene registers it again.
"""

RUNNER = """
import os, sys
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
    sys.modules["primer"]._registered_by_load_primer = False        # (tools/render.py load_primer: register again)
real_report(results=results)
"""
