"""A database outage answers 503 + Retry-After, never a traceback or a bare 500; researcher
pages are never cached (``ResearcherNoStoreMiddleware``, at the end).

When PostgreSQL restarts or is briefly unreachable, every request that touches
it raises django.db.OperationalError (or InterfaceError on a connection that
died under it).  A participant in the middle of the study must be told to wait
and retry, and the participant page's save-retry loop (and any well-behaved
client) keys on 503 + Retry-After; a 500 would read as "your answer was
rejected".  Nothing is lost by answering 503: the answer transaction either
committed (a retry is then an idempotent repeat, studyapp.participant.flow.record) or it
did not (the retry writes it).

Two hooks, because Django converts an exception into a response at every
middleware layer:

* ``DatabaseUnavailableMiddleware.process_exception`` catches it in a view
  (where nearly all database work happens), in DEBUG too;
* ``server_error`` (config.urls.handler500) catches it anywhere else, e.g. the
  session middleware saving a session after the view, with DEBUG off.

The response is built without templates or context processors, which could
touch the database (the session, request.user) and fail again.
"""
from __future__ import annotations

import logging
import sys

from django.conf import settings
from django.db import InterfaceError, OperationalError
from django.http import HttpResponse, JsonResponse
from django.utils.cache import add_never_cache_headers
from django.views import defaults

from studyapp.guards.security import wants_json

logger = logging.getLogger("studyapp.availability")

DB_ERRORS = (OperationalError, InterfaceError)
MESSAGE = ("The study's database is briefly unavailable. Nothing you have already saved is lost; "
           "please wait a moment and try again.")
HTML = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width, initial-scale=1">
<title>Please try again in a moment</title></head>
<body style="font-family: system-ui, sans-serif; max-width: 36rem; margin: 3rem auto; padding: 0 1rem">
<h1>Please try again in a moment</h1>
<p>{message}</p>
<p>This page can be reloaded in {retry_after} seconds.</p>
</body></html>
"""


def retry_after() -> int:
    # A PostgreSQL restart takes a few seconds; clients back off further on repeated 503s.
    return int(getattr(settings, "DB_OUTAGE_RETRY_AFTER", 3))


def unavailable_response(request, exc: BaseException) -> HttpResponse:
    logger.warning("database unavailable for %s %s: %s: %s", request.method, request.path,
                   type(exc).__name__, str(exc).strip().splitlines()[0] if str(exc).strip() else "")
    seconds = retry_after()
    if wants_json(request):
        response = JsonResponse({"ok": False, "error": MESSAGE, "retry_after": seconds}, status=503)
    else:
        response = HttpResponse(HTML.format(message=MESSAGE, retry_after=seconds), status=503,
                                content_type="text/html; charset=utf-8")
    response["Retry-After"] = str(seconds)
    # Never cache an outage page: a proxy or the browser would keep showing it after recovery.
    response["Cache-Control"] = "no-store"
    return response


class DatabaseUnavailableMiddleware:
    def __init__(self, get_response):
        self.get_response = get_response

    def __call__(self, request):
        return self.get_response(request)

    def process_exception(self, request, exception):
        if isinstance(exception, DB_ERRORS):
            return unavailable_response(request, exception)
        return None


def server_error(request, *args, **kwargs):
    """handler500: Django calls it inside its ``except`` block, so the exception is still current."""
    exc = sys.exc_info()[1]
    if isinstance(exc, DB_ERRORS):
        return unavailable_response(request, exc)
    return defaults.server_error(request, *args, **kwargs)


# The participant pages (studyapp.participant.views) set their own caching headers; every other view is a
# researcher's (dashboard, exports, analysis, designer and jobs, login, logout, the admin).
PARTICIPANT_URL_NAMES = frozenset({"home", "entry", "step", "answer", "participant_media"})


class ResearcherNoStoreMiddleware:
    """``Cache-Control: no-store`` (Django's never-cache set) on every researcher response.

    Keyed on the URL, not on each view, so that a researcher view added later cannot forget it:
    a browser's disk cache or a shared proxy must never keep a page or CSV export of participant
    data, and the browser's back button after logging out must not show it again.  Anything
    that did not resolve to a participant page counts (404s included); static files are served
    by WhiteNoise before this runs.
    """

    def __init__(self, get_response):
        self.get_response = get_response

    def __call__(self, request):
        response = self.get_response(request)
        match = getattr(request, "resolver_match", None)
        if match is None or match.view_name not in PARTICIPANT_URL_NAMES:
            add_never_cache_headers(response)
        return response
