"""Fitting learner models to a study's stored answers: participants who learn by a model go
through the real assignment and flow into the database, and `manage.py fit_models` reads them back from
there (another path than teaching's simulate-and-fit), finds the model that generated them, and writes the
CSV and figure; bad input ends in one line."""
from __future__ import annotations

import csv
import io
import random

import numpy as np
import pytest
from django.core.management import call_command
from django.core.management.base import CommandError

from studyapp.analysis.modelfit import CSV_COLUMNS, ModelFitError, fit_study, study_answers, study_design
from studyapp.analysis.simulate import simulate
from studyapp.models import Participant
from studyapp.participant import assignment
from studyapp.researcher.studies import make_study
from teaching.api import SimulatedLearner, TrajectoryTable
from teaching.core.conditions import teach

pytestmark = pytest.mark.django_db


@pytest.fixture(autouse=True)
def seeded_assignment(monkeypatch):
    monkeypatch.setattr(assignment, "_rng", random.Random(20261125), raising=False)


@pytest.fixture(scope="module")
def det_euclidean_study(django_db_setup, django_db_blocker, demo_table):
    """A study answered through the real flow by 24 det-euclidean learners per condition (λ 1, lapse 0.1),
    committed once for the three tests that read the answers of that generator (two of them simulated 108
    of their own: 12 of the module's 68 s of CPU).  No test here writes to it, and it is deleted after the
    module (and the cache cleared of its fits), so no other test sees it."""
    from django.core.cache import cache  # noqa: PLC0415

    with django_db_blocker.unblock(), pytest.MonkeyPatch.context() as mp:
        mp.setattr(assignment, "_rng", random.Random(20261125), raising=False)
        study = make_study(demo_table, "fit-det-euclidean")
        simulate(study, n_per_condition=24, seed=2, learner=SimulatedLearner("det-euclidean", 1.0, 0.1))
    yield study
    with django_db_blocker.unblock():
        Participant.objects.filter(study=study).delete()  # a condition with participants cannot be deleted
        study.delete()
        cache.clear()


def run(*args) -> str:
    out = io.StringIO()
    call_command("fit_models", *args, stdout=out)
    return out.getvalue()


@pytest.mark.parametrize("model, value", [("det-euclidean", 1.0), ("prob-reward", 100.0)])
def test_the_generating_model_is_found_in_the_stored_answers(demo_table, det_euclidean_study, tmp_path, model, value):
    if model == "det-euclidean":
        study = det_euclidean_study
    else:
        study = make_study(demo_table, f"fit-{model}")
        simulate(study, n_per_condition=24, seed=2, learner=SimulatedLearner(model, value, 0.1))
    answers, _ = study_answers(study, study_design(study))
    excluded = Participant.objects.filter(study=study, excluded=True).count()
    assert excluded > 0 and answers.n_participants == 9 * 24 - excluded  # the analysed set only
    out = run(study.slug, "--csv", str(tmp_path / "m.csv"), "--figure", str(tmp_path / "m.png"))
    first = out.splitlines()[2]
    assert first.startswith(model), out
    rows = list(csv.DictReader((tmp_path / "m.csv").open()))
    assert list(rows[0]) == CSV_COLUMNS and rows[0]["model"] == model
    assert abs(float(rows[0]["lapse"]) - 0.1) < 0.06
    assert float(rows[0]["delta_bic"]) == 0 and float(rows[0]["exceedance"]) > 0.5
    assert "det-strategy = prob-strategy" in {r["model"] for r in rows}
    assert (tmp_path / "m.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_accuracy_cells_compare_prediction_and_observation(det_euclidean_study):
    study = det_euclidean_study
    fit = fit_study(study)
    cells = fit.accuracy()
    assert len(cells) == 9 * len(study.test_set)
    for c in cells:
        assert 0 <= c["observed"] <= 1 and c["n"] > 0
        assert set(c["predicted"]) == {f.label for f in fit.comparison.fits[:3]}
    # observed by hand from the stored answers: the share of a condition's analysed participants choosing θ*
    people = Participant.objects.filter(study=study, completed_at__isnull=False, excluded=False,
                                        condition__name="exact")
    by_hand = np.mean([a.correct for p in people for a in p.answers.filter(kind="test", item=0)])
    assert next(c for c in cells if c["condition"] == "exact" and c["test"] == 0)["observed"] == pytest.approx(by_hand)


def test_bad_input_gives_one_line(demo_table, tiny_table):
    study = make_study(demo_table, "fit-empty")
    with pytest.raises(CommandError, match="no participant has finished") as err:
        run(study.slug)
    assert "\n" not in str(err.value)
    with pytest.raises(CommandError, match="no study 'nope'"):
        run("nope")
    one = make_study(demo_table, "fit-one", {"exact": [int(e) for e in study.conditions.get(name="exact").env_ids]})
    simulate(one, n_per_condition=3, seed=1, learner=SimulatedLearner("det-euclidean", 1.0, 0.1))
    with pytest.raises(CommandError, match="one condition"):
        run(one.slug)
    simulate(study, n_per_condition=5, seed=4, learner=SimulatedLearner("det-euclidean", 1.0, 1.0))  # guessers
    with pytest.raises(CommandError, match="better than guessing"):
        run(study.slug)
    with pytest.raises(CommandError, match="unknown learner model 'bogus'"):
        run(study.slug, "--models", "det-euclidean,bogus")


def test_a_study_whose_table_is_gone_says_so(demo_table):
    study = make_study(demo_table, "fit-gone")
    study.source = {**study.source, "table": "/nonexistent/table"}
    study.save()
    with pytest.raises(ModelFitError, match="trajectory table cannot be read: no trajectory table at"):
        fit_study(study)


# --- the analysis page's panel and CSV --------------------------------------------------------------------
def test_the_panel_ranks_the_models_and_serves_the_csv(demo_table, det_euclidean_study, staff_client):
    from django.urls import reverse  # noqa: PLC0415

    empty = staff_client.get(reverse("dashboard_models", args=[make_study(demo_table, "fit-panel").slug]))
    assert empty.status_code == 200
    assert b"No model fit: no participant has finished this study yet" in empty.content
    study = det_euclidean_study
    url = reverse("dashboard_models", args=[study.slug])
    page = staff_client.get(url)
    html = page.content.decode()
    assert page.status_code == 200 and 'id="model-fit-table"' in html
    assert html.index("<td>det-euclidean</td>") < html.index("<td>exact</td>")  # ranked: the generator first
    assert "data:image/png;base64," in html and "Download the table (CSV)" in html
    again = staff_client.get(url, HTTP_IF_NONE_MATCH=page["ETag"])
    assert again.status_code == 304  # nothing new: not fitted again
    csv_response = staff_client.get(reverse("dashboard_models_csv", args=[study.slug]))
    assert csv_response.status_code == 200 and csv_response["Content-Type"].startswith("text/csv")
    assert "no-store" in csv_response["Cache-Control"]
    rows = list(csv.DictReader(io.StringIO(csv_response.content.decode())))
    assert rows[0]["model"] == "det-euclidean"
    # the analysis page loads the panel from that URL
    analysis = staff_client.get(reverse("dashboard_analysis", args=[study.slug])).content.decode()
    assert f'data-url="{url}"' in analysis


def test_tied_models_are_reported_tied_in_the_command_the_csv_and_the_panel(demo_table, tmp_path, staff_client):
    """Exact-IRL learners through the real flow: the models that predict their answers alike (held-out
    log-likelihoods within 1e-6) share rank 1 and name each other wherever the ranking is shown, and the
    exceedance probability is flagged as split among them."""
    from django.core.cache import cache  # noqa: PLC0415
    from django.urls import reverse  # noqa: PLC0415

    study = make_study(demo_table, "fit-ties")
    simulate(study, n_per_condition=6, seed=2, learner=SimulatedLearner("exact", None, 0.1))
    out = run(study.slug, "--csv", str(tmp_path / "m.csv"), "--figure", str(tmp_path / "m.png"))
    rows = list(csv.DictReader((tmp_path / "m.csv").open()))
    top = [r for r in rows if r["rank"] == "1"]
    assert len(top) >= 2, out
    names = {r["model"] for r in top}
    assert "exact" in names
    lines = out.splitlines()
    for r in top:
        assert set(r["tied_with"].split("; ")) == names - {r["model"]}
        assert float(r["tie_exceedance"]) == pytest.approx(sum(float(t["exceedance"]) for t in top), abs=1e-5)
        line = next(x for x in lines if x.startswith(r["model"] + " "))
        assert "tied with " + ", ".join(n for n in (t["model"] for t in top) if n != r["model"]) in line, line
        assert f"{float(r['exceedance']):.3f}*" in line
    assert "the exceedance probability is split among tied models" in out
    assert rows[len(top)]["rank"] == str(len(top) + 1) and rows[len(top)]["tied_with"] == ""
    # the panel is cached under the study's response counts and pk; a rolled-back test's study of the same
    # size (SQLite reuses its pk) would otherwise be served from the cache
    cache.clear()
    html = staff_client.get(reverse("dashboard_models", args=[study.slug])).content.decode()
    cells = {seg.split("<td>")[2].split("</td>")[0]: seg for seg in html.split("<tr")[1:] if "<td>" in seg}
    for name in names:
        row = cells[name]
        assert "<td>1</td>" in row and "tied with " in row, row
        assert all(other in row for other in names - {name})
    assert "the exceedance probability (*) is split among them" in html
    assert "Best: <strong>" in html and ", tied with <strong>" in html


def test_the_panel_is_for_researchers_only(demo_table, client):
    from django.urls import reverse  # noqa: PLC0415

    study = make_study(demo_table, "fit-private")
    for name in ("dashboard_models", "dashboard_models_csv"):
        response = client.get(reverse(name, args=[study.slug]))
        assert response.status_code in (302, 403)


def test_a_csv_of_an_unfittable_study_says_why(demo_table, staff_client):
    from django.urls import reverse  # noqa: PLC0415

    study = make_study(demo_table, "fit-nocsv")
    response = staff_client.get(reverse("dashboard_models_csv", args=[study.slug]))
    assert response.status_code == 409 and b"no participant has finished" in response.content


def test_a_study_with_the_hierarchical_condition_is_analysed_and_fitted(demo_table, tmp_path):
    """The condition a study may add (the hierarchical learner's greedy sequence): answered by hierarchical
    learners through the real flow, `analyze` reports it as a group of its own and `fit_models` ranks the
    hierarchical learner first."""
    table = TrajectoryTable.load(demo_table)
    ids = table.env_ids
    whole = teach(table)
    sequences = {c: [int(ids[e]) for e in whole.sequences[c].envs] for c in ("exact", "random", "hierarchical")}
    study = make_study(demo_table, "fit-hier", sequences=sequences)
    simulate(study, n_per_condition=20, seed=7,
             learner=SimulatedLearner("hierarchical", whole.models["hierarchical"].value, 0.1))
    out = io.StringIO()
    call_command("analyze", study.slug, "--out", str(tmp_path / "report"), stdout=out)
    conditions = (tmp_path / "report" / "conditions.csv").read_text()
    assert conditions.count("\nhierarchical,") == 1, conditions
    first = run(study.slug, "--csv", str(tmp_path / "m.csv"), "--figure", str(tmp_path / "m.png")).splitlines()[2]
    assert first.startswith("hierarchical"), first
