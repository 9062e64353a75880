"""Env-driven settings and the embedded defaults (SQLite under var/, filesystem broker)."""
import json
import os
import subprocess
import sys
from pathlib import Path

from config import settings

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import json, django
django.setup()
from django.conf import settings
from config.celery import app
db = settings.DATABASES["default"]
print(json.dumps({"engine": db["ENGINE"], "name": str(db["NAME"]), "options": db.get("OPTIONS", {}),
                  "broker": app.conf.broker_url, "backend": app.conf.result_backend,
                  "transport": app.conf.broker_transport_options, "debug": settings.DEBUG,
                  "hosts": settings.ALLOWED_HOSTS}))
"""


def probe(tmp_path, **env):
    base = {k: v for k, v in os.environ.items() if k not in ("DATABASE_URL", "CELERY_BROKER_URL", "DEBUG",
                                                               "SECRET_KEY", "ALLOWED_HOSTS")}
    base.update(DJANGO_SETTINGS_MODULE="config.settings", VAR_DIR=str(tmp_path / "var"), **env)
    out = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, env=base, capture_output=True, text=True,
                         timeout=60)
    return out


def test_embedded_defaults(tmp_path):
    out = probe(tmp_path, DEBUG="1")
    assert out.returncode == 0, out.stderr
    cfg = json.loads(out.stdout)
    assert cfg["engine"] == "django.db.backends.sqlite3"
    assert cfg["name"] == str(tmp_path / "var" / "db.sqlite3") and (tmp_path / "var").is_dir()
    assert cfg["options"]["transaction_mode"] == "IMMEDIATE"
    assert cfg["broker"] == "filesystem://" and cfg["backend"] == "django-db"
    assert cfg["transport"]["data_folder_in"] == str(tmp_path / "var" / "broker" / "out")
    assert (tmp_path / "var" / "broker" / "processed").is_dir()


def test_environment_overrides(tmp_path):
    out = probe(tmp_path, DATABASE_URL="postgres://u@db.example:5432/study", CELERY_BROKER_URL="redis://r:6379/0",
                DEBUG="0", SECRET_KEY="s" * 50, ALLOWED_HOSTS="a.example, b.example")
    assert out.returncode == 0, out.stderr
    cfg = json.loads(out.stdout)
    assert cfg["engine"] == "django.db.backends.postgresql" and cfg["name"] == "study"
    assert cfg["broker"] == "redis://r:6379/0" and cfg["debug"] is False
    assert cfg["hosts"] == ["a.example", "b.example"]


def test_secret_key_required_without_debug(tmp_path):
    out = probe(tmp_path, DEBUG="0")
    assert out.returncode != 0 and "SECRET_KEY must be set" in out.stderr


def test_debug_is_off_unless_asked_for(tmp_path):
    """gunicorn started without serve.sh's environment (systemd, by hand) must not run with DEBUG on
    and the public key: no DEBUG means off, which needs a real key."""
    out = probe(tmp_path)
    assert out.returncode != 0 and "SECRET_KEY must be set when DEBUG is off" in out.stderr
    assert "DEBUG=1" in out.stderr  # says how to run locally
    out = probe(tmp_path, SECRET_KEY="k" * 50)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["debug"] is False


def test_the_public_dev_key_is_refused_without_debug(tmp_path):
    out = probe(tmp_path, DEBUG="0", SECRET_KEY=settings._DEV_KEY)
    assert out.returncode != 0 and "not the public dev key" in out.stderr


def test_on_off_values_are_strict(tmp_path):
    for typo in ("flase", "2", "enabled"):
        out = probe(tmp_path, DEBUG=typo)
        assert out.returncode != 0 and f"DEBUG='{typo}' is not an on/off value" in out.stderr
    out = probe(tmp_path, DEBUG="Yes", CELERY_TASK_ALWAYS_EAGER=" off ")
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["debug"] is True


def test_filesystem_broker_needs_no_server(tmp_path):
    code = PROBE.split("print(")[0] + "r = app.send_task('studyapp.nothing', args=[1]); print(r.id)"
    env = {k: v for k, v in os.environ.items() if k not in ("CELERY_BROKER_URL",)}
    env.update(DJANGO_SETTINGS_MODULE="config.settings", VAR_DIR=str(tmp_path / "var"))
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    queued = list((tmp_path / "var" / "broker" / "out").iterdir())
    assert len(queued) == 1 and out.stdout.strip() in queued[0].read_text()
