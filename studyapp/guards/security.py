"""Request hardening: rate limits, request-size caps, and the answer endpoint's CSRF check.

* ``rate_limit(setting, by)`` — a view decorator counting requests per client address or per
  participant token in Django's cache (fixed windows); over the limit: 429 + Retry-After.
* ``RequestLimitsMiddleware`` — refuses an oversized body by its Content-Length (413) before
  anything reads it, and turns Django's own form-parsing limits into a clean 413/400.
* ``framed_csrf_protect`` — Django's CSRF check, plus the one case it cannot handle: a page of
  ours inside Mechanical Turk's cross-site iframe posts without the CSRF cookie.

Policy and defaults: docs/decisions.md ("Security"); settings: config/settings.py ("security").
"""
from __future__ import annotations

import hashlib
import ipaddress
import logging
import math
import time
from functools import wraps
from urllib.parse import urlsplit

from django.conf import settings
from django.core.cache import caches
from django.core.exceptions import BadRequest, DisallowedHost, RequestDataTooBig, TooManyFieldsSent, TooManyFilesSent
from django.http import HttpResponse, JsonResponse
from django.http.multipartparser import MultiPartParserError
from django.middleware.csrf import CsrfViewMiddleware
from django.template.loader import render_to_string
from django.utils import translation
from django.utils.translation import gettext, gettext_noop

from ..language import participant_language

logger = logging.getLogger("studyapp.guards.security")

_generation = 0          # part of every counter's key: reset_rate_limits() starts afresh
_last_outage_log = 0.0   # a cache outage is logged at most once a minute, not per request
OUTAGE_LOG_EVERY = 60
_cache_down_until = 0.0  # circuit breaker: after a cache error, no request waits on the cache for a while
CACHE_RETRY_AFTER = 15.0  # seconds; then one request tries the cache again
BODY_ERRORS = (RequestDataTooBig, TooManyFieldsSent, TooManyFilesSent, MultiPartParserError, BadRequest)


def wants_json(request) -> bool:
    return "application/json" in request.headers.get("Accept", "")


def refuse(request, status: int, message: str, retry_after: int | None = None) -> HttpResponse:
    """A short refusal: JSON for the participant pages' script, else the participant error page.

    Rendered without the request (no context processors): a refusal must stay cheap under a
    flood and must not touch the session or the database.
    """
    if wants_json(request):
        response = JsonResponse({"ok": False, "error": message}, status=status)
    else:
        response = HttpResponse(render_to_string("studyapp/error.html", {"message": message}), status=status)
    if retry_after is not None:
        response["Retry-After"] = str(retry_after)
    response["Cache-Control"] = "no-store"
    return response


def refuse_before_view(request, status: int, message: str, **values) -> HttpResponse:
    """:func:`refuse` for what the middleware refuses before any view runs: `message` (an English msgid
    marked with gettext_noop, ``{name}`` placeholders filled from `values`) in the language of the study
    whose participant page was asked for (studyapp.language.participant_language), else the site's."""
    language = participant_language(request)
    with translation.override(language or translation.get_language()):
        return refuse(request, status, gettext(message).format(**values))


# --- client address -------------------------------------------------------------------------
def client_address(request) -> str:
    """The client's address as given: REMOTE_ADDR, or X-Forwarded-For behind trusted proxies.

    With TRUSTED_PROXY_COUNT = n, each of our n proxies appended the address it saw, so the
    client is the n-th entry from the right; entries further left are the client's own claims.
    Also what login throttling (django-axes, AXES_CLIENT_IP_CALLABLE) counts by.
    """
    addr = request.META.get("REMOTE_ADDR", "")
    hops = settings.TRUSTED_PROXY_COUNT
    if hops > 0:
        chain = [a.strip() for a in request.META.get("HTTP_X_FORWARDED_FOR", "").split(",") if a.strip()]
        if chain:
            addr = chain[-hops] if len(chain) >= hops else chain[0]
    return addr


def client_ip(request) -> str:
    """The address rate limits count by (client_address); IPv6 clients are counted per /64, the
    block one subscriber usually holds."""
    addr = client_address(request)
    try:
        ip = ipaddress.ip_address(addr)
    except ValueError:
        return addr[:64] or "unknown"
    if ip.version == 6 and ip.ipv4_mapped is None:
        return f"{ipaddress.ip_network(f'{ip}/64', strict=False).network_address}/64"
    return str(getattr(ip, "ipv4_mapped", None) or ip)


# --- rate limits ----------------------------------------------------------------------------
def reset_rate_limits() -> None:
    """Start every counter afresh (tests). Old counters are left to expire, never flushed: the
    cache may be a Redis database shared with other data.  Closes the circuit breaker too."""
    global _generation, _cache_down_until
    _generation += 1
    _cache_down_until = 0.0


def _cache_outage(exc: Exception) -> None:
    global _last_outage_log, _cache_down_until
    now = time.monotonic()
    # A hung cache (it accepts, never answers) costs each request its socket timeout per call;
    # with the breaker open only one request per process pays it every CACHE_RETRY_AFTER seconds.
    _cache_down_until = now + CACHE_RETRY_AFTER
    if now - _last_outage_log >= OUTAGE_LOG_EVERY:
        _last_outage_log = now
        logger.warning("rate limits not enforced: the cache is unavailable (%s: %s)", type(exc).__name__, exc)


def hit(key: str, limit: int, window: int) -> int:
    """Count one request under `key`; 0 when within the limit, else the seconds until the window
    ends. A cache outage lets the request through (fail open): the study must stay up."""
    if time.monotonic() < _cache_down_until:
        return 0  # the cache failed moments ago: do not wait on it again yet
    now = time.time()
    start = int(now // window) * window
    full_key = f"ratelimit:{_generation}:{key}:{window}:{start}"
    cache = caches[settings.RATE_LIMIT_CACHE]
    try:
        cache.add(full_key, 0, timeout=window + 5)  # atomic create; incr is atomic in Redis and LocMem
        count = cache.incr(full_key)
    except ValueError:  # evicted between add and incr: count this request as the first
        return 0
    except Exception as exc:  # any backend error (connection refused, timeout)
        _cache_outage(exc)
        return 0
    return max(1, math.ceil(start + window - now)) if count > limit else 0


def _token_key(kwargs) -> str:
    # Tokens come from the URL, i.e. from anyone: hash them into a short, safe cache key.
    return hashlib.sha256(f"{kwargs.get('slug')}/{kwargs.get('token')}".encode()).hexdigest()[:32]


def rate_limit(setting: str, by: str):
    """Limit a view by the (count, seconds) rule in `setting`, per client address (by="ip") or
    per participant token in the URL (by="token"). The rule is read per request (tests override)."""
    if by not in ("ip", "token"):
        raise ValueError(f"rate_limit: by must be 'ip' or 'token', not {by!r}")

    def decorate(view):
        @wraps(view)
        def wrapped(request, *args, **kwargs):
            rule = getattr(settings, setting, None)
            if rule:
                who = client_ip(request) if by == "ip" else _token_key(kwargs)
                wait = hit(f"{setting}:{who}", *rule)
                if wait:
                    logger.info("%s exceeded by %s %s on %s", setting, by, who, request.path)
                    return refuse(request, 429, gettext("Too many requests in a short time. Nothing was saved from "
                                                          "this one; please wait {seconds} seconds and try again.")
                                  .format(seconds=wait), retry_after=wait)
            return view(request, *args, **kwargs)
        return wrapped
    return decorate


# --- request size -----------------------------------------------------------------------------
class RequestLimitsMiddleware:
    """First in MIDDLEWARE: refuse a body over MAX_REQUEST_BODY by its declared length, unread."""

    def __init__(self, get_response):
        self.get_response = get_response

    def __call__(self, request):
        declared = request.META.get("CONTENT_LENGTH") or "0"
        try:
            length = int(declared)
        except ValueError:
            length = -1
        if length < 0:
            return refuse_before_view(request, 400, gettext_noop(
                "The request's Content-Length header is not a valid length."))
        if length > settings.MAX_REQUEST_BODY:
            return refuse_before_view(request, 413, gettext_noop(
                "The request is too large: at most {limit} bytes are accepted."), limit=settings.MAX_REQUEST_BODY)
        return self.get_response(request)

    def process_view(self, request, view, args, kwargs):
        # Parse the query and form data here rather than in the CSRF middleware or the view, where
        # Django's limits (too many fields, a chunked body over DATA_UPLOAD_MAX_MEMORY_SIZE) and
        # unparsable bodies end as a generic 400 page (a traceback page under DEBUG).
        try:
            request.GET  # noqa: B018  (the access parses the query)
            if request.method == "POST":
                incomplete = _incomplete_body(request)
                if incomplete:
                    got, declared = incomplete
                    return refuse_before_view(request, 400, gettext_noop(
                        "The request arrived incomplete ({got} of {declared} bytes), so nothing was saved. "
                        "Please answer again."), got=got, declared=declared)
                request.POST  # noqa: B018  (the access parses the body)
        except OSError:  # the client went away mid-body: whatever arrived is not an answer
            return refuse_before_view(request, 400, gettext_noop(
                "The request arrived incomplete, so nothing was saved. Please answer again."))
        except BODY_ERRORS as exc:
            return self.process_exception(request, exc)
        if _has_nul(request):
            return refuse_before_view(request, 400, gettext_noop(
                "The request contains a NUL character, which no field accepts."))
        return None

    def process_exception(self, request, exception):
        if not isinstance(exception, BODY_ERRORS):
            return None
        if isinstance(exception, RequestDataTooBig):
            return refuse_before_view(request, 413, gettext_noop(
                "The request is too large: at most {limit} bytes of form data are accepted."),
                limit=settings.DATA_UPLOAD_MAX_MEMORY_SIZE)
        if isinstance(exception, (TooManyFieldsSent, TooManyFilesSent)):
            return refuse_before_view(request, 400, gettext_noop(
                "The request has too many fields: at most {limit} are accepted."),
                limit=settings.DATA_UPLOAD_MAX_NUMBER_FIELDS)
        return refuse_before_view(request, 400, gettext_noop("The request's form data could not be read."))


def _incomplete_body(request) -> tuple[int, int] | None:
    """(bytes received, bytes declared) when the body is shorter than its Content-Length, else None.

    A client that closes its side mid-body hands the server an end of file, and the WSGI stream
    returns the bytes that came: parsed as a form, a truncated answer (`goals=merge` of
    `goals=merge&goals=forward`) looks like a complete one.  Reading the body first (it is at
    most MAX_REQUEST_BODY) lets its length be checked before anything is parsed or stored."""
    declared = int(request.META.get("CONTENT_LENGTH") or 0)
    if declared <= 0:
        return None
    got = len(request.body)
    return (got, declared) if got < declared else None


def _has_nul(request) -> bool:
    # PostgreSQL refuses NUL in text and JSON: a token, platform id or typed answer containing one
    # would fail in the database (a 500) instead of being refused as bad input.
    if "\x00" in request.path:
        return True
    parsed = [request.GET] + ([request.POST] if request.method == "POST" else [])
    return any("\x00" in key or any("\x00" in v for v in values)
               for data in parsed for key, values in data.lists())


# --- CSRF -------------------------------------------------------------------------------------
def _origin_of(request) -> str | None:
    """The Origin header, or without it the origin of the Referer; None when neither is sent."""
    origin = request.headers.get("Origin")
    if origin is None:
        referer = request.headers.get("Referer")
        if not referer:
            return None
        parts = urlsplit(referer)
        origin = f"{parts.scheme}://{parts.netloc}"
    return origin.strip().lower()


def same_origin(request) -> bool:
    """Did the browser say the request comes from a page of this site (or a trusted origin)?"""
    origin = _origin_of(request)
    if not origin or origin == "null":
        return False
    try:
        own = f"{request.scheme}://{request.get_host()}".lower()
    except DisallowedHost:
        return False
    return origin == own or origin in {o.lower() for o in settings.CSRF_TRUSTED_ORIGINS}


def _no_response(request):  # CsrfViewMiddleware needs a get_response; process_view never calls it
    return None


def framed_csrf_protect(view):
    """CSRF protection for a participant form that may be posted from inside MTurk's iframe.

    With the CSRF cookie: Django's full check (cookie + form token + Origin). Without it, which
    is what a SameSite=Lax cookie becomes inside a cross-site iframe, the browser's Origin (or
    Referer) must be this site itself: the page that posts is then ours, not a forger's. The view
    using this must also be csrf_exempt, so that the global middleware leaves the check to it.
    """
    check = CsrfViewMiddleware(_no_response)

    @wraps(view)
    def wrapped(request, *args, **kwargs):
        if request.method in ("GET", "HEAD", "OPTIONS", "TRACE"):
            return view(request, *args, **kwargs)
        if settings.CSRF_COOKIE_NAME in request.COOKIES:
            if check.process_view(request, None, (), {}) is not None:  # Django logged the reason
                return refuse(request, 403, gettext("This form has expired or was sent from another site, so "
                                                      "nothing was saved. Please reload the page and answer again."))
        elif not (getattr(request, "_dont_enforce_csrf_checks", False) or same_origin(request)):
            logger.warning("Forbidden (cookie-less post, origin %r): %s", _origin_of(request), request.path)
            return refuse(request, 403, gettext("This answer did not come from the study's own page (no CSRF cookie, "
                                                  "and the browser named no page of this site as its origin), so "
                                                  "nothing was saved. Please open the study from its link and "
                                                  "answer there."))
        return view(request, *args, **kwargs)
    return wrapped
