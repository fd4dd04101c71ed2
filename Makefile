# One entry for everything. `make test` on a fresh machine creates .venv, installs uvteam with its
# test extras and runs the suite; `make demo` runs the whole team on loopback.
PY ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

CHROMIUM ?= /usr/bin/chromium

.PHONY: install browser test unit demo bench experiment clean

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

test: $(STAMP) browser
	$(BIN)/python -m pytest -q

fuzz: $(STAMP)   # the decoders' and the MAVLink ingest's fuzz tests, longer than in CI
	UVTEAM_FUZZ_EXAMPLES=5000 $(BIN)/python -m pytest -q tests/unit/test_fuzz_decoders.py tests/unit/test_mavlink_fuzz.py

unit: $(STAMP)
	$(BIN)/python -m pytest -q tests/unit

demo: $(STAMP)
	$(BIN)/uvteam demo $(ARGS)

bench: $(STAMP)
	$(BIN)/uvteam bench all

experiment: $(STAMP)
	$(BIN)/uvteam experiment ../shared/scenarios/*.toml

clean:
	rm -rf $(VENV) build *.egg-info shared/*.egg-info
