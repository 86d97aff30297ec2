# Two entry points for newcomers: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.score4-installed

.PHONY: demo test clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	mkdir -p out/demo
	$(BIN)/score4 run examples/flat_alpha.yaml --out out/demo/flat_alpha.h5 --overwrite
	$(BIN)/score4 summary out/demo/flat_alpha.h5

test: $(STAMP)
	$(BIN)/python -m pytest

clean:
	rm -rf $(VENV) out build src/*.egg-info
