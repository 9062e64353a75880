#!/usr/bin/env bash
# Serve the demo study on the embedded default: SQLite and kombu's filesystem
# broker (no server), with one Celery worker in the background that is stopped
# when the server stops (Ctrl-C).
set -euo pipefail
cd "$(dirname "$0")/.."
# A local demo: debug on (settings default to off, for anything started by hand in production).
export DEBUG=${DEBUG:-1}
PY=.venv/bin/python
ADDR=${DEMO_ADDR:-127.0.0.1:8000}
$PY manage.py migrate --verbosity 0
.venv/bin/celery -A config worker --pool=prefork --concurrency 1 --loglevel WARNING &
worker=$!
stop_worker() { kill -TERM "$worker" 2>/dev/null && wait "$worker" 2>/dev/null || true; }
trap stop_worker EXIT INT TERM
$PY manage.py setup_demo --serve --demo-login --addrport "$ADDR"  # the table: $DEMO_TABLE or $TABLES_DIR/demo
