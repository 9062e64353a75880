"""Plain helpers shared by the study-app tests (fixtures live in conftest.py)."""
import json
import re

from django.http import QueryDict
from django.urls import reverse

from studyapp.models import Answer, Participant
from studyapp.participant import flow


def snapshot():
    """Everything an answer post may write: compare before and after a refused request."""
    answers = Answer.objects.values_list("participant_id", "step", "data")
    return (sorted((who, step, json.dumps(data, sort_keys=True)) for who, step, data in answers),
            sorted(Participant.objects.values_list("pk", "position", "excluded", "completed_at", "completion_code")))


def answer_url(p, step=0):
    return reverse("answer", args=[p.study.slug, p.token, step])


def step_url(p):
    return reverse("step", args=[p.study.slug, p.token])


def page_token(response) -> str:
    """The CSRF token a step page's form carries."""
    return re.search(rb'name="csrfmiddlewaretoken" value="([^"]+)"', response.content).group(1).decode()


def record(p, step, **fields):
    """Store an answer through studyapp.participant.flow (no request), fields given as keyword arguments."""
    q = QueryDict(mutable=True)
    for k, v in fields.items():
        q.setlist(k, v if isinstance(v, list) else [v])
    return flow.record(p, step, q)


def design_post(table, **fields) -> dict:
    """A minimal valid post of the study designer for `table` (a built table's directory), `fields` added or
    replacing its values."""
    return {"table": str(table), "slug": "designed", "target_per_condition": "20", "recruitment": "link",
            "approx_star": "det-euclidean", "seed": "0", "min_regret": "0.001", "estimated_minutes": "15",
            "conditions": ["exact"], "min_distance": "0.1", **fields}  # the tiny table's tests (TINY_TEST_SET)


def design_form(table, **fields):
    """The study designer's form for `table` with design_post's data."""
    from precompute.design import StudyDesignForm  # noqa: PLC0415  (the designer's own imports)
    from precompute.tables import built_tables  # noqa: PLC0415

    tables = [t for t in built_tables(table.parent) if t["path"] == str(table)]
    return StudyDesignForm(design_post(table, **fields), tables=tables)
