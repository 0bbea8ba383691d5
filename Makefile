# Everything starts from a clean clone with only Python 3.11 and pip.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= out

.PHONY: demo test fuzz lint bench bench-quick clean venv kernels

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,plot,cluster]'
	touch $(STAMP)

venv: $(STAMP)

# numba's cache of every kernel, and the kernel library short runs load without
# numba: compiled at install (about 40 s), checked again when a source changed
KERNELS := $(VENV)/.kernels
# (one BLAS thread: the short runs' small matrices, e.g. the 26-state Gramian's matrix
# exponentials, took 3-10 times the CPU with threaded OpenBLAS on a busy machine)
$(KERNELS): $(STAMP) $(shell find inins -name '*.py')
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(BIN)/python -m inins.commands.warmup
	touch $(KERNELS)

kernels: $(KERNELS)

demo: kernels
	$(BIN)/inins calibrate-bias -o $(OUT)/demo
	@echo; echo "the full report: $(OUT)/demo/calibrate-bias.txt"

lint: $(STAMP)
	$(BIN)/ruff check inins tests benchmarks
	$(BIN)/ruff format --check inins tests benchmarks
	$(BIN)/lint-imports

# PYTHONDONTWRITEBYTECODE cleared: pytest keeps its rewrite of the test modules (their
# asserts) as bytecode, which every worker would otherwise redo (3 s of CPU each)
test: lint kernels
	PYTHONDONTWRITEBYTECODE= $(BIN)/python -m pytest -n auto --dist loadscope

# More examples of the property tests (tests/cli/test_fuzz*.py: scenarios, table data,
# the recorded flight, every reader of solutions, IMU logs and RINEX), random seed:
# FUZZ_EXAMPLES per test (make test runs a derandomized subset of each).
FUZZ_EXAMPLES ?= 5000
fuzz: $(STAMP)
	ININS_FUZZ_EXAMPLES=$(FUZZ_EXAMPLES) $(BIN)/python -m pytest tests/cli/test_fuzz.py tests/cli/test_fuzz_flight.py tests/cli/test_fuzz_readers.py -q

# the yardsticks the benchmarks compare with (pyins' strapdown, allantools): the bench extra
BENCH := $(VENV)/.bench
$(BENCH): $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[bench]'
	touch $(BENCH)

bench: kernels $(BENCH)
	$(BIN)/python -m benchmarks

bench-quick: kernels $(BENCH)
	$(BIN)/python -m benchmarks --quick

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .ruff_cache .import_linter_cache
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
