# Primer: the two commands a new user needs are `make demo` and `make test`.
PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV   := .venv
PY     := $(VENV)/bin/python
VENV42 := .venv42
PY42   := $(VENV42)/bin/python

BLENDER_USER := $(CURDIR)/.pytest_cache/blender-user

# Extra pytest arguments, e.g. `make test PYTEST_ARGS="-m 'not slow'"` or PYTEST_ARGS="-k camera".
PYTEST_ARGS ?=
# pytest exits with 5 when it collects no test. With a filter in PYTEST_ARGS that is expected for one
# of the two runs below, so it passes; without a filter it means tests went missing, so it fails.
EMPTY_OK := $(if $(strip $(PYTEST_ARGS)),|| [ $$? -eq 5 ])

.PHONY: demo test venv venv42 kernels extension scenes clean

# Create a virtual environment and install pinned dependencies (once, or when they change).
define make_venv
	@$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "Primer needs Python 3.11, found " + sys.version.split()[0]'
	test -x $(1)/bin/python || $(PYTHON) -m venv $(1)
	$(1)/bin/python -m pip install --quiet --upgrade pip
	$(1)/bin/python -m pip install --quiet -r $(2)
	touch $(1)/.installed
endef

# .venv: the tracer, bpy 5.0 (Blender as a module) and the tools; used by `make demo` and `make test`.
$(VENV)/.installed: requirements.txt
	$(call make_venv,$(VENV),requirements.txt)

# .venv42: bpy 4.2 LTS, for the smoke test on the oldest Blender that Primer supports.
$(VENV42)/.installed: requirements-bpy42.txt
	$(call make_venv,$(VENV42),requirements-bpy42.txt)

venv: $(VENV)/.installed
venv42: $(VENV42)/.installed

# Compile core/native/primer.c for this machine (core/native/library.py loads it; without it Primer renders on its Python path).
kernels: venv
	$(PY) tools/build_kernels.py

# Render the sample scenes into out/, printing the time per image.
demo: venv kernels
	$(PY) tools/demo.py --out out

# Regenerate sample_scenes/*.blend with Blender 4.2 LTS, so that every supported Blender opens them.
scenes: venv42
	$(PY42) sample_scenes/make_scenes.py

# Build dist/primer-<version>.zip, the Blender extension, with embreex wheels for every platform.
extension: venv kernels
	$(PY) tools/build_extension.py

# Run the whole test suite: the tracer and Blender 5.0 tests, then the Blender 4.2 LTS smoke test.
# Blender inside the test process gets an empty user folder, so a personal Blender setup (preferences,
# installed extensions) cannot change the results; tests that install Primer use their own (tests/blender_env.py).
test: venv venv42 kernels
	rm -rf $(BLENDER_USER) && mkdir -p $(BLENDER_USER)
	BLENDER_USER_RESOURCES=$(BLENDER_USER) $(PY) -m pytest -q $(PYTEST_ARGS) $(EMPTY_OK)
	$(PY42) -m pytest -q tests/smoke_bpy42.py $(PYTEST_ARGS) $(EMPTY_OK)

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
	rm -rf $(VENV) $(VENV42) out dist .pytest_cache core/native/_kernels-*
