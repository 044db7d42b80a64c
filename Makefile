# The two commands a new user needs (see README.md):
#   make demo   set up .venv and run the simulated field test
#   make test   set up .venv and run the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test setup lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,mavlink,compress]'
	@# Aravis (GigE/USB3 Vision) needs PyGObject, which builds only where gobject-introspection
	@# headers are installed (.ci/run installs them); without it the Aravis tests skip.
	-$(BIN)/python -m pip install --quiet -e '.[aravis]' > $(VENV)/aravis-install.log 2>&1 \
		|| echo 'PyGObject not built (see $(VENV)/aravis-install.log): Aravis tests will skip'
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)
	$(BIN)/snrmon demo

test: $(STAMP)
	$(BIN)/lint-imports
	$(BIN)/mypy
	QT_QPA_PLATFORM=offscreen $(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check . && $(BIN)/ruff format --check .

clean:
	rm -rf $(VENV) build *.egg-info
