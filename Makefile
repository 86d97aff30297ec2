# Entry points: `make demo` and `make test` for newcomers; `make lint` for contributors.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.score4-installed
PYTEST_ARGS ?=

.PHONY: demo detector-module test test-deep lint docs docs-check docs-check-all clean

# score4 (editable) with the test extra, plus the pinned linters of the `lint` dependency group
# (pip >= 25.1 reads dependency groups; the step upgrades pip first). Not quiet: from a fresh
# clone this step takes minutes, and pip's lines show it is under way.
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install -e '.[test]' --group lint
	touch $(STAMP)

# The paper's application, small: 5.3 MeV alphas on a flat and on a pyramid-covered silicon face.
demo: $(STAMP)
	mkdir -p out/demo
	$(BIN)/score4 run examples/paper_a_flat.yaml --events 5000 --jobs 2 --out out/demo/flat.h5 --overwrite
	$(BIN)/score4 run examples/paper_a_rough.yaml --events 5000 --jobs 2 --out out/demo/rough.h5 --overwrite
	$(BIN)/score4 summary out/demo/rough.h5
	$(BIN)/score4 plot out/demo/flat.h5 out/demo/rough.h5 --label "flat face" --label "10 um pyramids" --out out/demo/spectra.png --overwrite

# The detector-scale example (examples/detector_module, docs/howto-detector-module.md): a module
# written as GDML by pyg4ometry, Po-210 in its copper frame at two depths, the crystal's spectra.
MODULE := out/detector_module
detector-module: $(STAMP)
	mkdir -p $(MODULE)
	$(BIN)/python examples/detector_module/write_module.py
	$(BIN)/score4 run examples/detector_module/po210_20nm.yaml --jobs 2 --out $(MODULE)/po210_20nm.h5 --overwrite
	$(BIN)/score4 run examples/detector_module/po210_1um.yaml --jobs 2 --out $(MODULE)/po210_1um.h5 --overwrite
	$(BIN)/score4 summary $(MODULE)/po210_1um.h5 --threshold "50 keV"
	$(BIN)/score4 plot $(MODULE)/po210_20nm.h5 $(MODULE)/po210_1um.h5 --volume crystal --label "Po-210 20 nm deep" --label "Po-210 1 um deep" --out $(MODULE)/crystal.png --overwrite

# On both cores (pytest-xdist): two tests at a time. Tests that start several worker
# processes share one xdist group (pytest.mark.xdist_group), so they never run side by side.
test: $(STAMP)
	$(BIN)/python -m pytest -n 2 --dist loadgroup $(PYTEST_ARGS)

# The long validations and fuzz runs that `make test` leaves out (pytest marker `deep`).
test-deep: $(STAMP)
	$(BIN)/python -m pytest -n 2 --dist loadgroup -m deep $(PYTEST_ARGS)

# Lint and types: the same checks as the pre-commit hooks' ruff and mypy, and the import
# contracts of pyproject.toml ([tool.importlinter]: the process boundary, no cycles). ruff and
# mypy (strict, [tool.mypy] files) check src/, benchmarks/ and tools/: a benchmark that calls a
# moved or renamed function fails here, not when someone next measures with it.
lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy
	$(BIN)/lint-imports

# Re-run the commands behind every transcript and figure in README.md and docs/*.md
# (docs/checks.yaml); fails on any difference and on a transcript or figure no check covers
# (conventions at the top of docs/checks.yaml). After a change that moves the numbers:
#   .venv/bin/python tools/docs_check.py --update   (then read the diff)
# --smoke: the slow checks too, each with the small arguments of its `smoke:` entry, their
# output compared by shape only (exit status, lines, table rows, values), so a benchmark that
# stops working is seen here.
docs-check: $(STAMP)
	$(BIN)/python tools/docs_check.py --smoke

# The same plus the slow checks (benchmarks of minutes; timings compared by shape only;
# `tools/docs_check.py --all --update --remeasure` on a quiet machine takes new figures).
docs-check-all: $(STAMP)
	$(BIN)/python tools/docs_check.py --all

# The documentation as a site in site/ (mkdocs.yml; the `docs` dependency group: MkDocs and
# mkdocstrings, installed here on first use). Offline; --strict: a broken page, anchor or
# docstring reference fails the build.
DOCS_STAMP := $(VENV)/.score4-docs-installed
$(DOCS_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet --group docs
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	$(BIN)/mkdocs build --strict

clean:
	rm -rf $(VENV) out build site src/*.egg-info
