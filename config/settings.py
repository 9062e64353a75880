"""Settings, all from the environment with embedded defaults (DESIGN §9).

Environment variables:

* ``SECRET_KEY``        — required when DEBUG is off (and never the public dev key); a fixed dev
                          key otherwise.
* ``DEBUG``             — "1"/"true" to enable; default **off**, so a server started without the
                          project's scripts (systemd, a bare gunicorn) is never in debug mode.
                          `make demo` and the test suite turn it on for local use.
* Every on/off variable takes 1/0, true/false, yes/no or on/off; anything else stops the start.
* ``ALLOWED_HOSTS``     — comma separated (default "localhost,127.0.0.1,[::1],testserver").
* ``DATABASE_URL``      — any dj-database-url URL; default SQLite at var/db.sqlite3.
* ``CELERY_BROKER_URL`` — default kombu's "filesystem://" transport under var/broker
                          (no server needed); e.g. redis://127.0.0.1:6379/0 in production.
* ``CELERY_RESULT_BACKEND`` — default "django-db" (django_celery_results).
* ``CSRF_TRUSTED_ORIGINS`` — comma separated, for deployments behind a proxy.
* ``DATABASE_TEST_NAME`` — name of the database the test runner creates (default test_<name>).
* ``CONN_MAX_AGE``      — seconds to keep database connections open (default 0: per request).
"""
import os
import tempfile
from datetime import timedelta
from pathlib import Path

import dj_database_url
from django.core.exceptions import ImproperlyConfigured

BASE_DIR = Path(__file__).resolve().parent.parent
VAR_DIR = Path(os.environ.get("VAR_DIR", BASE_DIR / "var"))


_TRUE, _FALSE = ("1", "true", "yes", "on"), ("0", "false", "no", "off", "")


def _flag(name, default):
    """An on/off variable; a value that is neither (a typo like DEBUG=flase) is refused, not read as off."""
    value = os.environ.get(name, default).strip().lower()
    if value not in _TRUE + _FALSE:
        raise ImproperlyConfigured(f"{name}={os.environ.get(name)!r} is not an on/off value: "
                                   "use 1/0, true/false, yes/no or on/off")
    return value in _TRUE


def _list(name, default):
    return [item.strip() for item in os.environ.get(name, default).split(",") if item.strip()]


DEBUG = _flag("DEBUG", "0")
_DEV_KEY = "dev-only-insecure-key-change-me"  # public (it is in this file): only ever with DEBUG on
SECRET_KEY = os.environ.get("SECRET_KEY", "")
if not DEBUG and SECRET_KEY in ("", _DEV_KEY):
    raise ImproperlyConfigured(
        "SECRET_KEY must be set when DEBUG is off (to 50+ random characters, not the public dev key). "
        "For local use set DEBUG=1 instead, as `make demo` does; scripts/serve.sh makes and keeps a key.")
SECRET_KEY = SECRET_KEY or _DEV_KEY
ALLOWED_HOSTS = _list("ALLOWED_HOSTS", "localhost,127.0.0.1,[::1],testserver")
CSRF_TRUSTED_ORIGINS = _list("CSRF_TRUSTED_ORIGINS", "")

INSTALLED_APPS = [
    "django.contrib.admin",
    "django.contrib.auth",
    "django.contrib.contenttypes",
    "django.contrib.sessions",
    "django.contrib.messages",
    "django.contrib.staticfiles",
    "django_celery_results",
    "axes",  # login throttling (security section)
    "studyapp",
    "precompute",
]

MIDDLEWARE = [
    "studyapp.guards.security.RequestLimitsMiddleware",  # body/field caps -> 413/400 (security section)
    "django.middleware.security.SecurityMiddleware",
    "config.middleware.DatabaseUnavailableMiddleware",  # DB outage -> 503 + Retry-After
    "whitenoise.middleware.WhiteNoiseMiddleware",
    "config.middleware.ResearcherNoStoreMiddleware",  # no-store on every researcher page and export
    "django.contrib.sessions.middleware.SessionMiddleware",
    "django.middleware.common.CommonMiddleware",
    "django.middleware.csrf.CsrfViewMiddleware",
    "django.contrib.auth.middleware.AuthenticationMiddleware",
    "django.contrib.messages.middleware.MessageMiddleware",
    "django.middleware.clickjacking.XFrameOptionsMiddleware",
    "axes.middleware.AxesMiddleware",  # last: turns a locked-out login into its 429 page
]

ROOT_URLCONF = "config.urls"
WSGI_APPLICATION = "config.wsgi.application"

TEMPLATES = [
    {
        "BACKEND": "django.template.backends.django.DjangoTemplates",
        "DIRS": [BASE_DIR / "templates"],
        "APP_DIRS": True,
        "OPTIONS": {
            "context_processors": [
                "django.template.context_processors.request",
                "django.contrib.auth.context_processors.auth",
                "django.contrib.messages.context_processors.messages",
            ],
        },
    },
]

# --- database ---------------------------------------------------------------
_default_sqlite = f"sqlite:///{VAR_DIR / 'db.sqlite3'}"
DATABASES = {"default": dj_database_url.parse(os.environ.get("DATABASE_URL", _default_sqlite),
                                          conn_max_age=int(os.environ.get("CONN_MAX_AGE", "0")))}
if os.environ.get("DATABASE_TEST_NAME"):  # the test runner's database (default test_<name>)
    DATABASES["default"]["TEST"] = {"NAME": os.environ["DATABASE_TEST_NAME"]}
if DATABASES["default"]["ENGINE"] == "django.db.backends.sqlite3":
    _name = str(DATABASES["default"]["NAME"])
    if _name and _name != ":memory:":
        Path(_name).parent.mkdir(parents=True, exist_ok=True)
    # BEGIN IMMEDIATE: every transaction takes SQLite's single write lock up
    # front, so the assignment transaction is serialised (see docs/study.md).
    DATABASES["default"]["CONN_MAX_AGE"] = 0
    DATABASES["default"].setdefault("OPTIONS", {}).update({"transaction_mode": "IMMEDIATE", "timeout": 20})
    # The test runner's database is a file too, not Django's shared-cache in-memory one: there a
    # second thread (an in-process Celery worker, the live server) meets SQLite's table locks,
    # which fail at once ("database table is locked") instead of waiting out the timeout above.
    # A file locks as the embedded default does.  One per process: parallel runs do not collide.
    DATABASES["default"].setdefault("TEST", {}).setdefault(
        "NAME", os.path.join(tempfile.gettempdir(), f"studyapp-test-{os.getpid()}.sqlite3"))
DEFAULT_AUTO_FIELD = "django.db.models.BigAutoField"

# --- celery -----------------------------------------------------------------
_broker_dir = VAR_DIR / "broker"
CELERY_BROKER_URL = os.environ.get("CELERY_BROKER_URL", "filesystem://")
if CELERY_BROKER_URL.startswith("filesystem://"):
    for _sub in ("out", "processed"):
        (_broker_dir / _sub).mkdir(parents=True, exist_ok=True)
    CELERY_BROKER_TRANSPORT_OPTIONS = {
        "data_folder_in": str(_broker_dir / "out"),
        "data_folder_out": str(_broker_dir / "out"),
        "processed_folder": str(_broker_dir / "processed"),
        "store_processed": False,
        # broadcast (control) bindings: under var/broker, not a "control" folder in the cwd
        "control_folder": str(_broker_dir / "control"),
    }
if CELERY_BROKER_URL.startswith(("redis://", "rediss://")):
    # An unacknowledged (acks_late) message goes back to the queue this long after delivery
    # when its worker died: longer than the longest task (docs/scaling.md).  A worker that
    # starts puts back a dead worker's messages at once (precompute/recovery.py).
    # Short socket timeouts and one publish retry: a hung Redis (it accepts, never answers) makes
    # launching a job fail within seconds with a clear message (precompute/jobs.py), not hang.
    # (The worker reads BRPOP replies from its event loop when the socket is readable, so its 1 s
    # BRPOP never meets this timeout.)
    CELERY_BROKER_TRANSPORT_OPTIONS = {
        "visibility_timeout": int(os.environ.get("CELERY_VISIBILITY_TIMEOUT", "3600")),
        "socket_timeout": 2, "socket_connect_timeout": 2}
    CELERY_TASK_PUBLISH_RETRY_POLICY = {"max_retries": 1, "interval_start": 0.2, "interval_step": 0.2,
                                        "interval_max": 0.2}
CELERY_RESULT_BACKEND = os.environ.get("CELERY_RESULT_BACKEND", "django-db")
CELERY_RESULT_EXTENDED = True
CELERY_TASK_TRACK_STARTED = True
CELERY_TASK_ALWAYS_EAGER = _flag("CELERY_TASK_ALWAYS_EAGER", "0")
# A worker reserves one message per process at a time: precompute chunks run for seconds to
# minutes, so prefetching would starve other machines (precompute tasks are also acks_late
# with reject_on_worker_lost, set on their base class; docs/scaling.md).
CELERY_WORKER_PREFETCH_MULTIPLIER = 1
PRECOMPUTE_QUEUE = os.environ.get("PRECOMPUTE_QUEUE", "celery")
# Each worker's job watchdog (precompute/watchdog.py): a job with no task started and no unit
# finished for QUIET seconds, none held by a worker while one of its queue is idle, lost its
# messages (a broker restarted empty): relaunched, or failed with an alarm.  Checked every EVERY
# seconds (0: no watchdog), so a lost job is noticed within QUIET + EVERY seconds.
PRECOMPUTE_WATCHDOG_QUIET = float(os.environ.get("PRECOMPUTE_WATCHDOG_QUIET", "60"))
PRECOMPUTE_WATCHDOG_EVERY = float(os.environ.get("PRECOMPUTE_WATCHDOG_EVERY", "15"))
# Where the study designer looks for built tables (each a directory with meta.json).
TABLES_DIR = Path(os.environ.get("TABLES_DIR", VAR_DIR / "tables"))
# The teaching benchmark's results folder: `manage.py benchmark` writes there by default, and a study's dashboard
# shows the leaderboard of its table from there (docs/benchmark.md).
BENCHMARK_DIR = Path(os.environ.get("BENCHMARK_DIR", VAR_DIR / "benchmark"))

# --- auth, i18n, static -------------------------------------------------------
# Researcher passwords (manage.py create_researcher): accounts that can export every answer.
AUTH_PASSWORD_VALIDATORS = [
    {"NAME": "django.contrib.auth.password_validation.UserAttributeSimilarityValidator"},
    {"NAME": "django.contrib.auth.password_validation.MinimumLengthValidator", "OPTIONS": {"min_length": 10}},
    {"NAME": "django.contrib.auth.password_validation.CommonPasswordValidator"},
    {"NAME": "django.contrib.auth.password_validation.NumericPasswordValidator"},
]
# Login throttling (django-axes; policy and page: studyapp/guards/lockout.py): a user name is locked after
# LOGIN_FAILURE_LIMIT wrong passwords from any address (staff accounts guard every export); an
# address only after LOGIN_ADDRESS_FAILURE_LIMIT across all names, so one researcher's typos never
# lock out the others behind the same address.  Each lock lasts LOGIN_COOLOFF_MINUTES from the
# failure that set it (attempts while locked do not extend it) and its 429 page says what is
# locked and for how long; `manage.py axes_reset` lifts it.  The address is the one rate limits
# count by.
AUTHENTICATION_BACKENDS = ["axes.backends.AxesStandaloneBackend", "django.contrib.auth.backends.ModelBackend"]
AXES_FAILURE_LIMIT = int(os.environ.get("LOGIN_FAILURE_LIMIT", "5"))
LOGIN_ADDRESS_FAILURE_LIMIT = int(os.environ.get("LOGIN_ADDRESS_FAILURE_LIMIT", "50"))
AXES_COOLOFF_TIME = timedelta(minutes=int(os.environ.get("LOGIN_COOLOFF_MINUTES", "15")))
AXES_LOCKOUT_PARAMETERS = "studyapp.guards.lockout.lockout_parameters"
AXES_LOCKOUT_CALLABLE = "studyapp.guards.lockout.lockout_response"
AXES_RESET_COOL_OFF_ON_FAILURE_DURING_LOCKOUT = False
AXES_CLIENT_IP_CALLABLE = "studyapp.guards.security.client_address"
AXES_RESET_ON_SUCCESS = True
AXES_VERBOSE = False
LOGIN_URL = "login"
LOGIN_REDIRECT_URL = "dashboard"
LOGOUT_REDIRECT_URL = "login"

LANGUAGE_CODE = "en-us"
# The languages a study may speak to its participants (Study.language; studyapp/i18n.py).  Researchers'
# pages stay in LANGUAGE_CODE.  Catalogs: locale/<lang>/LC_MESSAGES, compiled by `make venv`.
LANGUAGES = [("en", "English"), ("de", "Deutsch")]
LOCALE_PATHS = [BASE_DIR / "locale"]
TIME_ZONE = "UTC"
USE_I18N = True
USE_TZ = True

STATIC_URL = "static/"
STATICFILES_DIRS = [BASE_DIR / "static"]
STATIC_ROOT = VAR_DIR / "staticfiles"  # `manage.py collectstatic` for production
STATIC_ROOT.mkdir(parents=True, exist_ok=True)
WHITENOISE_USE_FINDERS = True  # serve static/ directly too, so the demo needs no collectstatic

SESSION_COOKIE_AGE = 60 * 60 * 24 * 14
SESSION_COOKIE_HTTPONLY = True
SECURE_CONTENT_TYPE_NOSNIFF = True
if not DEBUG:
    SESSION_COOKIE_SECURE = _flag("SECURE_COOKIES", "1")
    CSRF_COOKIE_SECURE = _flag("SECURE_COOKIES", "1")

# Everything goes to stderr (gunicorn, the worker and supervisord collect it), one line per event
# with time, level and logger.  Our own loggers (studyapp: assignments, completions, rate limits,
# outages; precompute: job events) at LOG_LEVEL; Django's and everything else at WARNING.  No
# personal data is logged: participants appear by row id, never by platform id.
_LOG_LEVEL = os.environ.get("LOG_LEVEL", "INFO").upper()
LOGGING = {
    "version": 1,
    "disable_existing_loggers": False,
    "formatters": {"line": {"format": "%(asctime)s %(levelname)s %(name)s: %(message)s"}},
    "handlers": {"console": {"class": "logging.StreamHandler", "formatter": "line"}},
    # one handler, on the root: the named loggers below only set levels and propagate to it
    "root": {"handlers": ["console"], "level": "WARNING"},
    "loggers": {"django": {"level": "WARNING"}, "studyapp": {"level": _LOG_LEVEL},
                "precompute": {"level": _LOG_LEVEL}},
}

# --- production -----------------------------------------------------------------
# Deploy settings, read when DEBUG is off.  With DEBUG=0, a SECRET_KEY of 50+ random characters
# and ALLOWED_HOSTS, `manage.py check --deploy` is clean (tests/studyapp/test_production.py).
# The defaults assume HTTPS in front, at a TLS-terminating proxy (docs/operations.md);
# scripts/serve.sh turns the HTTPS-only ones off when it serves plain HTTP on this machine.
#
# * SECURE_SSL_REDIRECT            — "1" (default): http:// is redirected to https://
# * SECURE_HSTS_SECONDS            — default 31536000 (a year); "0" sends no HSTS header
# * SECURE_HSTS_INCLUDE_SUBDOMAINS — default "1"
# * SECURE_HSTS_PRELOAD            — default "1" (only makes the host eligible; nothing is submitted)
# * SECURE_COOKIES                 — "1" (default, above): session and CSRF cookies over HTTPS only
# * BEHIND_PROXY                   — "1": trust the proxy's X-Forwarded-Proto: https (the proxy must
#                                    overwrite any such header the client sent)
# * CONN_MAX_AGE                   — (above) 60 in production: connections are health-checked before
#                                    reuse, so one broken by a database restart is replaced, not reused
# * DB_OUTAGE_RETRY_AFTER          — Retry-After seconds of the 503 sent during a database outage (3)
if not DEBUG:
    SECURE_SSL_REDIRECT = _flag("SECURE_SSL_REDIRECT", "1")
    SECURE_HSTS_SECONDS = int(os.environ.get("SECURE_HSTS_SECONDS", str(365 * 24 * 3600)))
    SECURE_HSTS_INCLUDE_SUBDOMAINS = _flag("SECURE_HSTS_INCLUDE_SUBDOMAINS", "1")
    SECURE_HSTS_PRELOAD = _flag("SECURE_HSTS_PRELOAD", "1")
    # collectstatic (scripts/serve.sh) writes gzip copies that WhiteNoise serves; the finders
    # would shadow them with the uncompressed sources.
    STORAGES = {"default": {"BACKEND": "django.core.files.storage.FileSystemStorage"},
                "staticfiles": {"BACKEND": "whitenoise.storage.CompressedStaticFilesStorage"}}
    WHITENOISE_USE_FINDERS = _flag("WHITENOISE_USE_FINDERS", "0")
if _flag("BEHIND_PROXY", "0"):
    SECURE_PROXY_SSL_HEADER = ("HTTP_X_FORWARDED_PROTO", "https")
DATABASES["default"]["CONN_HEALTH_CHECKS"] = True
DB_OUTAGE_RETRY_AFTER = int(os.environ.get("DB_OUTAGE_RETRY_AFTER", "3"))

# --- security -------------------------------------------------------------------
# Rate limits, request-size caps and the cache they count in (studyapp/guards/security.py;
# policy in docs/decisions.md, "Security").
#
# * CACHE_URL            — "redis://127.0.0.1:6379/1" for Redis; default: this process's memory.
#                          Several server processes (gunicorn workers, machines) must share the Redis
#                          cache, or each counts on its own and the limits multiply by their number.
# * RATE_LIMIT_ENTRY     — "30/60": requests per seconds to a study's entry link, per client address
# * RATE_LIMIT_ANSWER    — "60/60": answer posts per participant token
# * RATE_LIMIT_ANSWER_IP — "600/60": answer posts per client address (a lab behind one NAT)
#                          "off" disables one limit.
# * TRUSTED_PROXY_COUNT  — "0": the client address is REMOTE_ADDR; n > 0: the n-th address from the
#                          right of X-Forwarded-For (set it to the number of proxies you run in front)
# * MAX_REQUEST_BODY     — 65536 bytes: a larger Content-Length is refused with 413 before reading
# * MAX_REQUEST_FIELDS   — 500 form/query fields at most (400 beyond)


def _cache(url):
    if url.startswith(("redis://", "rediss://", "unix://")):
        # Short timeouts: an unreachable Redis must fail fast, and the rate limiter then lets
        # requests through (fail open) instead of holding participants.
        return {"BACKEND": "django.core.cache.backends.redis.RedisCache", "LOCATION": url,
                "OPTIONS": {"socket_connect_timeout": 0.5, "socket_timeout": 0.5}}
    if url in ("", "locmem://"):
        return {"BACKEND": "django.core.cache.backends.locmem.LocMemCache", "LOCATION": "studyapp"}
    raise RuntimeError(f"CACHE_URL must be redis://..., rediss://... or locmem://, not {url!r}")


def _rate(name, default):
    """'N/SECONDS' -> (N, SECONDS); 'off' -> None."""
    spec = os.environ.get(name, default).strip().lower()
    if spec in ("off", "0", ""):
        return None
    count, _, seconds = spec.partition("/")
    try:
        rule = (int(count), int(seconds or "60"))
    except ValueError:
        raise RuntimeError(f"{name} must look like 30/60 (requests/seconds) or off, not {spec!r}") from None
    if min(rule) < 1:
        raise RuntimeError(f"{name}: requests and seconds must be positive, got {spec!r}")
    return rule


CACHES = {"default": _cache(os.environ.get("CACHE_URL", "").strip())}
RATE_LIMIT_CACHE = "default"
RATE_LIMIT_ENTRY = _rate("RATE_LIMIT_ENTRY", "30/60")
RATE_LIMIT_ANSWER = _rate("RATE_LIMIT_ANSWER", "60/60")
RATE_LIMIT_ANSWER_IP = _rate("RATE_LIMIT_ANSWER_IP", "600/60")
TRUSTED_PROXY_COUNT = int(os.environ.get("TRUSTED_PROXY_COUNT", "0"))
MAX_REQUEST_BODY = int(os.environ.get("MAX_REQUEST_BODY", str(64 * 1024)))
# Django's own caps on parsed form data: at most the body cap, so a body that arrives without a
# Content-Length (chunked) is still bounded; both end as a clean 413/400 (RequestLimitsMiddleware).
DATA_UPLOAD_MAX_MEMORY_SIZE = MAX_REQUEST_BODY
DATA_UPLOAD_MAX_NUMBER_FIELDS = int(os.environ.get("MAX_REQUEST_FIELDS", "500"))
