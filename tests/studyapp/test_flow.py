"""The participant's flow: every step renders, answers are stored once, bad input is a 4xx that writes nothing."""
import pytest
from django.test import Client
from django.urls import reverse

from studyapp.data import exports
from studyapp.models import Answer, Participant, StepKind
from studyapp.participant import assignment, flow
from studyapp.researcher.dashboard import condition_stats
from tests.studyapp.helpers import snapshot

pytestmark = pytest.mark.django_db


@pytest.fixture
def participant(client, study):
    client.get(reverse("entry", args=[study.slug]), {"PROLIFIC_PID": "flow1", "STUDY_ID": "S", "SESSION_ID": "X"})
    return Participant.objects.get()


def url(p, step=None):
    if step is None:
        return reverse("step", args=[p.study.slug, p.token])
    return reverse("answer", args=[p.study.slug, p.token, step])


def advance(client, p, answer_for, until_kind):
    """Answer steps with valid data until the participant stands on a step of `until_kind`."""
    p.refresh_from_db()
    while flow.current_step(p).kind != until_kind:
        step = flow.current_step(p)
        r = client.post(url(p, step.index), answer_for(p, step))
        assert r.status_code == 302, r.content[:300]
        p.refresh_from_db()
    return flow.current_step(p)


def test_every_step_renders_in_order(client, participant, answer_for):
    seen = []
    p = participant
    while True:
        step = flow.current_step(p)
        r = client.get(url(p))
        assert r.status_code == 200
        assert r["Cache-Control"].count("no-store") == 1  # back/reload always refetches the current step
        seen.append(step.kind)
        if step.kind == StepKind.DONE:
            break
        assert client.post(url(p, step.index), answer_for(p, step)).status_code == 302
        p.refresh_from_db()
    n_train = len(p.condition.training)
    assert seen == [StepKind.CONSENT, StepKind.INSTRUCTIONS] + [StepKind.TRAINING] * n_train + [StepKind.TEST] * 6 + [
        StepKind.ATTENTION, StepKind.DEMOGRAPHICS, StepKind.DONE]
    assert Answer.objects.filter(participant=p).count() == len(seen) - 1


def test_training_page_carries_the_trajectory(client, participant, answer_for):
    advance(client, participant, answer_for, StepKind.TRAINING)
    r = client.get(url(participant))
    env = participant.condition.training[0]
    # what the page draws, and nothing else: no environment id, class or strategy cluster
    assert r.context["env"] == {k: env[k] for k in ("goal", "dt", "other", "robot", "world")}
    assert r.context["caption"] == ("Goal in this situation", env["goal_name"])
    for leak in (b"cluster", b"env_id", b"class_name", b"theta"):
        assert leak not in r.content
    assert b'id="env-data"' in r.content and b"training.js" in r.content
    assert len(env["robot"]) == 21 and len(env["robot"][0]) == 5 and len(env["other"]) == 21


def test_test_page_shows_options_in_the_participants_order(client, participant, answer_for):
    step = advance(client, participant, answer_for, StepKind.TEST)
    r = client.get(url(participant))
    order = participant.option_orders[step.item]
    assert r.context["options"] == ["A", "B", "C", "D"]
    test = participant.study.test_set[step.item]
    assert r.context["option_robots"]["A"] == test["options"][order[0]]["robot"]
    assert b"is_theta_star" not in r.content  # the page never reveals which option is theta*'s


def test_test_answer_is_scored(client, participant, answer_for):
    step = advance(client, participant, answer_for, StepKind.TEST)
    options = participant.study.test_set[step.item]["options"]
    star = next(k for k, o in enumerate(options) if o["is_theta_star"])
    wrong = (star + 1) % 4
    letter = "ABCD"[participant.option_orders[step.item].index(wrong)]  # as the participant sees it
    body = answer_for(participant, step)
    body.update(choice=[letter], **{f"rating_{letter}": ["5"]})
    assert client.post(url(participant, step.index), body).status_code == 302
    a = Answer.objects.get(participant=participant, step=step.index)
    assert (a.kind, a.item, a.chosen_option, a.correct, a.confidence_score) == (StepKind.TEST, 0, wrong, False, -5)
    assert a.data["order"] == participant.option_orders[0] and a.data["ratings"][wrong] == 5
    # the next test, answered right with confidence 6
    step = advance(client, participant, answer_for, StepKind.TEST)
    client.post(url(participant, step.index), answer_for(participant, step))
    a = Answer.objects.get(participant=participant, step=step.index)
    assert (a.correct, a.confidence_score) == (True, 6)


def test_repeated_post_is_idempotent(client, participant, answer_for):
    step = advance(client, participant, answer_for, StepKind.TEST)
    body = answer_for(participant, step)
    assert client.post(url(participant, step.index), body).status_code == 302
    before = snapshot()
    r = client.post(url(participant, step.index), body)
    assert r.status_code == 302 and r["Location"] == url(participant)
    r = client.post(url(participant, step.index), body, HTTP_ACCEPT="application/json")
    assert r.status_code == 200 and r.json()["ok"] is True
    assert snapshot() == before


def test_back_button_cannot_reanswer(client, participant, answer_for):
    step = advance(client, participant, answer_for, StepKind.TEST)
    client.post(url(participant, step.index), answer_for(participant, step))
    before = snapshot()
    changed = answer_for(participant, step)
    changed["rating_A"] = ["1"] if changed["rating_A"] != ["1"] else ["7"]
    # an out-of-date page is sent to the participant's current step, which says why
    r = client.post(url(participant, step.index), changed)
    assert r.status_code == 302 and r["Location"] == url(participant) + "?moved=1"
    page = client.get(r["Location"])
    assert page.context["notice"] == flow.MOVED_ON and flow.MOVED_ON.encode() in page.content
    assert page.context["step"].index == step.index + 1
    r = client.post(url(participant, step.index), changed, HTTP_ACCEPT="application/json")
    assert r.status_code == 409 and r.json() == {
        "ok": False, "moved": True, "next": url(participant) + "?moved=1",
        "error": "This question was already answered; an answer cannot be changed."}
    assert snapshot() == before


def test_answer_for_a_future_step_is_409(client, participant, answer_for):
    step = advance(client, participant, answer_for, StepKind.TRAINING)
    before = snapshot()
    r = client.post(url(participant, step.index + 1), {"played": ["1"]})
    assert r.status_code == 302 and r["Location"] == url(participant) + "?moved=1"
    r = client.post(url(participant, step.index + 1), {"played": ["1"]}, HTTP_ACCEPT="application/json")
    assert r.status_code == 409 and r.json()["moved"] is True
    assert client.post(url(participant, 999), {"x": "1"}).status_code == 404
    assert snapshot() == before


def test_token_of_another_study_is_404(client, participant, make_study):
    other = make_study("other")
    before = snapshot()
    r = client.get(reverse("step", args=[other.slug, participant.token]))
    assert r.status_code == 404
    r = client.post(reverse("answer", args=[other.slug, participant.token, 0]), {"consent": "yes"})
    assert r.status_code == 404
    assert client.get(reverse("step", args=[participant.study.slug, "no-such-token"])).status_code == 404
    assert snapshot() == before


def test_get_on_answer_url_is_405(client, participant):
    assert client.get(url(participant, 0)).status_code == 405


def _bad(body, **changes):
    body = {k: list(v) for k, v in body.items()}
    for k, v in changes.items():
        if v is None:
            body.pop(k, None)
        else:
            body[k] = v
    return body


@pytest.mark.parametrize("changes, message", [  # in the participant's words: the page says "Option B"
    ({"rating_A": ["0"]}, b"The rating of option A must be a whole number from 1 to 7."),
    ({"rating_B": ["8"]}, b"The rating of option B must be a whole number from 1 to 7."),
    ({"rating_C": ["abc"]}, b"The rating of option C must be a whole number from 1 to 7."),
    ({"rating_D": None}, b"Please rate how well option D matches (1 = not at all, 7 = exactly)."),
    ({"rating_D": ["3", "4"]}, b"Please rate how well option D matches"),
    ({"rating_E": ["3"]}, b"This question has options A, B, C, D only"),
    ({"rating_0": ["3"]}, b"This question has options A, B, C, D only"),
    ({"choice": ["E"]}, b"This question has options A, B, C, D only; please choose one of them."),
    ({"choice": ["0"]}, b"This question has options A, B, C, D only"),
    ({"choice": None}, b"Please choose the option that matches the car&#x27;s driving style."),
    ({"played": ["A", "B", "C"]}, b"Please play option D before you continue."),
    ({"played": None}, b"Please play option A, B, C, D before you continue."),
    ({"played": ["A", "B", "C", "D", "0"]}, b"This question has options A, B, C, D only"),
])
def test_bad_test_answers_are_400_and_write_nothing(client, participant, answer_for, changes, message):
    step = advance(client, participant, answer_for, StepKind.TEST)
    before = snapshot()
    r = client.post(url(participant, step.index), _bad(answer_for(participant, step), **changes))
    assert r.status_code == 400 and message in r.content
    r = client.post(url(participant, step.index), _bad(answer_for(participant, step), **changes),
                    HTTP_ACCEPT="application/json")
    assert r.status_code == 400 and r.json()["ok"] is False
    assert snapshot() == before


@pytest.mark.parametrize("kind, body, message", [  # no field names: what the participant can act on
    (StepKind.CONSENT, {}, b"Please say whether you agree to take part."),
    (StepKind.CONSENT, {"consent": "maybe"}, b"You can only continue if you agree to take part."),
    (StepKind.INSTRUCTIONS, {}, b"Please confirm that you have read the instructions."),
    (StepKind.TRAINING, {"played": "0"}, b"Please watch the whole animation before you continue."),
    (StepKind.TRAINING, {}, b"Please watch the whole animation before you continue."),
    (StepKind.ATTENTION, {}, b"Please tick your answer."),
    (StepKind.ATTENTION, {"goals": ["merge", "fly"]}, b"Please tick only answers from the list."),
    (StepKind.DEMOGRAPHICS, {"age": "17", "gender": "female"}, b"Your age must be a whole number from 18 to 120."),
    (StepKind.DEMOGRAPHICS, {"age": "121", "gender": "female"}, b"Your age must be a whole number from 18 to 120."),
    (StepKind.DEMOGRAPHICS, {"age": "thirty", "gender": "female"}, b"Your age must be a whole number from 18 to 120."),
    (StepKind.DEMOGRAPHICS, {"age": "30", "gender": "robot"}, b"Please choose an answer for gender from the list."),
    (StepKind.DEMOGRAPHICS, {"age": "30"}, b"Please choose an answer for gender (or &#x27;Prefer not to say&#x27;)."),
    (StepKind.DEMOGRAPHICS, {"gender": "female"}, b"Please enter your age."),
])
def test_bad_answers_on_other_steps(client, participant, answer_for, kind, body, message):
    step = advance(client, participant, answer_for, kind)
    before = snapshot()
    r = client.post(url(participant, step.index), body)
    assert r.status_code == 400 and message in r.content, r.content.decode()[-600:]
    assert snapshot() == before


def test_declining_consent_writes_nothing(client, participant):
    study = participant.study
    assert sum(assignment.condition_counts(study).values()) == 1  # the arrival holds a place
    r = client.post(url(participant, 0), {"consent": "no"})
    assert r.status_code == 200 and b"chose not to take part" in r.content
    assert b"has been deleted" in r.content  # what the page says is what happened:
    assert not Answer.objects.exists() and not Participant.objects.exists()  # no platform id kept
    assert sum(assignment.condition_counts(study).values()) == 0  # the place is free at once
    assert all(row["started"] == 0 for row in condition_stats(study))  # not "started", never "abandoned"
    assert "flow1" not in exports.long_csv(study) + exports.wide_csv(study)
    # a double click shows the same page; the dead token opens nothing
    assert b"chose not to take part" in client.post(url(participant, 0), {"consent": "no"}).content
    assert client.get(url(participant)).status_code == 404
    # coming back with the same Prolific id is a fresh arrival, asked for consent again
    client.get(reverse("entry", args=[study.slug]), {"PROLIFIC_PID": "flow1", "STUDY_ID": "S", "SESSION_ID": "Y"})
    again = Participant.objects.get()
    assert again.token != participant.token and again.position == 0


def test_declining_after_agreeing_in_another_tab_deletes_nothing(client, participant):
    assert client.post(url(participant, 0), {"consent": "yes"}).status_code == 302
    r = client.post(url(participant, 0), {"consent": "no"})  # the stale first tab
    assert b"chose not to take part" not in r.content
    assert Participant.objects.filter(pk=participant.pk).exists() and Answer.objects.count() == 1


def test_attention_check_failure_excludes_but_keeps(client, participant, answer_for):
    step = advance(client, participant, answer_for, StepKind.ATTENTION)
    client.post(url(participant, step.index), {"goals": ["merge", "park"]})
    participant.refresh_from_db()
    a = Answer.objects.get(participant=participant, kind=StepKind.ATTENTION)
    assert participant.excluded and a.data == {"goals": ["merge", "park"], "passed": False}
    advance(client, participant, answer_for, StepKind.DONE)
    participant.refresh_from_db()
    assert participant.completed_at is not None and participant.excluded


def test_attention_check_pass(client, participant, answer_for):
    step = advance(client, participant, answer_for, StepKind.ATTENTION)
    client.post(url(participant, step.index), {"goals": ["forward", "merge"]})
    participant.refresh_from_db()
    assert not participant.excluded
    assert Answer.objects.get(participant=participant, kind=StepKind.ATTENTION).data["passed"] is True


def test_completion_redirect_only_after_last_answer(client, participant, answer_for):
    step = advance(client, participant, answer_for, StepKind.DEMOGRAPHICS)
    r = client.get(url(participant))
    assert b"prolific.com" not in r.content and participant.completed_at is None
    client.post(url(participant, step.index), {"age": "40", "gender": "other", "gender_text": "x"})
    participant.refresh_from_db()
    assert participant.completed_at is not None and participant.completion_code
    demo = Answer.objects.get(participant=participant, kind=StepKind.DEMOGRAPHICS)
    assert demo.data == {"age": 40, "gender": "other", "gender_text": "x"}
    r = client.get(url(participant))
    target = f"https://app.prolific.com/submissions/complete?cc={participant.completion_code}"
    assert r.context["redirect_url"] == target
    assert target.encode() in r.content and b'http-equiv="refresh"' in r.content
    # nothing more can be answered once done
    assert client.post(url(participant, step.index + 1), {"x": "1"}).status_code == 409


def test_study_wide_completion_code(client, make_study, answer_for):
    s = make_study("coded", completion_code="C0DE123")
    client.get(reverse("entry", args=[s.slug]), {"PROLIFIC_PID": "z"})
    p = Participant.objects.get(study=s)
    advance(client, p, answer_for, StepKind.DONE)
    p.refresh_from_db()
    assert p.completion_code == "C0DE123"


def test_mturk_completion_posts_back_to_turk(client, study, answer_for):
    client.get(reverse("entry", args=[study.slug]), {"workerId": "W9", "assignmentId": "A9", "hitId": "H9",
                                                     "turkSubmitTo": "https://workersandbox.mturk.com"})
    p = Participant.objects.get()
    advance(client, p, answer_for, StepKind.DONE)
    r = client.get(url(p))
    assert b'action="https://workersandbox.mturk.com/mturk/externalSubmit"' in r.content
    assert b'name="assignmentId" value="A9"' in r.content


def test_a_stored_turk_submit_to_is_checked_again_before_it_becomes_a_form_action(client, study, answer_for):
    client.get(reverse("entry", args=[study.slug]), {"workerId": "W8", "assignmentId": "A8", "hitId": "H8"})
    Participant.objects.update(turk_submit_to="javascript://www.mturk.com/%0Aalert(document.domain)")  # legacy row
    p = Participant.objects.get()
    advance(client, p, answer_for, StepKind.DONE)
    r = client.get(url(p))
    assert b"javascript:" not in r.content
    assert f'action="{study.mturk_submit_url}"'.encode() in r.content


def test_anonymous_completion_shows_code_without_redirect(study, answer_for):
    c = Client()
    c.get(reverse("entry", args=[study.slug]))
    p = Participant.objects.get()
    advance(c, p, answer_for, StepKind.DONE)
    r = c.get(url(p))
    p.refresh_from_db()
    assert p.completion_code.encode() in r.content and "redirect_url" not in r.context


def test_visiting_updates_last_seen(client, participant):
    before = participant.last_seen_at
    client.get(url(participant))
    participant.refresh_from_db()
    assert participant.last_seen_at > before


def test_participant_pages_can_be_framed_by_mturk_only(client, participant, staff_client):
    for r in (client.get(url(participant)), client.get(reverse("entry", args=[participant.study.slug]))):
        assert "X-Frame-Options" not in r
        policy = dict(d.strip().split(" ", 1) for d in r["Content-Security-Policy"].split(";"))
        assert policy["frame-ancestors"] == "'self' https://workersandbox.mturk.com https://www.mturk.com"
        # only this site's own script files run on a participant page
        assert policy["script-src"] == "'self'" and policy["default-src"] == "'self'"
        assert policy["form-action"] == "'self' https://workersandbox.mturk.com https://www.mturk.com"
        assert policy["object-src"] == "'none'" and policy["base-uri"] == "'none'"
    assert staff_client.get(reverse("dashboard"))["X-Frame-Options"] == "DENY"


def test_cookieless_answers_need_this_sites_origin(participant):
    """Inside MTurk's cross-site iframe no cookie is sent, but the browser names our page as the
    Origin: accepted. Without the cookie and without a same-site Origin: refused, nothing written
    (the full CSRF policy is tested in test_csrf.py)."""
    strict = Client(enforce_csrf_checks=True)
    r = strict.post(url(participant, 0), {"consent": "yes"}, HTTP_ORIGIN="https://evil.example")
    assert r.status_code == 403 and not Answer.objects.exists()
    assert strict.post(url(participant, 0), {"consent": "yes"}).status_code == 403
    assert not Answer.objects.exists()
    r = strict.post(url(participant, 0), {"consent": "yes"}, HTTP_ORIGIN="http://testserver")
    assert r.status_code == 302
    assert Answer.objects.filter(participant=participant, step=0).exists()


def test_the_consent_stores_the_version_of_the_text_the_page_showed(study, client):
    p = assignment.assign(study, Participant.ANONYMOUS, "")
    page = client.get(reverse("step", args=[study.slug, p.token])).content.decode()
    version = study.consent_version()
    assert f'name="consent_version" value="{version}"' in page and len(version) == 12
    url = reverse("answer", args=[study.slug, p.token, 0])
    # the researcher changes the text while the participant reads it: their agreement is to another text
    study.consent_text = "A new approved text."
    study.save(update_fields=["consent_text"])
    r = client.post(url, {"consent": "yes", "consent_version": version}, HTTP_ACCEPT="application/json")
    assert r.status_code == 400 and "changed after this page was opened" in r.json()["error"]
    assert not Answer.objects.filter(participant=p).exists()
    r = client.post(url, {"consent": "yes", "consent_version": study.consent_version()})
    assert r.status_code == 302
    assert Answer.objects.get(participant=p).data == {"consent": True, "consent_version": study.consent_version()}
    assert study.consent_version() != version
