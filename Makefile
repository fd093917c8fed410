# drivebench: `make demo` and `make test` each build .venv when it is missing.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint browser clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,dask]'
	touch $(STAMP)

# The report's browser tests use Debian's chromium; install it when we can
# (root with apt), otherwise those tests skip and say why.
browser:
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
	      || echo "note: could not install chromium; browser tests will skip"; \
	  else echo "note: chromium missing and not root; browser tests will skip"; fi; }

demo: $(STAMP)
	$(BIN)/bench synth raw_measurements --check
	$(BIN)/bench run raw_measurements --out demo_out

lint: $(STAMP)
	$(BIN)/ruff check .

# The suite runs on two worker processes (pytest-xdist): the CI machine's two cores.
test: $(STAMP) browser lint
	$(BIN)/python -m pytest -q -n 2

clean:
	rm -rf demo_out .pytest_cache
