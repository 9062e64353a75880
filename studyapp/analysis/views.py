"""The live analysis report on the researcher dashboard.

``render_report(study)`` returns the report as an HTML fragment, cached under a fingerprint of
the study's responses (:func:`data.fingerprint`), so it is recomputed exactly when a new answer,
participant or exclusion arrives and served from the cache otherwise.

URL (add to ``studyapp/urls.py``)::

    from .analysis import views as analysis_views
    path("dashboard/<slug:slug>/analysis/", analysis_views.report, name="dashboard_analysis"),

``GET .../analysis/`` is the full page; ``?fragment=1`` returns only the fragment, with an ETag
(the fingerprint): the page polls it every ``REFRESH_SECONDS`` with ``If-None-Match`` and swaps the
fragment in when the server answers 200 instead of 304.  ``?compare=a:b`` (repeatable) adds
researcher-named Welch comparisons; ``?incomplete=1`` also analyses unfinished participants.
"""
from __future__ import annotations

import hashlib
import logging

from django.core.cache import cache
from django.http import HttpResponse
from django.shortcuts import get_object_or_404, render
from django.utils.cache import get_conditional_response

from ..access import researcher_required
from ..models import Study
from . import data as D
from . import report as R

logger = logging.getLogger("studyapp.analysis")
REFRESH_SECONDS = 20
CACHE_SECONDS = 60 * 60 * 24


def parse_comparisons(values) -> list[tuple[str, str]]:
    out = []
    for v in values:
        a, sep, b = str(v).partition(":")
        if sep and a.strip() and b.strip():
            out.append((a.strip(), b.strip()))
    return out


def _key(study, fp, extra, incomplete):
    tag = ";".join(f"{a}:{b}" for a, b in extra)
    return f"studyapp.analysis.report:{fp}:{tag}:{int(incomplete)}"


def render_report(study: Study, extra_comparisons=(), include_incomplete: bool = False,
                  fingerprint: str | None = None) -> str:
    """HTML fragment of the study's analysis; cached until the next response arrives."""
    extra = [tuple(c) for c in extra_comparisons]
    fp = fingerprint or D.fingerprint(study, include_incomplete)
    key = _key(study, fp, extra, include_incomplete)
    html = _cached(cache.get, key)
    if html is None:
        analysis = D.analyze_study(study, include_incomplete=include_incomplete, extra_comparisons=extra)
        html = R.render_fragment(analysis, title=f"Analysis of {study.name}")
        _cached(cache.set, key, html, CACHE_SECONDS)
    return html


def _cached(call, *args):
    """The cache only saves work: when it is down (Redis restarting), the report is computed
    afresh instead of failing, as the rate limits fail open (studyapp/security.py)."""
    try:
        return call(*args)
    except Exception as exc:  # any backend error (connection refused, timeout)
        logger.warning("analysis report cache unavailable (%s: %s); computing without it", type(exc).__name__, exc)
        return None


@researcher_required
def report(request, slug):
    study = get_object_or_404(Study, slug=slug)
    extra = parse_comparisons(request.GET.getlist("compare"))
    incomplete = request.GET.get("incomplete") == "1"
    fp = D.fingerprint(study, incomplete)
    etag = '"' + hashlib.sha1(_key(study, fp, extra, incomplete).encode()).hexdigest()[:20] + '"'
    if request.GET.get("fragment") == "1":
        # Django's If-None-Match handling (lists of tags, weak comparison, "*"): 304 when unchanged
        not_modified = get_conditional_response(request, etag=etag)
        if not_modified is not None:
            return not_modified
        response = HttpResponse(render_report(study, extra, incomplete, fp))
        response["ETag"] = etag
        response["Cache-Control"] = "no-cache"
        return response
    return render(request, "studyapp/analysis/dashboard.html", {
        "study": study, "fragment": render_report(study, extra, incomplete, fp), "etag": etag,
        "refresh_seconds": REFRESH_SECONDS})
