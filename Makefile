# The README's two commands are `make demo` and `make test`; everything else is a step of those.
PY := .venv/bin/python
PIP := .venv/bin/pip
# uv installs the pinned requirements: in about 16 s where pip took 42 (one core, then byte-compiling
# every file on it), the first step of every `make test` from a fresh clone (docs/decisions.md, Dependencies)
UV_VERSION := 0.13.9

.PHONY: demo test lint venv browser-deps serve-deps media-deps messages table bench clean serve load docs example example-videos bench-teaching leaderboard leaderboard-paper

venv: .venv/.installed
.venv/.installed: requirements.txt
	test -x $(PY) || python3 -m venv .venv
	$(PIP) install -q uv==$(UV_VERSION)
	.venv/bin/uv pip install -q --python $(PY) --compile-bytecode -r requirements.txt
	touch $@

# Debian's Chromium for the Playwright browser tests (CI runs as root on Debian).
browser-deps:
	@command -v chromium >/dev/null 2>&1 || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null)

# Debian's ffmpeg: ffprobe checks that an imported table's videos are videos a browser plays (docs/importing.md).
media-deps:
	@command -v ffprobe >/dev/null 2>&1 || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq ffmpeg >/dev/null)

# Debian's nginx for scripts/serve.sh (in front of gunicorn; config/nginx.conf.template).
serve-deps:
	@command -v nginx >/dev/null 2>&1 || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nginx >/dev/null)

# The participants' languages: locale/<lang>/LC_MESSAGES/*.po compiled to .mo (not kept in git) with Debian's
# gettext (msgfmt --check refuses a translation whose placeholders differ from its English).
messages:
	@command -v msgfmt >/dev/null 2>&1 || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq gettext >/dev/null)
	@for po in locale/*/LC_MESSAGES/*.po; do [ -e "$$po" ] || continue; msgfmt --check -o "$${po%.po}.mo" "$$po" || exit 1; done

# Where tables live: $TABLES_DIR, else $VAR_DIR/tables, else var/tables (config/settings.py's TABLES_DIR).
TABLES_DIR ?= $(or $(VAR_DIR),var)/tables

table: venv
	$(PY) -m teaching build --preset demo --out $(TABLES_DIR)/demo

# Serve the demo study locally on the embedded default (SQLite + filesystem broker, worker included).
demo: venv table messages
	bash scripts/demo.sh

# The teaching benchmark on the demo table (docs/benchmark.md): every selector x every learner x 10 seeds,
# resumed where a run stopped.
bench-teaching: venv table
	.venv/bin/python -m teaching benchmark --table $(TABLES_DIR)/demo --out $(or $(VAR_DIR),var)/benchmark --seeds 10

# docs/leaderboard.md and its figures, generated from the benchmark of the five small tables (built where missing),
# 10 seeds each: a rerun computes only the cells its results folder lacks.
LEADERBOARD_TABLES := demo gridworld skateboard taxi two-goal
leaderboard: venv
	for t in $(LEADERBOARD_TABLES); do test -f $(TABLES_DIR)/$$t/meta.json || \
		.venv/bin/python -m teaching build --preset $$t --out $(TABLES_DIR)/$$t || exit 1; done
	.venv/bin/python -m teaching benchmark $(foreach t,$(LEADERBOARD_TABLES),--table $(TABLES_DIR)/$(t)) \
		--out $(or $(VAR_DIR),var)/leaderboard --seeds 10 --leaderboard docs/leaderboard.md

# The same page with the paper's table too, whose cells a Celery worker on this machine computes (the filesystem
# broker; bench/teaching_benchmark_workers.py builds the table where missing, ~30 min, then times the run).
leaderboard-paper: venv
	.venv/bin/python bench/teaching_benchmark_workers.py --preset paper --tables-dir $(TABLES_DIR) \
		--out $(or $(VAR_DIR),var)/leaderboard --seeds 10
	$(MAKE) leaderboard LEADERBOARD_TABLES="$(LEADERBOARD_TABLES) paper"

# The worked example of a robot from outside the project (examples/hallway): its table folder from its own
# planner, imported, taught, made a study and served locally.
example: venv messages
	bash examples/hallway/serve.sh

# The same robot shown by the clips its own script renders (matplotlib and ffmpeg): docs/importing.md, "Videos".
example-videos: venv messages media-deps
	bash examples/hallway/serve.sh --videos

# The production configuration on this machine: gunicorn + PostgreSQL + Redis + a Celery worker
# (docs/operations.md; DATABASE_URL, CELERY_BROKER_URL, CACHE_URL, BIND override).
serve: venv serve-deps
	bash scripts/serve.sh

# Launch-day load: 500 simulated participants within 60 s against a fresh PostgreSQL database,
# PostgreSQL restarted in the middle (docs/operations.md); LOAD_ARGS adds options.
load: venv serve-deps table
	$(PY) -m tests.load.run --participants 500 --window 60 $(LOAD_ARGS)

# Ruff, configured in pyproject.toml; .ci/run runs it before the tests.
lint: venv
	.venv/bin/ruff check .

# Two pytest runs side by side: most of the suite in three pytest-xdist workers, and the tests of the
# machine's shared services (marked postgres or redis) one after another, as they must be (the load
# test restarts PostgreSQL under every connection; the load harness and the real-worker tests own
# Redis databases).  The first run touches neither service, so the two cannot disturb each other;
# the second one's output is printed when both are done.  Both build the tables they need in one
# directory made for this command ($TEST_BUILDS_DIR, tests/conftest.py's built_once), so the demo
# table is built once, not once per run.  (xdist's own grouping, --dist loadgroup,
# is silently ignored under pytest 9.2: pytest-xdist #1386.)  The xdist run hands each worker a contiguous
# slice of the tests, longest modules first, and an idle worker takes half of a busy one's queue
# (--dist worksteal): a module's tests mostly stay on one worker, so its module-scoped fixtures are
# built once, and no worker sits out the last minutes while another works through a queue it was
# dealt.  Before both, tests/prebuild.py compiles
# the planner's Numba kernels into their disk caches and builds the demo table, on the idle machine,
# so that no test pays a cold compile or waits for that table while the two runs compete for it, and
# collects the tests once: Python may write bytecode here (unset PYTHONDONTWRITEBYTECODE, which this
# machine sets), so the project's modules and pytest's rewritten test modules are compiled once, not in
# every pytest process, server and subprocess of the suite.
# Each xdist worker runs Numba's kernels and BLAS on one thread: three workers beside the services' run on
# two cores are already more processes than cores, and a second thread per worker only competed with the
# others (docs/decisions.md, "One thread per worker"); the tables' bytes do not depend on the thread count,
# and the prebuilt tables the tests compare with were built on every core.
# pytest exit 5 means "no tests collected": that is a failure here, never a pass.
SERVICES_LOG = var/test-services.log
test: venv browser-deps serve-deps media-deps messages
	@mkdir -p var
	unset PYTHONDONTWRITEBYTECODE; export TEST_BUILDS_DIR=$$(mktemp -d /tmp/test-builds.XXXXXX); \
	$(PY) -m tests.prebuild || exit 1; \
	$(PY) -m pytest -p no:cacheprovider -m "postgres or redis" > $(SERVICES_LOG) 2>&1 & svc=$$!; \
	NUMBA_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -n 3 --dist worksteal -m "not (postgres or redis)"; a=$$?; \
	echo "--- the shared-services tests ($(SERVICES_LOG)) ---"; wait $$svc; b=$$?; cat $(SERVICES_LOG); \
	rm -rf "$$TEST_BUILDS_DIR"; \
	for rc in $$a $$b; do if [ $$rc -eq 5 ]; then echo "pytest collected no tests" >&2; exit 1; fi; done; \
	if [ $$a -ne 0 ]; then exit $$a; fi; exit $$b

# The documentation as a site in site/ (strict: a broken link or anchor fails it); `.venv/bin/mkdocs serve` to read.
docs: venv
	.venv/bin/mkdocs build --strict

bench: venv
	$(PY) bench/planner.py
	$(PY) bench/teaching.py
	$(PY) bench/gridworld.py
	$(PY) bench/precompute.py
	$(PY) bench/exports.py
	$(PY) bench/fitting.py

clean:
	rm -rf var/ test-output/ .pytest_cache
