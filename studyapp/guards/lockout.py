"""Login lockout policy and its page (django-axes; settings "Login throttling").

Policy: a **user name** is locked after LOGIN_FAILURE_LIMIT (5) wrong passwords, from any address;
an **address** only after LOGIN_ADDRESS_FAILURE_LIMIT (50) wrong passwords across all names, which
no researcher mistyping reaches but a guesser trying many names does.  Each lock lasts
LOGIN_COOLOFF_MINUTES (15) from the failure that set it; attempts while locked are refused
without extending it (AXES_RESET_COOL_OFF_ON_FAILURE_DURING_LOCKOUT = False), so the minutes the
page gives are true.  Before, the address was locked after 5 failures like a name, which also
refused the right password of every other researcher behind that address, and /admin/, with a
bare "locked out" and no time.

The page (429) says what is locked (this name, this address or both), for how many more
minutes, that the admin's login is the same lock, and how to lift it sooner.
"""
from __future__ import annotations

import math

from axes.helpers import get_client_username, get_cool_off
from axes.models import AccessAttempt
from django.conf import settings
from django.db.models import Max, Sum
from django.http import HttpRequest, HttpResponse, JsonResponse
from django.template.loader import render_to_string
from django.utils import timezone

from .security import client_address


def _failures(**match) -> tuple[int, object]:
    """(wrong passwords, the latest one's time) within the cool-off, for rows matching `match`."""
    since = timezone.now() - settings.AXES_COOLOFF_TIME
    agg = AccessAttempt.objects.filter(attempt_time__gte=since, **match).aggregate(
        n=Sum("failures_since_start"), last=Max("attempt_time"))
    return agg["n"] or 0, agg["last"]


def lockout_parameters(request_or_attempt, credentials=None):
    """AXES_LOCKOUT_PARAMETERS: always the user name; the address too once it reached its own,
    larger limit (then its count, well over AXES_FAILURE_LIMIT, locks it).  Lists of lists, so
    axes records every failure even without a user name."""
    if isinstance(request_or_attempt, HttpRequest):
        if _failures(ip_address=client_address(request_or_attempt))[0] >= settings.LOGIN_ADDRESS_FAILURE_LIMIT:
            return [["username"], ["ip_address"]]
    return [["username"]]


def _minutes_left(last) -> int:
    if last is None:
        return 0
    left = (last + (get_cool_off() or settings.AXES_COOLOFF_TIME) - timezone.now()).total_seconds()
    return max(1, math.ceil(left / 60))


def lockout_response(request, original_response=None, credentials=None):
    """AXES_LOCKOUT_CALLABLE: 429, saying what is locked and for how long."""
    username = get_client_username(request, credentials) or ""
    address = client_address(request)
    name_n, name_last = _failures(username=username) if username else (0, None)
    addr_n, addr_last = _failures(ip_address=address)
    context = {
        "username": username,
        "address": address,
        "name_locked": bool(username) and name_n >= settings.AXES_FAILURE_LIMIT,
        "address_locked": addr_n >= settings.LOGIN_ADDRESS_FAILURE_LIMIT,
        "name_limit": settings.AXES_FAILURE_LIMIT,
        "address_limit": settings.LOGIN_ADDRESS_FAILURE_LIMIT,
    }
    context["name_minutes"] = _minutes_left(name_last) if context["name_locked"] else 0
    context["address_minutes"] = _minutes_left(addr_last) if context["address_locked"] else 0
    minutes = max(context["name_minutes"], context["address_minutes"], 1)
    if "application/json" in request.headers.get("Accept", ""):
        response = JsonResponse({"ok": False, "locked": [k for k in ("name", "address") if context[f"{k}_locked"]],
                                 "minutes": minutes}, status=429)
    else:
        response = HttpResponse(render_to_string("registration/locked_out.html", context, request=request),
                                status=429)
    response["Retry-After"] = str(minutes * 60)
    return response
