# The two set-up commands of the README: `make demo` and `make test`.
# Each creates .venv when missing, installs the CPU build of torch first (so no resolver
# pulls a CUDA build), then the project with its dev extras; a stamp keeps reruns quick.
PYTHON ?= python3
VENV   ?= .venv
PY      = $(VENV)/bin/python
STAMP   = $(VENV)/.foresight-installed
# the planner plugin the tests evaluate (an entry point in the group foresight.planners)
TOY_PLUGIN = tests/plugins/toy_planner
# the example predictor plug-in the tests evaluate (an entry point in the group foresight.predictors)
PREDICTOR_PLUGIN = examples/predictor_plugin
# test processes (pytest-xdist): most tests wait on servers, workers and subprocesses, so two share two cores well;
# --dist loadscope: each test module whole in one process (its module fixtures built once; tests/conftest.py)
TEST_WORKERS ?= 2

.PHONY: install browser test demo lint docs bench clean

$(STAMP): pyproject.toml setup.py $(TOY_PLUGIN)/pyproject.toml $(PREDICTOR_PLUGIN)/pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q torch==2.13.0
	$(PY) -m pip install -q -e '.[dev]'
	$(PY) -m pip install -q -e $(TOY_PLUGIN)
	$(PY) -m pip install -q -e $(PREDICTOR_PLUGIN)
	touch $(STAMP)

install: $(STAMP)

# The dashboard test drives Debian's Chromium through Playwright (no browser download).
browser:
	@command -v chromium >/dev/null 2>&1 || { [ "$$(id -u)" = 0 ] && apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; } || \
		echo "warning: chromium is not installed; the browser test needs it (apt-get install chromium)"

test: install browser
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadscope

demo: install
	$(VENV)/bin/foresight demo

lint: install
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/ruff check .

# The documentation site (docs/, mkdocs.yml) into site/; --strict: a broken link or a missing page fails it.
# The reference pages are generated from the code by the hook docs/_hooks/reference.py.
docs: install
	$(VENV)/bin/mkdocs build --strict --site-dir site

bench: install
	$(PY) bench/sim_speed.py --json

clean:
	rm -rf $(VENV) .pytest_cache site
