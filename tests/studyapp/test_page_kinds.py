"""One object per step kind (studyapp.participant.pages): a new kind of step is this one module, a form and a Page
registered before the attention check, and the real flow, views, answer recording and simulated
participants take it with no change anywhere else."""
from __future__ import annotations

import re

import numpy as np
import pytest
from django import forms
from django.http import HttpResponse
from django.template import engines

from studyapp.analysis.simulate import run_participant
from studyapp.models import Answer, Participant, StepKind
from studyapp.participant import flow
from studyapp.participant.forms import StepForm
from studyapp.participant.pages import PAGE_SEQUENCE, PAGES, Page, register, unregister
from tests.conftest import answer_payload

TOY = "sleep"  # what Answer.kind stores for the toy step

TEMPLATE = """{% extends "studyapp/participant_base.html" %}{% block content %}
<h1>How rested are you?</h1><p id="hours">{{ hours_prompt }}</p>
<form method="post" action="{% url 'answer' study.slug participant.token step.index %}">{% csrf_token %}
<input name="hours" type="number"><button type="submit">Next</button></form>{% endblock %}"""


class SleepForm(StepForm):
    hours = forms.IntegerField(min_value=0, max_value=24, error_messages={
        "required": "Please say how many hours you slept.", "min_value": "From 0 to 24 hours, please.",
        "max_value": "From 0 to 24 hours, please.", "invalid": "From 0 to 24 hours, please."})

    def answer(self) -> dict:
        return {"hours": self.cleaned_data["hours"]}


class SleepPage(Page):
    kind, form = TOY, SleepForm

    def context(self, participant, step, ctx):
        return {"hours_prompt": f"Hours slept last night (step {step.index + 1})"}

    def render(self, request, ctx, status=200):
        return HttpResponse(engines["django"].from_string(TEMPLATE).render(ctx, request), status=status)

    def score(self, answer, participant, step, data):
        answer.correct = data["hours"] >= 6

    def simulate(self, sim, participant, step):
        return {"hours": int(sim.rng.integers(4, 10))}


@pytest.fixture
def sleep_page():
    register(SleepPage(), before=StepKind.ATTENTION)
    yield PAGES[TOY]
    unregister(TOY)


def test_a_toy_step_kind_is_walked_through_the_real_views(sleep_page, study, client):
    assert PAGE_SEQUENCE.index(TOY) == PAGE_SEQUENCE.index(StepKind.ATTENTION) - 1
    client.get(f"/s/{study.slug}/?PROLIFIC_PID=toy1&STUDY_ID=s&SESSION_ID=x")
    participant = Participant.objects.get(study=study, platform_pid="toy1")
    kinds = [s.kind for s in flow.steps_for(participant)]
    assert kinds[-4:] == [TOY, StepKind.ATTENTION, StepKind.DEMOGRAPHICS, StepKind.DONE]
    seen = []
    for step in flow.steps_for(participant)[:-1]:
        page = client.get(participant.get_absolute_url())
        assert page.status_code == 200
        seen.append(step.kind)
        if step.kind == TOY:
            html = page.content.decode()
            assert f"Hours slept last night (step {step.index + 1})" in html
            url = re.search(r'action="([^"]+)"', html).group(1)
            refused = client.post(url, {"hours": "30"})  # the toy form's own message, nothing stored
            assert "From 0 to 24 hours, please." in refused.content.decode()
            assert not Answer.objects.filter(participant=participant, kind=TOY).exists()
            body = {"hours": "7"}
        else:
            body = answer_payload(participant, step)
            url = f"/s/{study.slug}/p/{participant.token}/{step.index}/"
        assert client.post(url, body).status_code == 302
        participant.refresh_from_db()
    assert seen[-3:] == [TOY, StepKind.ATTENTION, StepKind.DEMOGRAPHICS]
    stored = Answer.objects.get(participant=participant, kind=TOY)
    assert stored.data == {"hours": 7} and stored.correct is True
    participant.refresh_from_db()
    assert participant.completed_at is not None and participant.completion_code


def test_a_simulated_participant_answers_the_toy_step_too(sleep_page, study):
    participant = run_participant(study, np.random.default_rng(0))
    assert participant.completed_at is not None
    [hours] = Answer.objects.filter(participant=participant, kind=TOY).values_list("data__hours", flat=True)
    assert 4 <= hours < 10


def test_without_the_toy_page_the_flow_is_the_studys_own(study, participant):
    assert TOY not in PAGE_SEQUENCE and TOY not in PAGES
    assert [s.kind for s in flow.steps_for(participant)][-3:] == [
        StepKind.ATTENTION, StepKind.DEMOGRAPHICS, StepKind.DONE]


def test_a_kind_is_registered_once(sleep_page):
    with pytest.raises(ValueError, match="registered already"):
        register(SleepPage(), before=StepKind.DONE)
