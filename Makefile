# The README's two commands are `make demo` and `make test`; everything else is a step of those.
PY := .venv/bin/python
PIP := .venv/bin/pip

.PHONY: demo test venv browser-deps table bench clean

venv: .venv/.installed
.venv/.installed: requirements.txt
	test -x $(PY) || python3 -m venv .venv
	$(PIP) install -q --upgrade pip
	$(PIP) install -q -r requirements.txt
	touch $@

# Debian's Chromium for the Playwright browser tests (CI runs as root on Debian).
browser-deps:
	@command -v chromium >/dev/null 2>&1 || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null)

table: venv
	$(PY) -m teaching build --preset demo --out var/tables/demo

# Serve the demo study locally on the embedded default (SQLite + filesystem broker, worker included).
demo: venv table
	bash scripts/demo.sh

# pytest exit 5 means "no tests collected": that is a failure here, never a pass.
test: venv browser-deps
	$(PY) -m pytest; rc=$$?; if [ $$rc -eq 5 ]; then echo "pytest collected no tests" >&2; exit 1; fi; exit $$rc

bench: venv
	$(PY) bench/planner.py
	$(PY) bench/teaching.py
	$(PY) bench/precompute.py

clean:
	rm -rf var/ test-output/ .pytest_cache
