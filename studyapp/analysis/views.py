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
researcher-named Welch comparisons (a pair of the study's conditions not compared already: else
a 400 with the message, ComparisonsForm); ``?incomplete=1`` also analyses unfinished participants.
A study whose conditions include two names of one condition is not analysed: the page says why.

``GET .../analysis/models/`` is the learner-model panel (modelfit.py: every model fitted, ranked,
with the predicted-vs-observed figure), fetched by the page after the report and again whenever the
report changes; cached under the same fingerprint, with an ETag.  ``.../analysis/models.csv`` is its
table.  A study that cannot be fitted gets the reason in one line, never a traceback.
"""
from __future__ import annotations

import hashlib
import logging

from django import forms
from django.core.cache import cache
from django.http import HttpResponse
from django.shortcuts import get_object_or_404, render
from django.template.loader import render_to_string
from django.utils.cache import get_conditional_response

from teaching.api import TIE_TOLERANCE

from ..guards.access import researcher_required
from ..models import Study
from . import data as D
from . import figures as FIG
from . import modelfit as MF
from . import report as R
from . import stats as S

logger = logging.getLogger("studyapp.analysis")
REFRESH_SECONDS = 20
CACHE_SECONDS = 60 * 60 * 24


class ComparisonsForm(forms.Form):
    """The page's ``?compare=a:b`` (repeatable): each a pair of the study's conditions that is not
    compared already (comparisons.comparison_family); anything else is a message, never dropped."""

    compare = forms.Field(required=False, widget=forms.MultipleHiddenInput)

    def __init__(self, data, *, conditions: list[str], planned: list[tuple[str, str]]):
        super().__init__(data)
        self.conditions, self.planned = conditions, planned

    def clean_compare(self) -> list[tuple[str, str]]:
        pairs = []
        for value in self.cleaned_data["compare"] or []:
            a, sep, b = str(value).partition(":")
            if not (sep and a.strip() and b.strip()):
                raise forms.ValidationError(f"compare={value!r}: name two conditions as condition-a:condition-b.")
            pairs.append((a.strip(), b.strip()))
        try:
            S.comparison_family(self.planned, pairs, set(self.conditions))
        except S.ConditionError as exc:
            raise forms.ValidationError(f"compare: {exc}.") from None
        return pairs


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
    afresh instead of failing, as the rate limits fail open (studyapp/guards/security.py)."""
    try:
        return call(*args)
    except Exception as exc:  # any backend error (connection refused, timeout)
        logger.warning("analysis report cache unavailable (%s: %s); computing without it", type(exc).__name__, exc)
        return None


@researcher_required
def report(request, slug):
    study = get_object_or_404(Study, slug=slug)
    try:  # a study stored with two names for one condition is not analysed (docs/analysis.md)
        conditions = D.condition_names(study)
    except S.ConditionError as exc:
        return _refused(request, study, [f"This study cannot be analysed: {exc}."], status=200)
    form = ComparisonsForm(request.GET, conditions=conditions,
                           planned=S.default_comparisons(D.study_approx_star(conditions)))
    if not form.is_valid():
        return _refused(request, study, form.errors["compare"], status=400, bad_compare=True)
    extra = form.cleaned_data["compare"]
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


def _refused(request, study, errors, status, bad_compare=False):
    """The page (or the polled fragment) with the messages instead of the report."""
    context = {"study": study, "errors": list(errors), "bad_compare": bad_compare, "refresh_seconds": REFRESH_SECONDS}
    if request.GET.get("fragment") == "1":
        return render(request, "studyapp/analysis/_errors.html", context, status=status)
    return render(request, "studyapp/analysis/dashboard.html", context, status=status)


# --- the learner-model panel ---------------------------------------------------------------------
def _models_key(fp: str) -> str:
    return f"studyapp.analysis.models:{fp}"


def render_models(study: Study, fingerprint: str | None = None) -> str:
    """HTML fragment of the model comparison (or the one-line reason there is none); cached like the report."""
    key = _models_key(fingerprint or D.fingerprint(study))
    html = _cached(cache.get, key)
    if html is None:
        try:
            fit = MF.fit_study(study)
        except MF.ModelFitError as exc:
            context = {"study": study, "error": str(exc)}
        else:
            context = {"study": study, **models_context(fit)}
        html = render_to_string("studyapp/analysis/_models.html", context)
        _cached(cache.set, key, html, CACHE_SECONDS)
    return html


def models_context(fit: MF.StudyFit) -> dict:
    rows = fit.comparison.rows()
    for r in rows:
        r["value_label"] = ("" if r["value"] is None or not r["param"]
                            else f"{'τ' if r['param'] == 'tau' else 'λ'} = {r['value']:.3g}")
    figure = MF.accuracy_figure(fit)
    return {"rows": rows, "n_participants": fit.comparison.n_participants,
            "n_answers": rows[0]["n_answers"] if rows else 0, "best": rows[0]["model"] if rows else "",
            "best_tied": rows[0]["tied_with"] if rows else [], "ties": any(r["tied_with"] for r in rows),
            "tie_tolerance": f"{TIE_TOLERANCE:g}",
            "figure": FIG.data_uri(FIG.to_bytes(figure)), "bms": fit.comparison.bms is not None}


@researcher_required
def models(request, slug):
    study = get_object_or_404(Study, slug=slug)
    fp = D.fingerprint(study)
    etag = '"' + hashlib.sha1(_models_key(fp).encode()).hexdigest()[:20] + '"'
    not_modified = get_conditional_response(request, etag=etag)
    if not_modified is not None:
        return not_modified
    response = HttpResponse(render_models(study, fp))
    response["ETag"] = etag
    response["Cache-Control"] = "no-cache"
    return response


@researcher_required
def models_csv(request, slug):
    study = get_object_or_404(Study, slug=slug)
    try:
        body = MF.fit_study(study).csv()
    except MF.ModelFitError as exc:
        return HttpResponse(f"No model fit for this study: {exc}\n", status=409,
                            content_type="text/plain; charset=utf-8")
    response = HttpResponse(body, content_type="text/csv; charset=utf-8")
    response["Content-Disposition"] = f'attachment; filename="{slug}-models.csv"'
    return response
