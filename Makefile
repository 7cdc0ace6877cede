# The two commands of the README: `make demo` (start everything) and `make test`.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
PYTEST_WORKERS ?= auto

.PHONY: demo test lint fmt bench screenshots clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/chameleons demo $(if $(PORT),--port $(PORT))

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy chameleons tests
	$(BIN)/pytest -n $(PYTEST_WORKERS) -m "not browser"
	$(BIN)/pytest -n $(PYTEST_WORKERS) -m browser

# The README's screenshots (docs/screenshots/), from a real demo session in Chromium.
screenshots: $(STAMP)
	$(BIN)/python scripts/take_screenshots.py

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy chameleons tests

fmt: $(STAMP)
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache
