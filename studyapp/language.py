"""The language a participant's page is in: their study's (Study.language), whatever their browser asks for.

Participant views run inside :func:`in_study_language`, which activates the study's language for the
request (researchers' pages stay in settings.LANGUAGE_CODE).  Every participant-facing string goes through
Django's catalogs: templates by ``{% translate %}``, Python by ``gettext``, JavaScript by the study's
JavaScript catalog (:func:`javascript_catalog`), and a robot's own texts by studyapp.i18n.
"""
from __future__ import annotations

from functools import wraps

from django.conf import settings
from django.urls import Resolver404, resolve
from django.utils import translation
from django.views.i18n import JavaScriptCatalog

from .models import Study


def study_language(slug: str) -> str:
    """The language of the study `slug` (the site's default for an unknown slug: its 404 page)."""
    found = Study.objects.filter(slug=slug).values_list("language", flat=True).first()
    return found or settings.LANGUAGE_CODE


# The URL names of the participant pages (studyapp/urls.py): what is refused before their view runs is
# refused in their study's language.
PARTICIPANT_URLS = frozenset({"entry", "step", "answer", "jsi18n"})


def participant_language(request) -> str | None:
    """The study's language when `request` asks for one of its participant pages, from the URL alone;
    None for any other page.  For refusals sent before a view runs (a body too large, incomplete or with
    a NUL): one indexed query by slug, only when refusing."""
    try:
        match = resolve(request.path_info)
    except Resolver404:
        return None
    return study_language(match.kwargs["slug"]) if match.url_name in PARTICIPANT_URLS else None


def in_study_language(view):
    """Run a participant view (its URL names the study's ``slug``) in the study's language; the response
    says which (Content-Language)."""
    @wraps(view)
    def wrapped(request, *args, **kwargs):
        language = study_language(kwargs["slug"])
        with translation.override(language):
            request.LANGUAGE_CODE = language
            response = view(request, *args, **kwargs)
        response.headers.setdefault("Content-Language", language)
        return response

    return wrapped


# The study's JavaScript catalog (gettext() and interpolate() for the participant pages' scripts), in its
# language: a script from this site, so the participant pages' CSP (script-src 'self') allows it.
javascript_catalog = in_study_language(JavaScriptCatalog.as_view(domain="djangojs"))
