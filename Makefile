# Everything starts from a clean clone with only Python 3.11 and pip.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
BASE   := $(VENV)/.installed
STAMP  := $(VENV)/.installed-dev
OUT    ?= out
# a line every 5 s while a long step works (pip can unpack wheels for a minute silently)
BEAT   := .ci/heartbeat

.PHONY: demo test fuzz lint bench bench-quick bench-peers clean venv warmup

# inins and what it needs to run (the demo); then the test, plot and cluster extras
$(BASE): pyproject.toml
	$(BEAT) "creating $(VENV)" $(PYTHON) -m venv $(VENV)
	$(BEAT) "installing inins and its dependencies" \
	  $(BIN)/python -m pip install --progress-bar off -e .
	touch $(BASE)

$(STAMP): $(BASE)
	$(BEAT) "installing the test, plot and cluster extras" \
	  $(BIN)/python -m pip install --progress-bar off -e '.[dev,plot,cluster]'
	touch $(STAMP)

venv: $(STAMP)

# The first run of a command compiles the numerical kernels it needs (and says so);
# later runs load them from numba's on-disk cache. `inins warmup` compiles them ahead.
warmup: $(BASE)
	$(BIN)/inins warmup

demo: $(BASE)
	$(BIN)/inins calibrate-bias -o $(OUT)/demo
	@echo; echo "the full report: $(OUT)/demo/calibrate-bias.txt"

lint: $(STAMP)
	$(BIN)/ruff check inins tests benchmarks
	$(BIN)/ruff format --check inins tests benchmarks
	$(BIN)/lint-imports

# The kernels are compiled once before the workers start (else each worker compiles
# the same ones). PYTHONDONTWRITEBYTECODE cleared: pytest keeps its rewrite of the test
# modules (their asserts) as bytecode, which every worker would otherwise redo.
test: lint warmup
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

# the C tools the whole-process rows run beside inins (Debian's rtklib: rnx2rtkp); where
# they cannot be installed (no apt-get, not root, offline) those rows are skipped with a note
bench-peers:
	@command -v rnx2rtkp >/dev/null || { command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ] \
	  && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq rtklib >/dev/null 2>&1; } \
	  || echo "rnx2rtkp not installed: make bench skips the SPP peer row"

bench: warmup $(BENCH) bench-peers
	$(BIN)/python -m benchmarks

bench-quick: warmup $(BENCH) bench-peers
	$(BIN)/python -m benchmarks --quick

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .ruff_cache .import_linter_cache
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
