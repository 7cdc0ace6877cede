# The two commands of the README: `make demo` (start everything) and `make test` (which
# first installs the system packages the tests need: scripts/system_packages.sh).
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
PYTEST_WORKERS ?= auto

.PHONY: demo test lint fmt bench screenshots clean i18n-extract i18n-compile docs docs-reference

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/chameleons demo $(if $(PORT),--port $(PORT))

# First the system packages the tests need (scripts/system-packages.txt): installed when
# they are missing and this user can (root, or sudo without a password), else it stops here
# naming the one command to run. Then the virtual environment, then the checks.
test:
	scripts/system_packages.sh ensure
	$(MAKE) --no-print-directory $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy chameleons tests
	$(BIN)/pytest -n $(PYTEST_WORKERS) -m "not browser" --durations=20
	$(BIN)/pytest -n $(PYTEST_WORKERS) -m browser --durations=10

# The documentation's screenshots (docs/screenshots/), from a real demo session in Chromium.
screenshots: $(STAMP)
	$(BIN)/python scripts/take_screenshots.py

# The documentation site (mkdocs.yml, docs/) at http://127.0.0.1:8001 while you edit it.
docs: $(STAMP)
	$(BIN)/mkdocs serve --dev-addr 127.0.0.1:8001

# The reference pages generated from the code (docs/reference/: commands, settings, study
# YAML, codebook); a test fails while a committed page differs from what this writes.
docs-reference: $(STAMP)
	$(BIN)/python scripts/docs_reference.py

# Languages (docs/designing-a-study.md, "Languages"): extract the participant's texts into the templates
# (.pot) and merge them into every language's .po; then translate the new entries.
LOCALE := chameleons/locale
i18n-extract: $(STAMP)
	$(BIN)/pybabel extract -F babel.cfg --no-location --sort-output \
	    --project=chameleons -o $(LOCALE)/messages.pot .
	$(BIN)/pybabel extract -F babel-js.cfg -k t --no-default-keywords --no-location \
	    --sort-output --project=chameleons -o $(LOCALE)/phone.pot .
	for lang in $$(ls $(LOCALE) | grep -v '\.pot$$'); do \
	    for domain in messages phone; do \
	        $(BIN)/pybabel update --no-fuzzy-matching --ignore-obsolete -D $$domain -l $$lang \
	            -i $(LOCALE)/$$domain.pot -d $(LOCALE) || exit 1; \
	    done; \
	done

# Optional: the app reads the .po files directly; compiled .mo files (newer than their .po)
# are used instead, and compiling checks the catalogues. `make test` compiles them too, in a
# temporary folder (tests/i18n/test_compile.py), and fails on any error or warning.
i18n-compile: $(STAMP)
	$(BIN)/pybabel compile --statistics -D messages -d $(LOCALE)
	$(BIN)/pybabel compile --statistics -D phone -d $(LOCALE)

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy chameleons tests

fmt: $(STAMP)
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache
