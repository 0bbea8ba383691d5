# Everything starts from a clean clone with only Python 3.11 and pip.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= out

.PHONY: demo test lint bench bench-quick clean venv

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,plot,cluster]'
	$(BIN)/python -m inins.commands.warmup
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(BIN)/inins calibrate-bias -o $(OUT)/demo
	@echo; cat $(OUT)/demo/calibrate-bias.txt

lint: $(STAMP)
	$(BIN)/ruff check inins tests benchmarks
	$(BIN)/ruff format --check inins tests benchmarks
	$(BIN)/lint-imports

test: lint
	$(BIN)/python -m pytest -n auto --dist loadscope

bench: $(STAMP)
	$(BIN)/python -m benchmarks

bench-quick: $(STAMP)
	$(BIN)/python -m benchmarks --quick

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .ruff_cache .import_linter_cache
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
