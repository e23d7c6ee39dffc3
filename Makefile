# Primer: the two commands a new user needs are `make demo` and `make test`.
PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV   := .venv
PY     := $(VENV)/bin/python
VENV42 := .venv42
PY42   := $(VENV42)/bin/python
# Blender 5.1 and later run Python 3.13: python3.13 on the PATH if it runs (a pyenv shim may not), else
# pyenv's own 3.13. Set PYTHON313=/path/to/python3.13 to choose another.
PYTHON313 ?= $(shell for p in python3.13 $$HOME/.pyenv/versions/3.13*/bin/python3.13; do \
	"$$p" -c 'import sys; assert sys.version_info[:2] == (3, 13)' 2>/dev/null && { command -v "$$p"; break; }; done)
VENV52 := .venv52
PY52   := $(VENV52)/bin/python
# What `make test` runs on bpy 5.2: the tests that run Blender, and the debug views whose float32 buffers
# numpy 2 compares differently. The rest of the tracer never imports bpy; `make test TESTS52=tests` runs
# everything on 5.2 too (about 45 s more).
TESTS52 ?= $(wildcard tests/test_blender_*.py) tests/test_extension.py tests/test_tour.py tests/test_viewport.py \
	tests/test_debug_views.py
# On 5.2 the render-setting variants' image comparisons with Cycles (tests/test_blender_scenes.py) and the lecture's
# face-normal rule against Cycles' leak are left to the 5.0 run, and of the sample scenes' comparisons three stay (a path-traced box, an HDRI world, textures): they
# check Primer's light transport, the same on both, and their Cycles references are committed for 5.0 only
# (tests/references/). `make test TESTS52_SKIP=` runs them all on 5.2 too, rendering those references (about
# twelve minutes). Six tour stops are left to 5.0 as well: Russian roulette, MIS against its two strategies, the
# thin lens as a mean of pinholes, light adding up over emitters and the world, the negative light of the N.L clamp
# switch and the white random walk check Primer's estimators on Primer's own settings (min light bounces, light
# sampling, the lecture switches, the walk's step cap), the same on both Blenders (what 5.2 reads of them: the
# camera's depth of field in tests/test_blender_depth_of_field.py, Cycles 5.2's subsurface in
# tests/test_blender_subsurface.py), and render the most of the tour (about a minute of the 5.2 run on 2 cores).
TESTS52_SKIP ?= -k "not test_render_setting_matches_cycles and not (test_sample_scene_matches_cycles and not \
	(cornell_box or world_hdri or materials_textures)) and not test_lecture_differs_from_cycles_only_by_the_leak \
	and not test_russian_roulette_is_unbiased \
	and not test_mis_beats_light_sampling and not test_a_thin_lens_image_is_the_mean_of_pinhole_images \
	and not test_emitters_and_the_world_light_the_scene and not test_negative_light_only_without_the_clamp \
	and not test_a_white_random_walk_loses_only_the_walks"

BLENDER_USER := $(CURDIR)/.pytest_cache/blender-user

# Extra pytest arguments, e.g. `make test PYTEST_ARGS="-m 'not slow'"` or PYTEST_ARGS="-k camera".
PYTEST_ARGS ?=
# pytest exits with 5 when it collects no test. With a filter in PYTEST_ARGS that is expected for one
# of the runs below, so it passes; without a filter it means tests went missing, so it fails.
EMPTY_OK := $(if $(strip $(PYTEST_ARGS)),|| [ $$? -eq 5 ])

# pytest-xdist workers of `make test`'s two large runs (the tracer with bpy 5.0, and bpy 5.2): both cores.
# PYTEST_JOBS=0 runs in one process.
PYTEST_JOBS ?= 2
# tests/conftest.py's pytest_xdist_make_scheduler keeps the tests that write into the checkout on one worker.
XDIST := $(if $(filter-out 0 1,$(PYTEST_JOBS)),-n $(PYTEST_JOBS))

.PHONY: demo test test-setup test-kernels test-platforms-check test-run venv venv42 venv52 kernels platforms platforms-check extension scenes references clean

# Create a virtual environment $(1) with Python $(2) and install the pinned dependencies $(3) (once, or
# when they change). pip byte-compiles every module it installs (bpy's thousands of scripts: about 10 s of CPU for
# each bpy, while the kernels compile): where Python may not write bytecode (PYTHONDONTWRITEBYTECODE, set on the
# machines the tests run on), every Blender process would otherwise compile bpy's start-up scripts again, 2.4 s of
# CPU each (measured: tools/render.py 4.65 s without their .pyc files, 1.48 s with them).
define make_venv
	test -x $(1)/bin/python || $(2) -m venv $(1)
	$(1)/bin/python -m pip install --quiet --upgrade pip
	$(1)/bin/python -m pip install --quiet -r $(3)
endef
CHECK_PYTHON311 = @$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), \
	"Primer needs Python 3.11 (Blender 4.2 to 5.0), found " + sys.version.split()[0]'

# .venv's numpy first (its pin in requirements.txt): all that tools/build_kernels.py needs, so that `make kernels`
# compiles while pip installs the rest of .venv (bpy is most of it) and the other environments.
$(VENV)/.numpy-installed: requirements.txt
	$(CHECK_PYTHON311)
	test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet "$$(grep '^numpy==' requirements.txt)"
	touch $@

# .venv: the tracer, bpy 5.0 (Blender as a module) and the tools; used by `make demo` and `make test`.
$(VENV)/.installed: requirements.txt $(VENV)/.numpy-installed $(if $(filter test-setup,$(MAKECMDGOALS)),$(VENV)/.zig-installed)
	$(CHECK_PYTHON311)
	$(call make_venv,$(VENV),$(PYTHON),requirements.txt)
	touch $@

# .venv42: bpy 4.2 LTS, for the smoke test on the oldest Blender that Primer supports.
$(VENV42)/.installed: requirements-bpy42.txt
	$(CHECK_PYTHON311)
	$(call make_venv,$(VENV42),$(PYTHON),requirements-bpy42.txt)
	touch $@

# .venv52: bpy 5.2 on Python 3.13 and numpy 2, for the Blender tests on the newest Blender. OpenImageIO is
# the copy inside bpy (a .pth file puts bpy's bundled site-packages on the path), not a second install.
$(VENV52)/.installed: requirements-bpy52.txt
	@test -n "$(PYTHON313)" || { echo "make: the Blender 5.2 tests need Python 3.13 (none found on the PATH" \
		"or in ~/.pyenv/versions); install it or set PYTHON313=/path/to/python3.13" >&2; exit 1; }
	@$(PYTHON313) -c 'import sys; assert sys.version_info[:2] == (3, 13), \
		"bpy 5.2 needs Python 3.13, found " + sys.version.split()[0]'
	$(call make_venv,$(VENV52),$(PYTHON313),requirements-bpy52.txt)
	$(PY52) tools/bpy_site_packages.py
	touch $@

venv: $(VENV)/.installed
venv42: $(VENV42)/.installed
venv52: $(VENV52)/.installed

# Zig's C toolchain (the ziglang package), installed into .venv beside the pinned dependencies: the
# cross-compiler of `make platforms` and `make extension`, and of tests/test_platforms.py.
$(VENV)/.platforms-installed: $(VENV)/.installed requirements-platforms.txt
	$(PY) -m pip install --quiet --no-compile -r requirements-platforms.txt -c requirements.txt
	touch $@

# The other environments build the extension with .venv's Zig (tools/build_kernels.py reads $ZIG).
ZIG := $(CURDIR)/$(PY) -m ziglang

# Compile core/native/primer.c for this machine (core/native/library.py loads it; without it Primer renders on its Python path).
# A plain C library loaded through ctypes, the same file for every Python: .venv42 and .venv52 use it too. It needs
# numpy alone of .venv, so it starts before the rest of .venv is installed.
kernels: $(VENV)/.numpy-installed
	$(PY) tools/build_kernels.py

# Render the sample scenes into out/, printing the time per image.
demo: venv kernels
	$(PY) tools/demo.py --out out

# Regenerate sample_scenes/*.blend with Blender 4.2 LTS, so that every supported Blender opens them.
scenes: venv42
	$(PY42) sample_scenes/make_scenes.py

# Cross-compile the kernels for every platform the extension ships (Linux x64/arm64, Windows x64, macOS
# arm64/x64) into dist/kernels/ with Zig; the first build takes a few minutes (Zig builds each C library once).
platforms: $(VENV)/.platforms-installed
	$(PY) tools/build_kernels.py --all-platforms

# The same five unoptimised (-O0, into dist/kernels-check/): what the tests check (format, exports, loading), built
# in a fifth of the time.
platforms-check: $(VENV)/.platforms-installed
	$(PY) tools/build_kernels.py --all-platforms --check

# Build dist/primer-<version>.zip, the Blender extension, with embreex wheels and kernels for every platform.
extension: venv $(VENV)/.platforms-installed
	$(PY) tools/build_extension.py

# Run the whole test suite: the tracer and Blender 5.0 tests, then the Blender 5.2 tests (Python 3.13, numpy 2) with
# the Blender 4.2 LTS smoke test beside them. Blender inside the test process gets an empty user folder, so a
# personal Blender setup (preferences, installed extensions) cannot change the results; tests that install
# Primer use their own (tests/blender_env.py).
# First the set-up, up to four jobs at once: the three environments, this machine's kernels (Zig, -O3, one core,
# started as soon as .venv has numpy and Zig, while pip installs the rest) and the other platforms' (Zig, two at a
# time, unoptimised: test-platforms-check), so that no test waits for a compiler; then the runs: Blender 5.0 on both cores
# (pytest-xdist), then Blender 5.2 on both cores with the 4.2 smoke test beside it; last, the whole suite's time.
test:
	@start=$$(date +%s); \
	$(MAKE) --no-print-directory -j4 test-setup && $(MAKE) --no-print-directory test-run; status=$$?; \
	took=$$(( $$(date +%s) - start )); echo "make test: $$((took / 60))m$$((took % 60))s"; exit $$status

# The test suite's kernels: this machine's compiled by Zig as the shipped ones are (tools/build_kernels.py --zig;
# it also stands for this platform's check build), the other platforms' unoptimised. Zig is installed into .venv
# right after numpy, so that both compile while pip installs the rest.
$(VENV)/.zig-installed: $(VENV)/.numpy-installed requirements-platforms.txt
	$(PY) -m pip install --quiet --no-compile -r requirements-platforms.txt
	touch $@

test-kernels: $(VENV)/.zig-installed
	$(PY) tools/build_kernels.py --zig

test-platforms-check: $(VENV)/.zig-installed
	$(PY) tools/build_kernels.py --all-platforms --check --except-host

test-setup: venv venv42 venv52 test-kernels test-platforms-check

# The Blender 4.2 smoke test (one process, a few Blender processes of its own) runs beside the 5.2 run, its output
# kept in $(SMOKE42_LOG) and shown after it; the suite fails if either fails.
SMOKE42_LOG := .pytest_cache/smoke-bpy42.log

# The checkout's own bytecode, for Python 3.11 (.venv, .venv42) and 3.13 (.venv52): written once here, read by
# every Blender process the tests start (Primer's modules took 0.6 s of CPU to compile in each).
BYTECODE_DIRS := __init__.py addon core tools tests bench sample_scenes

test-run:
	rm -rf $(BLENDER_USER) && mkdir -p $(BLENDER_USER)
	$(PY) -m compileall -q -j 0 $(BYTECODE_DIRS) && $(PY52) -m compileall -q -j 0 $(BYTECODE_DIRS)
	BLENDER_USER_RESOURCES=$(BLENDER_USER) $(PY) -m pytest -q $(XDIST) --durations=15 $(PYTEST_ARGS) $(EMPTY_OK)
	@echo "Blender 4.2 smoke test: in the background, its output after the Blender 5.2 run"; \
	( ZIG="$(ZIG)" $(PY42) -m pytest -q -p no:cacheprovider tests/smoke_bpy42.py $(PYTEST_ARGS) \
		> $(SMOKE42_LOG) 2>&1 $(EMPTY_OK) ) & smoke=$$!; \
	BLENDER_USER_RESOURCES=$(BLENDER_USER) ZIG="$(ZIG)" $(PY52) -m pytest -q $(XDIST) --durations=5 $(TESTS52) \
		$(TESTS52_SKIP) $(PYTEST_ARGS) $(EMPTY_OK); status=$$?; \
	wait $$smoke; smoke_status=$$?; echo "== Blender 4.2 smoke test =="; cat $(SMOKE42_LOG); \
	[ $$status -eq 0 ] && [ $$smoke_status -eq 0 ]

# Render the Cycles references of tests/test_blender_scenes.py and tests/test_blender_holdout.py, and of the scenes
# other Blender tests build (their `reference` labels), that are missing or stale (their key changed) into
# tests/references/<bpy version>/, with bpy 5.0 and 5.2; commit them after. The Blender user folder is empty, as in
# `make test`.
references: venv venv52 kernels
	mkdir -p $(BLENDER_USER)
	BLENDER_USER_RESOURCES=$(BLENDER_USER) $(PY) tools/make_references.py
	BLENDER_USER_RESOURCES=$(BLENDER_USER) $(PY52) tools/make_references.py --no-variants

# The benchmark's extra tools (FLIP, matplotlib), installed into .venv beside the pinned dependencies.
$(VENV)/.bench-installed: $(VENV)/.installed requirements-bench.txt
	$(PY) -m pip install --quiet -r requirements-bench.txt -c requirements.txt
	touch $@

# Primer against Cycles: speed against error, profile, scaling and the hard cases, written to
# bench/REPORT.md and docs/performance.md's Benchmark section (about half an hour; BENCH_ARGS=--quick: a few minutes).
BENCH_ARGS ?=
bench: venv kernels $(VENV)/.bench-installed
	$(PY) bench/run.py $(BENCH_ARGS)

clean:
	rm -rf $(VENV) $(VENV42) $(VENV52) out dist .pytest_cache core/native/_kernels-*
