# One entry for everything. `make test` on a fresh machine creates .venv, installs uvteam with its
# test extras and runs the suite; `make demo` runs the whole team on loopback.
PY ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

CHROMIUM ?= /usr/bin/chromium

.PHONY: install browser js test unit pythons demo bench experiment clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test,plots]'
	touch $(STAMP)

install: $(STAMP)

# The live map's browser test drives Debian's chromium (never a downloaded browser build): as root
# with apt a missing one is installed (~45 s); anywhere else the test skips and says what is missing.
browser:
	@if [ ! -x "$(CHROMIUM)" ] && [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  echo "make: installing chromium for the map's browser test"; \
	  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	    chromium >/dev/null) || echo "make: could not install chromium; the map's browser test will skip"; \
	fi

# Foxglove's own MCAP reader and message schemas (npm, pinned in tests/js/package.json) check what
# `uvteam record` writes; without npm that test skips and says so.
JS_STAMP := tests/js/node_modules/.installed
$(JS_STAMP): tests/js/package.json
	@if command -v npm >/dev/null 2>&1; then \
	  npm install --prefix tests/js --no-audit --no-fund --no-package-lock --silent && touch $(JS_STAMP) \
	    || echo "make: could not install tests/js; the Foxglove MCAP check will skip"; \
	else echo "make: no npm; the Foxglove MCAP check will skip"; fi

js: $(JS_STAMP)

test: $(STAMP) browser js
	$(BIN)/python -m pytest -q

fuzz: $(STAMP)   # the decoders' and the MAVLink ingest's fuzz tests, longer than in CI
	UVTEAM_FUZZ_EXAMPLES=5000 $(BIN)/python -m pytest -q tests/unit/test_fuzz_decoders.py tests/unit/test_mavlink_fuzz.py

unit: $(STAMP)
	$(BIN)/python -m pytest -q tests/unit

# The unit suite on every other Python this machine has (pyenv's 3.10, 3.12, 3.13): the wheel with its
# test extras in a fresh venv per Python under build/pythons/, the tests from this tree.
PYTHONS ?= $(wildcard $(HOME)/.pyenv/versions/3.1[0-9]*/bin/python3)
pythons: $(STAMP)
	@rm -rf build/pythons/dist && $(BIN)/pip wheel --quiet --no-deps -w build/pythons/dist .
	@for py in $(PYTHONS); do \
	  v=$$($$py -c 'import sys; print("%d.%d" % sys.version_info[:2])'); d=build/pythons/$$v; \
	  echo "== Python $$v"; rm -rf $$d && $$py -m venv $$d && \
	  $$d/bin/pip install --quiet "$$(ls build/pythons/dist/uvteam-*.whl)[test]" && \
	  $$d/bin/python -m pytest -q -p no:cacheprovider tests/unit || exit 1; \
	done

demo: $(STAMP)
	$(BIN)/uvteam demo $(ARGS)

bench: $(STAMP)
	$(BIN)/uvteam bench all

experiment: $(STAMP)
	$(BIN)/uvteam experiment ../shared/scenarios/*.toml

clean:
	rm -rf $(VENV) build *.egg-info shared/*.egg-info tests/js/node_modules
