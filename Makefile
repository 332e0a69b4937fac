# Two commands from a fresh clone: `make run` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: run test test-fast lint bench soak clean bytecode

PACKAGES := player_server behaviors murdoch worlds experiments murdoch_api

# uv installs the same pinned set as pip would, in a quarter of the time, compiled to
# bytecode as pip does
$(STAMP): pyproject.toml constraints.txt
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --disable-pip-version-check -c constraints.txt uv
	$(BIN)/uv pip install -q --compile-bytecode --python $(BIN)/python -c constraints.txt \
		-e '.[dev]'
	touch $(STAMP)

# our own modules' bytecode, brought up to date (only what changed is compiled again): a
# process then loads it instead of compiling every module it imports, which it does each
# time where PYTHONDONTWRITEBYTECODE is set (0.4 s of every `murdoch` command's start-up)
bytecode: $(STAMP)
	$(BIN)/python -m compileall -q -j 0 $(PACKAGES)

run: bytecode
	$(BIN)/murdoch run longterm --until 30m

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/lint-imports
	$(BIN)/python tools/import_cycles.py
	$(BIN)/mypy $(PACKAGES)

# three workers (pytest-xdist) on the two CPUs: the end-to-end tests wait on each other's
# processes, the browser and pip often enough that a third keeps both CPUs busy; a module's
# tests stay on one worker, so a run they share is made once
test: lint bytecode
	$(BIN)/python -m pytest -q -n 3 --dist loadscope --durations=20

# the inner loop: unit tests and pure logic, the slow ones left out (tests/unit/conftest.py)
test-fast: bytecode
	$(BIN)/python -m pytest -q -n 2 -m "not slow and not soak" tests/unit

soak: bytecode
	$(BIN)/python -m pytest -q -m soak

bench: bytecode
	for b in bench/*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .mypy_cache .hypothesis
