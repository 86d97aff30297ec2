# Two entry points for newcomers: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.score4-installed

.PHONY: demo test docs-check clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

# The paper's application, small: 5.3 MeV alphas on a flat and on a pyramid-covered silicon face.
demo: $(STAMP)
	mkdir -p out/demo
	$(BIN)/score4 run examples/paper_a_flat.yaml --events 5000 --jobs 2 --out out/demo/flat.h5 --overwrite
	$(BIN)/score4 run examples/paper_a_rough.yaml --events 5000 --jobs 2 --out out/demo/rough.h5 --overwrite
	$(BIN)/score4 summary out/demo/rough.h5
	$(BIN)/score4 plot out/demo/flat.h5 out/demo/rough.h5 --label "flat face" --label "10 um pyramids" --out out/demo/spectra.png

test: $(STAMP)
	$(BIN)/python -m pytest

# Re-run the commands behind every transcript and number quoted in README.md and docs/*.md
# (docs/checks.yaml); fails on any difference. After a change that moves the numbers:
#   .venv/bin/python tools/docs_check.py --update   (then read the diff)
docs-check: $(STAMP)
	$(BIN)/python tools/docs_check.py

clean:
	rm -rf $(VENV) out build src/*.egg-info
