# trimd: every target creates/reuses .venv with the machine's python3.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test test-fast bench lint install browser clean

# MAVProxy (the ground-station-in-the-loop tests) without its declared dependencies, which
# pull in GUI libraries: its --daemon --non-interactive mode needs only pymavlink.
# --no-compile: pip would compile every installed module (28 of the install's 64 s here);
# what trimd and its terminal UI import is compiled instead (7 s), even where the machine
# turns bytecode caching off (PYTHONDONTWRITEBYTECODE: each trimd command would then
# compile numpy, scipy and Textual afresh, ≈ 3 s).
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet --no-compile -e '.[test]'
	$(BIN)/python -m pip install --quiet --no-compile --no-deps MAVProxy==1.8.75
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -c "import trimd.cli.main, trimd.tui.app, \
		trimd.tui.run, trimd.tui.watch_app, trimd.tui.replay_app, scipy.signal"
	touch $(STAMP)

install: $(STAMP)

# The browser the page test drives (tests/app/test_serve_browser.py): Debian's chromium when
# apt can install it, else playwright's own build.
# Never fails: where neither can be installed the page test skips and says why.
browser: $(STAMP)
	@command -v chromium >/dev/null || command -v chromium-browser >/dev/null || \
		apt-get install -y -q chromium >/dev/null 2>&1 || \
		$(BIN)/python -m playwright install chromium >/dev/null 2>&1 || \
		echo "make browser: no chromium could be installed; the page test will skip"

# The full trim procedure on the simulated Sabertooth with 10 kg at AftSB: the terminal UI
# when a terminal is attached, headless progress otherwise.
demo: $(STAMP)
	$(BIN)/trimd demo

lint: $(STAMP)
	$(BIN)/ruff check trimd tests bench examples
	$(BIN)/mypy

# The whole suite on one worker more than the machine has cores (pytest-xdist), the 15
# slowest tests listed at the end; test-fast leaves out the tests marked slow (the inner
# loop). The extra worker fills the time the others wait on simulators that the wall clock
# paces (a served vehicle at 10×, MAVProxy beside it: a fifth of the workers' time): on
# this 2-core machine 3 workers ran the suite in 498 s where 2 took 598 s. With bytecode
# caching on even where the machine turns it off (PYTHONDONTWRITEBYTECODE): each of the
# suite's trimd subprocesses would otherwise compile trimd from source (≈ 0.5 s of CPU).
WORKERS := $(shell echo $$(( $$(nproc) + 1 )))
PYTEST := env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -n $(WORKERS) \
	--dist worksteal --durations=15

test: lint browser
	$(PYTEST)

test-fast: lint browser
	$(PYTEST) -m "not slow"

bench: $(STAMP)
	$(BIN)/python -m bench

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache
