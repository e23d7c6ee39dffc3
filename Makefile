# Primer: the two commands a new user needs are `make demo` and `make test`.
PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV   := .venv
PY     := $(VENV)/bin/python

.PHONY: demo test venv clean

# Create the virtual environment and install the pinned dependencies (once, or when they change).
$(VENV)/.installed: requirements.txt
	@$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "Primer needs Python 3.11, found " + sys.version.split()[0]'
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	touch $@

venv: $(VENV)/.installed

# Render the sample scenes into out/, printing the time per image.
demo: venv
	$(PY) tools/demo.py --out out

# Run the whole test suite.
test: venv
	$(PY) -m pytest -q

clean:
	rm -rf $(VENV) out dist .pytest_cache
