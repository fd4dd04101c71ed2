# One entry for everything. `make test` on a fresh machine creates .venv, installs uvteam with its
# test extras and runs the suite; `make demo` runs the whole team on loopback.
PY ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install test unit demo bench experiment clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test,plots]'
	touch $(STAMP)

install: $(STAMP)

test: $(STAMP)
	$(BIN)/python -m pytest -q

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
