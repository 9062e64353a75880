"""The stimulus sheet (researchers only): every condition's training examples, in order, and
every test's four options, each drawn as its whole trajectory (a contact sheet) and playable as the
participant's animation, so a study can be looked over before it is opened.

This page is staff-only, so unlike a participant's page (studyapp/participant/views.py, which carries only
what it draws) it names what the server knows: each environment's id and class, each option's
strategy cluster and theta index, and which option is theta*'s.  What the canvas draws is still
:func:`studyapp.trajectories.drawn_scene` of the stored payload, the participant's exact scene.
"""
from __future__ import annotations

from django.shortcuts import get_object_or_404, render
from django.urls import reverse
from django.views.decorators.http import require_GET

from ..guards.access import researcher_required
from ..models import Study
from ..scenes import recording, scene_context
from ..trajectories import drawn_scene, is_show, study_domain

LETTERS = "ABCDEFGH"  # canonical option order (a participant sees them in an order drawn for them)


def row_of_example(payload: dict, number: int, domain) -> dict:
    return {"number": number, "env_id": payload.get("env_id"), "caption": domain.caption(payload),
            "class_name": payload.get("class_name", ""), "cluster_name": payload.get("cluster_name", ""),
            "scene": drawn_scene(payload, robot=True, domain=domain)}


def row_of_test(test: dict, number: int, domain) -> dict:
    """A test's row: its options, or for a "show the way" test θ*'s own way (the one that scores 0 regret;
    the participant never sees it)."""
    if is_show(test):
        options = [{"letter": "θ*'s way", "theta_index": None, "is_theta_star": True,
                    "cluster_name": test.get("cluster_name", ""), "robot": test["robot"]}]
    else:
        options = [{"letter": LETTERS[k], "theta_index": o.get("theta_index"),
                    "is_theta_star": bool(o.get("is_theta_star")), "cluster_name": o.get("cluster_name", ""),
                    "robot": o["robot"]}
                   for k, o in enumerate(test["options"])]
    return {"number": number, "env_id": test.get("env_id"), "caption": domain.caption(test),
            "class_name": test.get("class_name", ""), "scene": drawn_scene(test, robot=False, domain=domain),
            "options": options}


def sheet(study: Study) -> dict:
    """The page's data: per condition its examples in order, and the test set."""
    domain = study_domain(study)
    conditions = [{"id": f"training-{c.pk}", "name": c.name,
                   "examples": [row_of_example(p, i + 1, domain) for i, p in enumerate(c.training)]}
                  for c in study.conditions.order_by("position", "pk")]
    tests = [row_of_test(t, j + 1, domain) for j, t in enumerate(study.test_set)]
    media_base = reverse("dashboard_study", args=[study.slug]) + "media/"
    return {"conditions": conditions, "tests": tests, **scene_context(study, media_base=media_base),
            "n_examples": sum(len(c["examples"]) for c in conditions),
            "n_options": sum(len(t["options"]) for t in tests)}


@researcher_required
def stimuli(request, slug):
    study = get_object_or_404(Study, slug=slug)
    return render(request, "studyapp/dashboard/stimuli.html", {"study": study, **sheet(study)})


@researcher_required
@require_GET
def media(request, slug, name):
    """A recording the stimulus sheet shows."""
    return recording(get_object_or_404(Study, slug=slug), name)
