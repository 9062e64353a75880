#!/usr/bin/env bash
# Serve the study app in its production configuration on this machine: gunicorn on PostgreSQL,
# Redis as Celery broker and cache, WhiteNoise for static files, plus one Celery worker for the
# precompute builds.  Ctrl-C (or SIGTERM) stops both gracefully: requests and tasks in flight
# finish first.  Every setting is an environment variable (docs/operations.md).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=.venv/bin/python

export DATABASE_URL=${DATABASE_URL:-postgres://postgres@127.0.0.1:5432/study}
export CELERY_BROKER_URL=${CELERY_BROKER_URL:-redis://127.0.0.1:6379/0}
export CACHE_URL=${CACHE_URL:-redis://127.0.0.1:6379/1}
export CONN_MAX_AGE=${CONN_MAX_AGE:-60}
export DEBUG=${DEBUG:-0}
export ALLOWED_HOSTS=${ALLOWED_HOSTS:-localhost,127.0.0.1}
export GUNICORN_BIND=${GUNICORN_BIND:-127.0.0.1:8000}
VAR=${VAR_DIR:-var}
mkdir -p "$VAR"

# Sessions and CSRF tokens are signed with SECRET_KEY: keep one across restarts rather than
# logging every participant out (and failing their next save) whenever the server restarts.
if [ -z "${SECRET_KEY:-}" ]; then
    if [ ! -s "$VAR/secret_key" ]; then
        (umask 077 && $PY -c "import secrets; print(secrets.token_urlsafe(50))" > "$VAR/secret_key")
    fi
    SECRET_KEY=$(cat "$VAR/secret_key")
    export SECRET_KEY
fi

# Without a TLS proxy in front this serves plain HTTP, where HTTPS redirects, HSTS and
# HTTPS-only cookies would lock everyone out; behind one (BEHIND_PROXY=1) they stay on.
if [ "${BEHIND_PROXY:-0}" != "1" ]; then
    export SECURE_SSL_REDIRECT=${SECURE_SSL_REDIRECT:-0} SECURE_HSTS_SECONDS=${SECURE_HSTS_SECONDS:-0}
    export SECURE_COOKIES=${SECURE_COOKIES:-0}
    echo "serve: plain HTTP on $GUNICORN_BIND (set BEHIND_PROXY=1 behind a TLS proxy)" >&2
fi

# The database named in DATABASE_URL is created on first use (the server must exist).
$PY - <<'EOF'
import os, sys
import dj_database_url, psycopg
from psycopg import sql
db = dj_database_url.parse(os.environ["DATABASE_URL"])
if db["ENGINE"] == "django.db.backends.postgresql":
    params = {k: v for k, v in {"host": db["HOST"], "port": db["PORT"] or None, "user": db["USER"],
                                "password": db["PASSWORD"] or None}.items() if v}
    try:
        with psycopg.connect(dbname="postgres", autocommit=True, connect_timeout=10, **params) as conn:
            if not conn.execute("SELECT 1 FROM pg_database WHERE datname = %s", [db["NAME"]]).fetchone():
                conn.execute(sql.SQL("CREATE DATABASE {}").format(sql.Identifier(db["NAME"])))
                print(f"serve: created database {db['NAME']}", file=sys.stderr)
    except psycopg.Error as exc:
        sys.exit(f"serve: cannot reach PostgreSQL for {db['NAME']!r}: {exc}")
EOF
$PY manage.py migrate --noinput --verbosity 0
$PY manage.py collectstatic --noinput --verbosity 0

# Job control gives each child its own process group, so a terminal's Ctrl-C reaches only this
# script, which then sends each child exactly one SIGTERM: a second signal would make the Celery
# worker abandon its task (cold shutdown) instead of finishing it.
set -m
.venv/bin/gunicorn -c config/gunicorn.conf.py config.wsgi &
web=$!
.venv/bin/celery -A config worker --pool=prefork --concurrency "${CELERY_CONCURRENCY:-1}" \
    --queues "${PRECOMPUTE_QUEUE:-celery}" --loglevel "${CELERY_LOG_LEVEL:-WARNING}" &
worker=$!

stopped=0
stop() {
    [ "$stopped" = 1 ] && return
    stopped=1
    echo "serve: stopping gunicorn ($web) and the Celery worker ($worker)" >&2
    kill -TERM "$web" "$worker" 2>/dev/null || true
    wait "$web" 2>/dev/null || true
    wait "$worker" 2>/dev/null || true
}
# A second Ctrl-C (make forwards one too) must not cut the graceful stop short.
trap 'trap "" INT TERM; stop; exit 0' INT TERM
trap stop EXIT
# Either one dying takes the other down too: half a server is worse than none.
set +e
wait -n "$web" "$worker"
rc=$?
set -e
echo "serve: a child exited (status $rc)" >&2
stop
exit "$rc"
