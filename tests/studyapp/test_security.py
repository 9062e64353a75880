"""Security policy (docs/decisions.md, "Security"): staff-only researcher pages, a token reaches only
its own participant, CSRF on every form (the MTurk-iframe case included), escaping of participant
text, CSV-injection-safe exports, rate limits and request-size caps."""
import csv
import io
import logging
import re
from pathlib import Path

import pytest
from django.http import QueryDict
from django.test import Client, override_settings
from django.urls import URLPattern, URLResolver, get_resolver, reverse

from precompute.models import Job
from studyapp import assignment, exports, flow, security, views
from studyapp.models import Answer, Participant, Study

pytestmark = pytest.mark.django_db
ROOT = Path(__file__).resolve().parents[2]
XSS = "<script>alert(\"x\")</script>'\"&"


def snapshot():
    return (list(Answer.objects.values_list("pk", "step", "data")),
            list(Participant.objects.values_list("pk", "position", "excluded", "completed_at")))


def answer_url(p, step=0):
    return reverse("answer", args=[p.study.slug, p.token, step])


def step_url(p):
    return reverse("step", args=[p.study.slug, p.token])


def page_token(response) -> str:
    return re.search(rb'name="csrfmiddlewaretoken" value="([^"]+)"', response.content).group(1).decode()


def record(p, step, **fields):
    q = QueryDict(mutable=True)
    for k, v in fields.items():
        q.setlist(k, v if isinstance(v, list) else [v])
    return flow.record(p, step, q)


# --- access control ---------------------------------------------------------------------------
def staff_urls(study, job):
    cond = study.conditions.first()
    gets = [reverse("dashboard"), reverse("dashboard_study", args=[study.slug]),
            reverse("dashboard_progress", args=[study.slug]), reverse("dashboard_analysis", args=[study.slug]),
            *(reverse("dashboard_export", args=[study.slug, k]) for k in ("long", "wide", "dictionary")),
            reverse("precompute:jobs"), reverse("precompute:job", args=[job.pk]),
            reverse("precompute:job_status", args=[job.pk])]
    posts = [reverse("dashboard_toggle", args=[study.slug]),
             reverse("dashboard_preview", args=[study.slug, cond.pk]),
             reverse("precompute:job_retry", args=[job.pk])]
    return gets, posts


@pytest.mark.parametrize("who", ["anonymous", "non-staff"])
def test_researcher_pages_refuse_everyone_but_staff(study, django_user_model, who):
    job = Job.objects.create(kind=Job.STUDY, params={"slug": study.slug}, status=Job.FAILED, error="boom")
    c = Client()
    if who == "non-staff":
        c.force_login(django_user_model.objects.create_user("plain", password="pw-plain-123"))
    gets, posts = staff_urls(study, job)
    for url in gets:
        r = c.get(url)
        assert r.status_code == 302 and r["Location"].startswith("/admin/login/"), url
    for url in posts:
        r = c.post(url, {"open": "0"})
        assert r.status_code == 302 and r["Location"].startswith("/admin/login/"), url
    job.refresh_from_db()
    assert Study.objects.get().is_open and not Participant.objects.exists() and job.attempts == 0


def test_staff_reach_every_researcher_page(staff_client, study):
    job = Job.objects.create(kind=Job.STUDY, params={"slug": study.slug}, status=Job.FAILED, error="boom")
    for url in staff_urls(study, job)[0]:
        assert staff_client.get(url).status_code == 200, url


def test_a_token_reaches_only_its_own_participant(client, make_study, complete):
    a_study, b_study = make_study("a"), make_study("b")
    mine = assignment.assign(a_study, "prolific", "MINE-pid")
    theirs = complete(assignment.assign(a_study, "prolific", "THEIRS-pid"))
    other = assignment.assign(b_study, "prolific", "OTHER-pid")
    before = snapshot()
    # a token under another study's slug is unknown there
    assert client.get(reverse("step", args=["b", mine.token])).status_code == 404
    assert client.post(reverse("answer", args=["b", mine.token, 0]), {"consent": "yes"}).status_code == 404
    assert client.post(reverse("answer", args=["a", other.token, 0]), {"consent": "yes"}).status_code == 404
    assert snapshot() == before
    # my page shows nothing of the finished participant, my answer moves only me
    page = client.get(step_url(mine)).content
    assert theirs.completion_code.encode() not in page and theirs.token.encode() not in page
    assert b"THEIRS-pid" not in page and b"MINE-pid" not in page
    assert client.post(answer_url(mine), {"consent": "yes"}).status_code == 302
    assert [(a.participant_id, a.step) for a in Answer.objects.exclude(participant=theirs)] == [(mine.pk, 0)]
    theirs_after = Participant.objects.get(pk=theirs.pk)
    assert (theirs_after.position, theirs_after.completed_at) == (theirs.position, theirs.completed_at)


# --- CSRF -------------------------------------------------------------------------------------
@pytest.fixture
def strict():
    return Client(enforce_csrf_checks=True)


@pytest.fixture
def participant(study):
    return assignment.assign(study, "prolific", "csrf1")


@pytest.mark.parametrize("headers", [
    {"HTTP_ORIGIN": "https://evil.example"},
    {"HTTP_ORIGIN": "null"},
    {"HTTP_ORIGIN": "http://testserver.evil.example"},
    {"HTTP_REFERER": "https://evil.example/forge.html"},
    {},  # no cookie, no token, no Origin, no Referer
])
def test_cookieless_answer_from_elsewhere_is_refused(strict, participant, headers):
    before = snapshot()
    for body in ({"consent": "yes"}, {"consent": "no"}):  # declining is a form too
        r = strict.post(answer_url(participant), body, **headers)
        assert r.status_code == 403 and b"nothing was saved" in r.content
    r = strict.post(answer_url(participant), {"consent": "yes"}, HTTP_ACCEPT="application/json", **headers)
    assert r.status_code == 403 and r.json()["ok"] is False and "study's own page" in r.json()["error"]
    assert snapshot() == before


@pytest.mark.parametrize("headers", [
    {"HTTP_ORIGIN": "http://testserver"},
    {"HTTP_REFERER": f"http://testserver/s/s1/p/x/"},
])
def test_cookieless_answer_from_our_own_page_is_accepted(strict, participant, headers):
    """The MTurk iframe: our page, our Origin, but the SameSite=Lax CSRF cookie is not sent."""
    assert strict.post(answer_url(participant), {"consent": "yes"}, **headers).status_code == 302
    assert Answer.objects.filter(participant=participant, step=0).exists()


@override_settings(CSRF_TRUSTED_ORIGINS=["https://study.example.org"])
def test_cookieless_answer_from_a_trusted_origin_is_accepted(strict, participant):
    r = strict.post(answer_url(participant), {"consent": "yes"}, HTTP_ORIGIN="https://study.example.org")
    assert r.status_code == 302


def test_answer_with_cookie_needs_the_form_token(strict, participant):
    token = page_token(strict.get(step_url(participant)))  # sets the CSRF cookie, as a browser visit does
    before = snapshot()
    assert strict.post(answer_url(participant), {"consent": "yes"}, HTTP_ORIGIN="http://testserver").status_code == 403
    r = strict.post(answer_url(participant), {"consent": "yes", "csrfmiddlewaretoken": token},
                    HTTP_ORIGIN="https://evil.example")
    assert r.status_code == 403 and snapshot() == before
    r = strict.post(answer_url(participant), {"consent": "yes", "csrfmiddlewaretoken": "x" * 64},
                    HTTP_ACCEPT="application/json")
    assert r.status_code == 403 and "expired" in r.json()["error"] and snapshot() == before
    assert strict.post(answer_url(participant), {"consent": "yes", "csrfmiddlewaretoken": token}).status_code == 302
    assert Answer.objects.filter(participant=participant, step=0).exists()


def test_staff_forms_need_the_csrf_token(study, django_user_model):
    user = django_user_model.objects.create_user("staff", password="pw-staff-123", is_staff=True)
    c = Client(enforce_csrf_checks=True)
    c.force_login(user)
    job = Job.objects.create(kind=Job.STUDY, params={"slug": study.slug}, status=Job.FAILED, error="boom")
    toggle = reverse("dashboard_toggle", args=[study.slug])
    assert c.post(toggle, {"open": "0"}).status_code == 403
    assert c.post(reverse("dashboard_preview", args=[study.slug, study.conditions.first().pk])).status_code == 403
    assert c.post(reverse("precompute:job_retry", args=[job.pk])).status_code == 403
    job.refresh_from_db()
    assert Study.objects.get().is_open and not Participant.objects.exists() and job.attempts == 0
    assert b"csrfmiddlewaretoken" in c.get(reverse("precompute:job", args=[job.pk])).content
    token = page_token(c.get(reverse("dashboard_study", args=[study.slug])))
    assert c.post(toggle, {"open": "0", "csrfmiddlewaretoken": token}).status_code == 302
    assert not Study.objects.get().is_open
    assert c.post(reverse("admin:logout")).status_code == 403


def test_admin_login_needs_the_csrf_token(django_user_model):
    django_user_model.objects.create_user("staff", password="pw-staff-123", is_staff=True)
    c = Client(enforce_csrf_checks=True)
    creds = {"username": "staff", "password": "pw-staff-123", "next": "/admin/"}
    assert c.post(reverse("admin:login"), creds).status_code == 403
    creds["csrfmiddlewaretoken"] = page_token(c.get(reverse("admin:login")))
    assert c.post(reverse("admin:login"), creds).status_code == 302


def _views(patterns):
    for p in patterns:
        if isinstance(p, URLResolver):
            yield from _views(p.url_patterns)
        elif isinstance(p, URLPattern):
            yield p.callback


def test_only_the_answer_view_takes_over_the_csrf_check():
    exempt = {v for v in _views(get_resolver().url_patterns) if getattr(v, "csrf_exempt", False)}
    assert exempt == {views.answer}


def test_every_post_form_carries_a_csrf_token():
    """Except the MTurk completion form: it posts to mturk.com, which must never see our token."""
    forms = []
    for path in [*ROOT.glob("templates/**/*.html"), *ROOT.glob("*/templates/**/*.html")]:
        for form in re.findall(r"<form\b[^>]*method=\"post\".*?</form>", path.read_text(), re.S | re.I):
            forms.append((path.name, form))
    assert len(forms) >= 8
    for name, form in forms:
        if 'id="mturk-form"' in form:
            assert "csrf_token" not in form
        else:
            assert "{% csrf_token %}" in form, name


# --- escaping and CSV injection ---------------------------------------------------------------
def test_participant_text_is_escaped_on_every_page(client, admin_client, study, complete):
    q = {"workerId": XSS, "assignmentId": XSS, "hitId": XSS, "turkSubmitTo": "https://www.mturk.com"}
    assert client.get(reverse("entry", args=[study.slug]), q).status_code == 302
    turk = complete(Participant.objects.get(), stop_before="demographics")
    turk = record(turk, turk.position, age="30", gender="other", gender_text=XSS)
    prolific = complete(assignment.assign(study, "prolific", XSS, platform_study_id=XSS, platform_session_id=XSS))
    escaped = "&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt;&#x27;&quot;&amp;".encode()
    shown = {  # page -> must it show the text (escaped)?
        step_url(turk): True,  # the MTurk completion form carries assignmentId
        step_url(prolific): False,
        reverse("dashboard"): False, reverse("dashboard_study", args=[study.slug]): False,
        reverse("dashboard_progress", args=[study.slug]): False,
        reverse("dashboard_analysis", args=[study.slug]): False,
        reverse("admin:studyapp_participant_changelist"): True,
        reverse("admin:studyapp_participant_changelist") + "?q=script": True,
        reverse("admin:studyapp_participant_change", args=[prolific.pk]): True,
        reverse("admin:studyapp_participant_change", args=[turk.pk]): True,
        reverse("admin:studyapp_answer_changelist"): True,
        reverse("admin:studyapp_answer_change", args=[Answer.objects.get(participant=turk,
                                                                          kind="demographics").pk]): False,
    }
    for url, must_show in shown.items():
        r = (client if "/p/" in url else admin_client).get(url)
        assert r.status_code == 200, url
        assert b"<script>alert" not in r.content, url
        if must_show:
            assert escaped in r.content, url
    demo = admin_client.get(reverse("admin:studyapp_answer_change", args=[
        Answer.objects.get(participant=turk, kind="demographics").pk])).content
    assert b"&lt;script&gt;alert(" in demo  # gender_text inside the stored JSON, escaped


def test_exports_neutralise_formulas_but_not_numbers(staff_client, study, complete):
    wrong = [next(k for k, o in enumerate(t["options"]) if not o["is_theta_star"]) for t in study.test_set]
    p = complete(assignment.assign(study, "prolific", "=HYPERLINK(\"http://x\")", platform_study_id="+1",
                                   platform_session_id="-2"), choices=wrong, stop_before="demographics")
    record(p, p.position, age="30", gender="other", gender_text="@SUM(A1)")
    complete(assignment.assign(study, "prolific", "\tTAB", platform_session_id="\rCR"))
    wide = list(csv.DictReader(io.StringIO(
        staff_client.get(reverse("dashboard_export", args=[study.slug, "wide"])).content.decode())))
    row = next(r for r in wide if r["participant_id"] == str(p.pk))
    assert (row["platform_pid"], row["platform_study_id"], row["platform_session_id"], row["gender_text"]) == (
        "'=HYPERLINK(\"http://x\")", "'+1", "'-2", "'@SUM(A1)")
    tab = next(r for r in wide if r["participant_id"] != str(p.pk))
    assert (tab["platform_pid"], tab["platform_session_id"]) == ("'\tTAB", "'\rCR")
    scores = [row[f"test{j}_confidence_score"] for j in range(6)]
    assert scores == ["-2"] * 6  # chosen option rated 2, not theta*'s: untouched negative numbers
    assert float(row["mean_confidence_score"]) == pytest.approx(sum(map(int, scores)) / 6)
    long = list(csv.DictReader(io.StringIO(exports.long_csv(study))))
    negative = [r["confidence_score"] for r in long if r["confidence_score"].startswith("-")]
    assert negative and all(re.fullmatch(r"-[1-7]", s) for s in negative)
    assert exports.neutralise(-5) == -5 and exports.neutralise(-0.5) == -0.5 and exports.neutralise("ok") == "ok"


# --- rate limits ------------------------------------------------------------------------------
@override_settings(RATE_LIMIT_ENTRY=(3, 60))
def test_entry_is_rate_limited_per_address(study):
    c = Client()
    for i in range(3):
        assert c.get(reverse("entry", args=[study.slug]), {"PROLIFIC_PID": f"r{i}"}).status_code == 302
    r = c.get(reverse("entry", args=[study.slug]), {"PROLIFIC_PID": "r3"})
    assert r.status_code == 429 and 1 <= int(r["Retry-After"]) <= 60
    assert b"Too many requests" in r.content and b"Traceback" not in r.content
    assert "frame-ancestors" in r["Content-Security-Policy"]  # readable inside the MTurk iframe too
    r = c.get(reverse("entry", args=[study.slug]), {"PROLIFIC_PID": "r3"}, HTTP_ACCEPT="application/json")
    assert r.status_code == 429 and r.json()["ok"] is False and "wait" in r.json()["error"]
    assert Participant.objects.count() == 3
    # another address is counted on its own; a forged X-Forwarded-For changes nothing
    assert Client(REMOTE_ADDR="192.0.2.7").get(reverse("entry", args=[study.slug])).status_code == 302
    assert c.get(reverse("entry", args=[study.slug]), HTTP_X_FORWARDED_FOR="198.51.100.1").status_code == 429


@override_settings(RATE_LIMIT_ANSWER=(2, 60))
def test_answers_are_rate_limited_per_token(client, study):
    p, q = (assignment.assign(study, "prolific", pid) for pid in ("t1", "t2"))
    for _ in range(2):  # the repeat is an idempotent no-op, but it still counts
        assert client.post(answer_url(p), {"consent": "yes"}).status_code == 302
    before = snapshot()
    r = client.post(answer_url(p, 1), {"ack": "1"}, HTTP_ACCEPT="application/json")
    assert r.status_code == 429 and r.json()["ok"] is False and int(r["Retry-After"]) >= 1
    assert snapshot() == before
    assert client.post(answer_url(q), {"consent": "yes"}).status_code == 302  # another token, same address


@override_settings(RATE_LIMIT_ANSWER_IP=(3, 60))
def test_answers_are_rate_limited_per_address(client, study):
    people = [assignment.assign(study, "prolific", f"ip{i}") for i in range(4)]
    for p in people[:3]:
        assert client.post(answer_url(p), {"consent": "yes"}).status_code == 302
    assert client.post(answer_url(people[3]), {"consent": "yes"}).status_code == 429
    assert not Answer.objects.filter(participant=people[3]).exists()


@override_settings(RATE_LIMIT_ENTRY=(1, 60))
def test_the_window_ends(study, monkeypatch):
    now = [1_000_000.0]
    monkeypatch.setattr(security.time, "time", lambda: now[0])
    c = Client()
    assert c.get(reverse("entry", args=[study.slug])).status_code == 302
    r = c.get(reverse("entry", args=[study.slug]))
    assert r.status_code == 429 and r["Retry-After"] == "20"  # 1_000_020 is the next multiple of 60
    now[0] += 20
    assert c.get(reverse("entry", args=[study.slug])).status_code == 302


@override_settings(RATE_LIMIT_ENTRY=(1, 60), RATE_LIMIT_CACHE="down", CACHES={
    "default": {"BACKEND": "django.core.cache.backends.locmem.LocMemCache"},
    "down": {"BACKEND": "django.core.cache.backends.redis.RedisCache", "LOCATION": "redis://127.0.0.1:1/0",
             "OPTIONS": {"socket_connect_timeout": 0.2, "socket_timeout": 0.2}}})
def test_a_cache_outage_lets_participants_through(study, caplog, monkeypatch):
    monkeypatch.setattr(security, "_last_outage_log", 0.0)
    with caplog.at_level(logging.WARNING, logger="studyapp.security"):
        for _ in range(3):
            assert Client().get(reverse("entry", args=[study.slug])).status_code == 302
    assert sum("cache is unavailable" in r.getMessage() for r in caplog.records) == 1  # once, not per request


def test_client_address(rf, settings):
    settings.TRUSTED_PROXY_COUNT = 0
    req = rf.get("/", REMOTE_ADDR="10.1.2.3", HTTP_X_FORWARDED_FOR="6.6.6.6")
    assert security.client_ip(req) == "10.1.2.3"
    settings.TRUSTED_PROXY_COUNT = 1
    assert security.client_ip(rf.get("/", REMOTE_ADDR="10.0.0.1", HTTP_X_FORWARDED_FOR="6.6.6.6, 203.0.113.5")
                              ) == "203.0.113.5"
    settings.TRUSTED_PROXY_COUNT = 2
    assert security.client_ip(rf.get("/", REMOTE_ADDR="10.0.0.1", HTTP_X_FORWARDED_FOR="6.6.6.6, 203.0.113.5, "
                                      "10.0.0.2")) == "203.0.113.5"
    settings.TRUSTED_PROXY_COUNT = 0
    assert security.client_ip(rf.get("/", REMOTE_ADDR="2001:db8:1:2:3:4:5:6")) == "2001:db8:1:2::/64"
    assert security.client_ip(rf.get("/", REMOTE_ADDR="::ffff:192.0.2.9")) == "192.0.2.9"


@pytest.mark.redis
def test_counters_in_redis(settings):
    import redis

    try:
        redis.Redis(socket_connect_timeout=1).ping()
    except redis.exceptions.ConnectionError:
        pytest.skip("no Redis on 127.0.0.1:6379")
    settings.CACHES = {"default": {"BACKEND": "django.core.cache.backends.locmem.LocMemCache"},
                       "rl": {"BACKEND": "django.core.cache.backends.redis.RedisCache",
                              "LOCATION": "redis://127.0.0.1:6379/1"}}
    settings.RATE_LIMIT_CACHE = "rl"
    key = f"test:{security._generation}:{id(settings)}"  # expires by itself; nothing is flushed
    assert [security.hit(key, 2, 30) for _ in range(2)] == [0, 0]
    assert security.hit(key, 2, 30) >= 1


def test_settings_parse_limits_and_cache_urls(monkeypatch):
    from config import settings as cfg

    monkeypatch.setenv("RATE_LIMIT_X", "5/10")
    assert cfg._rate("RATE_LIMIT_X", "1/1") == (5, 10)
    monkeypatch.setenv("RATE_LIMIT_X", "off")
    assert cfg._rate("RATE_LIMIT_X", "1/1") is None
    for bad in ("fast", "0/10", "5/0"):
        monkeypatch.setenv("RATE_LIMIT_X", bad)
        with pytest.raises(RuntimeError, match="RATE_LIMIT_X"):
            cfg._rate("RATE_LIMIT_X", "1/1")
    assert cfg._cache("redis://r:6379/1")["BACKEND"].endswith("RedisCache")
    assert cfg._cache("")["BACKEND"].endswith("LocMemCache")
    with pytest.raises(RuntimeError, match="CACHE_URL"):
        cfg._cache("memcached://x")


# --- request size -----------------------------------------------------------------------------
@pytest.mark.parametrize("debug", [False, True])
def test_oversized_and_overfull_requests_are_clean_4xx(client, participant, settings, debug):
    settings.DEBUG = debug
    before = snapshot()
    big = client.post(answer_url(participant), {"consent": "yes", "pad": "x" * (70 * 1024)})
    assert big.status_code == 413 and b"too large" in big.content
    many = client.post(answer_url(participant), {"consent": "yes", **{f"f{i}": "1" for i in range(600)}})
    assert many.status_code == 400 and b"too many fields" in many.content
    query = client.get(reverse("entry", args=[participant.study.slug]) + "?" + "&".join(f"a{i}=1" for i in range(600)))
    assert query.status_code == 400
    bad_length = client.generic("POST", answer_url(participant), b"consent=yes",
                                content_type="application/x-www-form-urlencoded", CONTENT_LENGTH="lots")
    assert bad_length.status_code == 400
    broken = client.generic("POST", answer_url(participant), b"--x\r\nnot a multipart body",
                            content_type="multipart/form-data; boundary=x")
    assert broken.status_code == 400
    settings.DATA_UPLOAD_MAX_MEMORY_SIZE = 100  # as a body that came without a Content-Length
    assert client.post(answer_url(participant), {"consent": "yes", "pad": "x" * 200}).status_code == 413
    for r in (big, many, query, bad_length, broken):
        assert b"Traceback" not in r.content
    assert snapshot() == before


def test_json_clients_get_json_refusals(client, participant):
    r = client.post(answer_url(participant), {"pad": "x" * (70 * 1024)}, HTTP_ACCEPT="application/json")
    assert r.status_code == 413 and r.json()["ok"] is False


def test_admin_still_works_under_the_caps(admin_client, study, complete):
    complete(assignment.assign(study, "prolific", "adm"))
    url = reverse("admin:studyapp_study_change", args=[study.pk])
    form = admin_client.get(url).context["adminform"].form
    data = {k: ("" if v is None else v) for k, v in form.initial.items() if k in form.fields}
    data.update(name="Renamed", is_open="on", **{
        "conditions-TOTAL_FORMS": "0", "conditions-INITIAL_FORMS": "0",
        "conditions-MIN_NUM_FORMS": "0", "conditions-MAX_NUM_FORMS": "1000"})
    r = admin_client.post(url, data)
    assert r.status_code == 302, r.content[:2000]
    assert Study.objects.get().name == "Renamed"
    assert admin_client.get(reverse("admin:studyapp_participant_changelist")).status_code == 200


def test_nul_characters_and_overlong_ids_are_refused_not_500(client, participant):
    """Both would fail inside PostgreSQL (a 500) rather than be refused as bad input."""
    before = snapshot()
    entry = reverse("entry", args=[participant.study.slug])
    assert client.get(entry, {"PROLIFIC_PID": "a\x00b"}).status_code == 400
    assert client.get(entry, {"workerId": "W", "assignmentId": "A",
                              "turkSubmitTo": "https://www.mturk.com/" + "x" * 300}).status_code == 400
    assert client.post(answer_url(participant), {"consent": "yes", "x\x00": "1"}).status_code == 400
    assert client.get(reverse("step", args=[participant.study.slug, "to\x00ken"])).status_code == 400
    assert snapshot() == before and Participant.objects.count() == 1
