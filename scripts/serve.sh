#!/usr/bin/env bash
# Serve the study app in its production configuration on this machine: gunicorn on PostgreSQL,
# Redis as Celery broker and cache, WhiteNoise for static files, plus one Celery worker for the
# precompute builds, with nginx in front; all three under supervisord, which restarts each one
# alone if it dies.
# Ctrl-C (or SIGTERM) stops them gracefully: requests and tasks in flight finish first.  Every
# setting is an environment variable (docs/operations.md).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=.venv/bin/python

export DATABASE_URL=${DATABASE_URL:-postgres://postgres@127.0.0.1:5432/study}
export CELERY_BROKER_URL=${CELERY_BROKER_URL:-redis://127.0.0.1:6379/0}
export CACHE_URL=${CACHE_URL:-redis://127.0.0.1:6379/1}
export CONN_MAX_AGE=${CONN_MAX_AGE:-60}
export DEBUG=${DEBUG:-0}
export ALLOWED_HOSTS=${ALLOWED_HOSTS:-localhost,127.0.0.1}
BIND=${BIND:-127.0.0.1:8000}
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
    echo "serve: plain HTTP on $BIND (set BEHIND_PROXY=1 behind a TLS proxy)" >&2
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

VAR_DIR=$(cd "$VAR" && pwd)
export SERVE_ROOT=$PWD VAR_DIR

# nginx on $BIND reads every request whole before gunicorn sees it, so slow clients never hold
# gunicorn's threads (config/nginx.conf.template).  gunicorn listens on a Unix socket only nginx
# uses, under /tmp because a Unix socket's path is limited to 107 bytes.
export BIND GUNICORN_BIND=${GUNICORN_BIND:-unix:/tmp/study-gunicorn-$(printf %s "$VAR_DIR" | sha1sum | cut -c1-12).sock}
# nginx appends the address it saw to X-Forwarded-For: one more proxy for the rate limits to count past.
export TRUSTED_PROXY_COUNT=$(( ${TRUSTED_PROXY_COUNT:-0} + 1 ))
export NGINX_DIR=$VAR_DIR/nginx NGINX_CONF=$VAR_DIR/nginx/nginx.conf
mkdir -p "$NGINX_DIR"
$PY scripts/render_nginx.py "$NGINX_CONF"
if ! nginx -t -q -c "$NGINX_CONF" -e stderr; then
    echo "serve: nginx refuses $NGINX_CONF (is it installed? make serve-deps)" >&2
    exit 1
fi

# supervisord (config/supervisord.conf) runs nginx, gunicorn and the Celery worker and restarts
# each one on its own when it dies: a killed worker never takes the participant site down.
# Ctrl-C or SIGTERM stops them gracefully (requests and the task in flight finish first).
export CELERY_CONCURRENCY=${CELERY_CONCURRENCY:-1} PRECOMPUTE_QUEUE=${PRECOMPUTE_QUEUE:-celery}
export CELERY_LOG_LEVEL=${CELERY_LOG_LEVEL:-WARNING}
exec .venv/bin/supervisord -c config/supervisord.conf
