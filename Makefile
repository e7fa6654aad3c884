# flatweave developer commands.
#
#   make run    create .venv if needed, install flatweave into it, open the app
#   make test   install what the tests need (system packages too, as root), run pytest (a worker per core)
#   make test-fast  the same, without the tests marked slow (pytest -m "not slow"): a couple of minutes
#   make lint   ruff (from the venv's dev extras) on the whole tree, configured in pyproject.toml
#
# The venv is (re)installed only when pyproject.toml is newer than the stamp file.

PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.flatweave-installed
PYTEST_ARGS ?=

# Debian packages a Qt xcb window on a virtual display needs beyond the base
# image (checked with `ldd .../PySide6/Qt/plugins/platforms/libqxcb.so`).
APT_PACKAGES := xvfb libxcb-icccm4 libxcb-keysyms1

.PHONY: run test test-fast lint install system-deps check-qt clean-venv

run: $(STAMP)
	$(VENV)/bin/flatweave resources/surfaces/octant.json

# one pytest worker per core (pytest-xdist), a test file's tests on one worker (its module fixtures made once).
# A worker that dies (a native crash, or a test past faulthandler_timeout in pyproject.toml) ends the
# run, naming its test: xdist 3.8 replacing it under loadfile can wait forever at the end of the run
# (pytest-xdist#784, #1378), which is how one CI run spent its 90 minutes after a crash at 70%.
WORKERS := -n auto --dist loadfile --max-worker-restart=0

test: system-deps $(STAMP) check-qt
	$(PY) -m pytest $(WORKERS) $(PYTEST_ARGS)

test-fast: system-deps $(STAMP) check-qt
	$(PY) -m pytest $(WORKERS) -m "not slow" $(PYTEST_ARGS)

lint: $(STAMP)
	$(VENV)/bin/ruff check .

install: $(STAMP)

$(PY):
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $@

# Install the missing Debian packages when root; otherwise name them and stop.
system-deps:
	@if ! command -v dpkg-query >/dev/null 2>&1; then \
	  echo "make: not a Debian system; skipping the system package check"; exit 0; \
	fi; \
	missing=""; \
	for p in $(APT_PACKAGES); do \
	  dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q 'install ok installed' \
	    || missing="$$missing $$p"; \
	done; \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" = 0 ]; then \
	  echo "make: installing system packages:$$missing"; \
	  apt-get update -qq \
	    && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing; \
	else \
	  echo "make: missing system packages:$$missing" >&2; \
	  echo "make: install them with: sudo apt-get install --no-install-recommends$$missing" >&2; \
	  exit 1; \
	fi

# Qt reports a missing xcb library misleadingly (it blames libxcb-cursor0);
# name the real culprit before the GUI tests fail on it.
check-qt: $(STAMP)
	@plugin="$$($(PY) -c 'import pathlib, PySide6; print(pathlib.Path(PySide6.__file__).parent / "Qt/plugins/platforms/libqxcb.so")')"; \
	if [ -f "$$plugin" ] && command -v ldd >/dev/null 2>&1; then \
	  missing="$$(ldd "$$plugin" | grep 'not found' | sort -u)"; \
	  if [ -n "$$missing" ]; then \
	    echo "make: Qt's xcb platform plugin cannot load; missing libraries:" >&2; \
	    echo "$$missing" >&2; exit 1; \
	  fi; \
	fi

clean-venv:
	rm -rf $(VENV)
