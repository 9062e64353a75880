"""The production configuration: `check --deploy` is clean, and a database outage answers 503.

Settings are read once per process, so the configuration tests run Django in a subprocess with
the production environment (docs/operations.md), as gunicorn would.
"""
from __future__ import annotations

import json
import os
import secrets
import subprocess
import sys
from pathlib import Path

import pytest
from django.contrib.sessions.backends.db import SessionStore
from django.db import InterfaceError, OperationalError
from django.test import Client

from studyapp.participant import views

ROOT = Path(__file__).resolve().parents[2]
# The variables a deployment sets (docs/operations.md); everything else is left to its default.
PRODUCTION_ENV = {"DEBUG": "0", "SECRET_KEY": secrets.token_urlsafe(50), "ALLOWED_HOSTS": "study.example.org",
                  "DATABASE_URL": "postgres://study@db.example.org:5432/study", "CONN_MAX_AGE": "60",
                  "CELERY_BROKER_URL": "redis://127.0.0.1:6379/0"}
CLEARED = ("DEBUG", "SECRET_KEY", "ALLOWED_HOSTS", "DATABASE_URL", "CELERY_BROKER_URL", "SECURE_SSL_REDIRECT",
           "SECURE_HSTS_SECONDS", "SECURE_HSTS_INCLUDE_SUBDOMAINS", "SECURE_HSTS_PRELOAD", "SECURE_COOKIES",
           "BEHIND_PROXY", "CONN_MAX_AGE")


def run_django(tmp_path, args, **env):
    base = {k: v for k, v in os.environ.items() if k not in CLEARED}
    base.update(DJANGO_SETTINGS_MODULE="config.settings", VAR_DIR=str(tmp_path / "var"), **env)
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=base, capture_output=True, text=True, timeout=120)


def test_check_deploy_is_clean_in_production(tmp_path):
    out = run_django(tmp_path, ["manage.py", "check", "--deploy", "--fail-level", "WARNING"], **PRODUCTION_ENV)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "System check identified no issues (0 silenced)." in out.stdout, out.stdout + out.stderr
    assert "WARNING" not in out.stdout + out.stderr


def test_check_deploy_flags_a_development_environment(tmp_path):
    """The check above is real: the demo's settings (DEBUG on, dev key) are reported."""
    out = run_django(tmp_path, ["manage.py", "check", "--deploy", "--fail-level", "WARNING"], DEBUG="1")
    assert out.returncode != 0
    assert "security.W018" in out.stderr and "security.W009" in out.stderr


PROBE = """
import json, django
django.setup()
from django.conf import settings as s
print(json.dumps({"redirect": s.SECURE_SSL_REDIRECT, "hsts": s.SECURE_HSTS_SECONDS, "proxy": s.SECURE_PROXY_SSL_HEADER,
                  "cookie": s.SESSION_COOKIE_SECURE, "health": s.DATABASES["default"]["CONN_HEALTH_CHECKS"],
                  "age": s.DATABASES["default"]["CONN_MAX_AGE"], "finders": s.WHITENOISE_USE_FINDERS}))
"""


def test_production_settings_come_from_the_environment(tmp_path):
    out = run_django(tmp_path, ["-c", PROBE], **PRODUCTION_ENV)
    assert out.returncode == 0, out.stderr
    cfg = json.loads(out.stdout)
    assert cfg == {"redirect": True, "hsts": 31536000, "proxy": None, "cookie": True, "health": True, "age": 60,
                   "finders": False}
    # plain HTTP on a trusted host (scripts/serve.sh without a proxy), and behind a TLS proxy
    out = run_django(tmp_path, ["-c", PROBE], **dict(PRODUCTION_ENV, SECURE_SSL_REDIRECT="0", SECURE_HSTS_SECONDS="0",
                                                  SECURE_COOKIES="0"))
    cfg = json.loads(out.stdout)
    assert (cfg["redirect"], cfg["hsts"], cfg["cookie"]) == (False, 0, False)
    out = run_django(tmp_path, ["-c", PROBE], **dict(PRODUCTION_ENV, BEHIND_PROXY="1"))
    assert json.loads(out.stdout)["proxy"] == ["HTTP_X_FORWARDED_PROTO", "https"]


# --- a database outage -------------------------------------------------------------------
def assert_unavailable(response, as_json):
    assert response.status_code == 503
    assert int(response["Retry-After"]) > 0
    assert "no-store" in response["Cache-Control"]
    body = response.content.decode()
    assert "Traceback" not in body and "OperationalError" not in body and "InterfaceError" not in body
    if as_json:
        data = json.loads(body)
        assert data["ok"] is False and "unavailable" in data["error"]
    else:
        assert response["Content-Type"].startswith("text/html") and "try again" in body


@pytest.mark.parametrize("error", [OperationalError("server closed the connection unexpectedly"),
                                   InterfaceError("connection already closed")])
def test_database_error_in_a_view_is_a_503(study, client, monkeypatch, error):
    def down(*args, **kwargs):
        raise error

    monkeypatch.setattr(views, "assign", down)
    assert_unavailable(client.get(f"/s/{study.slug}/", {"PROLIFIC_PID": "p1"}), as_json=False)
    monkeypatch.setattr(views, "_participant", down)
    assert_unavailable(client.get(f"/s/{study.slug}/p/tok/"), as_json=False)
    assert_unavailable(client.post(f"/s/{study.slug}/p/tok/0/", {"consent": "yes"}, HTTP_ACCEPT="application/json"),
                       as_json=True)


def test_database_error_outside_the_view_is_a_503(study, monkeypatch):
    """The session is saved by its middleware after the view: handler500 turns that into a 503."""
    def down(self, *args, **kwargs):
        raise OperationalError("the database system is shutting down")

    monkeypatch.setattr(SessionStore, "save", down)
    client = Client(raise_request_exception=False)
    assert_unavailable(client.get(f"/s/{study.slug}/", {"PROLIFIC_PID": "p1"}), as_json=False)


def test_other_errors_stay_500(study, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("a bug")

    monkeypatch.setattr(views, "assign", broken)
    response = Client(raise_request_exception=False).get(f"/s/{study.slug}/", {"PROLIFIC_PID": "p1"})
    assert response.status_code == 500 and "Retry-After" not in response


OUTAGE = """
import json, django
django.setup()
from django.test import Client
c = Client(raise_request_exception=False)
r1 = c.get("/s/demo/?PROLIFIC_PID=p1")
r2 = c.post("/s/demo/p/tok/0/", {"consent": "yes"}, HTTP_ACCEPT="application/json")
print(json.dumps([[r.status_code, r.get("Retry-After"), r.content.decode()] for r in (r1, r2)]))
"""


def test_unreachable_database_is_a_503(tmp_path):
    """A real connection failure (nothing listens on port 9 of loopback), in production settings."""
    env = dict(PRODUCTION_ENV, DATABASE_URL="postgres://postgres@127.0.0.1:9/none", ALLOWED_HOSTS="testserver",
               SECURE_SSL_REDIRECT="0")
    out = run_django(tmp_path, ["-c", OUTAGE], **env)
    assert out.returncode == 0, out.stderr
    (s1, ra1, html), (s2, ra2, body) = json.loads(out.stdout.strip().splitlines()[-1])
    assert (s1, s2) == (503, 503) and int(ra1) > 0 and int(ra2) > 0
    assert "try again" in html and "Traceback" not in html
    assert json.loads(body)["ok"] is False
