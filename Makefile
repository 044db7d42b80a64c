# The two commands a new user needs (see README.md):
#   make demo   set up .venv and run the simulated field test
#   make test   set up .venv and run the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
# The exact versions CI tested (pyproject.toml keeps the ranges); `make constraints` rewrites it.
CONSTRAINTS := constraints.txt

.PHONY: demo test setup lint clean constraints dist-check

$(STAMP): pyproject.toml $(CONSTRAINTS)
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c $(CONSTRAINTS) -e '.[dev,mavlink,compress]'
	@# Aravis (GigE/USB3 Vision) needs PyGObject, which builds only where gobject-introspection
	@# headers are installed (.ci/run installs them); without it the Aravis tests skip.
	-$(BIN)/python -m pip install --quiet -c $(CONSTRAINTS) -e '.[aravis]' \
		> $(VENV)/aravis-install.log 2>&1 \
		|| echo 'PyGObject not built (see $(VENV)/aravis-install.log): Aravis tests will skip'
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)
	$(BIN)/snrmon demo

test: $(STAMP)
	$(BIN)/lint-imports
	$(BIN)/mypy
	QT_QPA_PLATFORM=offscreen $(BIN)/python -m pytest -q

# After a green `make test` with new versions: pin them as the tested ones.
constraints: $(STAMP)
	$(BIN)/python .ci/freeze_constraints.py > $(CONSTRAINTS).new && mv $(CONSTRAINTS).new $(CONSTRAINTS)

# The package as a user gets it: wheel and sdist with licence and metadata, the wheel installed
# into a fresh venv with the tested versions, `snrmon --help` run from there.
dist-check: $(STAMP)
	PYTHON=$(PYTHON) BIN=$(BIN) bash .ci/dist-check

lint: $(STAMP)
	$(BIN)/ruff check . && $(BIN)/ruff format --check .

clean:
	rm -rf $(VENV) build dist *.egg-info
