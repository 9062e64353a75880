"""What a researcher reads of a study speaks of its own robot: for a study of every registered domain,
its report names that domain's strategy clusters (and pairs them by its classes, not by the car's
``c ^ 1``), and its data dictionary describes that domain's environments and choice."""
from __future__ import annotations

import csv
import html
import io
import re

import pandas as pd
import pytest
from django.core.management import call_command

from studyapp.analysis import data as D
from studyapp.analysis import figures as F
from studyapp.analysis import stats as S
from studyapp.data import exports
from studyapp.participant import assignment
from studyapp.researcher.studies import build_study
from teaching.core.build import build_table
from teaching.core.domain import domain_names, get_domain, siblings
from teaching.core.table import TrajectoryTable
from tests.conftest import built_once, complete_flow
from tests.studyapp.test_stimuli import real_spec, smallest_preset

CAR_WORDS = re.compile(r"\b(cars?|driv\w*|lanes?|highway|road|merg\w*|brak\w*|tailgat\w*)\b")


@pytest.fixture(params=domain_names())
def domain_study(request, db, tmp_path_factory):
    """A study of the domain on its smallest table (two conditions, four tests), with four participants
    who finished it."""
    domain = get_domain(request.param)
    preset = smallest_preset(domain)
    out = built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))
    study = build_study(real_spec(TrajectoryTable.load(out), out, slug=f"words-{domain.name}"))
    for k in range(4):
        complete_flow(assignment.assign(study, "anonymous", f"w{k}"))
    return study, domain


def others_words(domain) -> set[str]:
    """Cluster names of the other registered domains that this one does not use too."""
    return {n for name in domain_names() if name != domain.name for n in get_domain(name).cluster_names[:-1]
            } - set(domain.cluster_names)


def test_a_studys_report_names_its_own_domains_clusters(domain_study, tmp_path):
    study, domain = domain_study
    if study.test_kind == "show":  # a world that shows the way: its report is of regrets, per test cluster
        call_command("analyze", study.slug, "--out", str(tmp_path), stdout=io.StringIO())
        page = (tmp_path / "index.html").read_text()
        for test in study.test_set:  # the per-test table's cluster cells
            assert f"<td>{html.escape(domain.cluster_names[test['cluster']])}</td>" in page, test["cluster"]
        for name in others_words(domain):  # a whole cell ("other: deliver" is a prefix of the taxi's "other")
            assert f">{html.escape(name)}<" not in page, name
        return
    analysis = D.analyze_study(study)
    assert analysis.clusters == S.Clusters.of(domain)
    assert list(analysis.examples_per_cluster.columns) == list(range(len(domain.class_of_cluster)))
    call_command("analyze", study.slug, "--out", str(tmp_path), stdout=io.StringIO())
    page = (tmp_path / "index.html").read_text()
    for name in domain.cluster_names[:-1]:
        assert html.escape(name) in page, name
    for name in others_words(domain):
        assert html.escape(name) not in page, name
    figure = F.examples_figure(analysis)
    ticks = [t.get_text() for t in figure.axes[0].get_xticklabels()]
    assert ticks == list(domain.cluster_names[:-1])
    # a white line between two classes, wherever the domain's classes change (not every second cluster)
    lines = sorted(line.get_xdata()[0] for line in figure.axes[0].lines)
    changes = [k - 0.5 for k in range(1, len(domain.class_of_cluster))
               if domain.class_of_cluster[k] != domain.class_of_cluster[k - 1]]
    assert lines == changes


def test_a_gridworld_studys_report_does_not_speak_of_the_car(db, tmp_path_factory, tmp_path):
    domain = get_domain("gridworld")
    preset = smallest_preset(domain)
    out = built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))
    study = build_study(real_spec(TrajectoryTable.load(out), out, slug="yard-report"))
    for k in range(2):
        complete_flow(assignment.assign(study, "anonymous", f"y{k}"))
    call_command("analyze", study.slug, "--out", str(tmp_path), stdout=io.StringIO())
    page = (tmp_path / "index.html").read_text()
    assert "mud: through the mud" in page and "dog: around the dog" in page
    assert not CAR_WORDS.search(page.lower()), CAR_WORDS.search(page.lower())


@pytest.mark.parametrize("name", domain_names())
def test_siblings_are_the_domains(name):
    domain = get_domain(name)
    clusters = S.Clusters.of(domain)
    assert clusters.names == tuple(domain.cluster_names) and clusters.n == len(domain.class_of_cluster)
    for c in range(clusters.n):
        assert clusters.siblings(c) == tuple(int(k) for k in siblings(domain, c)), c


def test_helpful_examples_count_every_sibling_of_the_tests_class():
    """x = examples in the test's cluster; else -(examples in the other clusters of its class), however
    many its class has; a cluster alone in its class has none (the car's c ^ 1 looked at the next one)."""
    clusters = S.Clusters(names=("a1", "a2", "a3", "b1", "alone", "none"), class_of_cluster=(0, 0, 0, 1, 2))
    training = pd.DataFrame({"condition": ["x"] * 5, "position": range(5), "environment_id": range(5),
                             "cluster": [1, 2, 2, 3, 3]})
    counts = S.examples_per_cluster(training, clusters=clusters)
    assert list(counts.columns) == [0, 1, 2, 3, 4]
    assert [S.helpful_examples(counts, "x", t, clusters) for t in range(5)] == [-3, 1, 2, 2, 0]
    assert S.helpful_examples(counts, "y", 0, clusters) == 0  # a condition without examples


def test_the_yards_other_cluster_has_no_sibling():
    clusters = S.Clusters.of(get_domain("gridworld"))
    other = clusters.names.index("other: deliver")
    assert clusters.siblings(other) == () and other ^ 1 == clusters.n  # c ^ 1 would be "no strategy"


def dictionary(text: str) -> dict:
    return {(r["file"], r["column"]): r["description"] for r in csv.DictReader(io.StringIO(text))}


def test_a_studys_data_dictionary_describes_its_own_domain(domain_study, staff_client):
    study, domain = domain_study
    response = staff_client.get(f"/dashboard/{study.slug}/export/dictionary.csv")
    assert response.status_code == 200
    d = dictionary(response.content.decode())
    env = d[("long", "env_id")]
    assert domain.name in env and f"{domain.n_environments:,}" in env
    assert all(c in env for c in domain.class_names), env
    assert all(other not in env for other in domain_names() if other != domain.name), env
    if study.test_kind == "show":  # the way shown and its regret, not a choice
        assert "moves" in d[("long", "moves")] and "theta*" in d[("long", "regret")]
    else:
        assert domain.texts.question in d[("long", "chosen_option")]
        assert domain.texts.option in d[("long", "chosen_option")]
    right = [label for value, label in domain.texts.attention_choices if value in domain.texts.attention_correct]
    assert all(label in d[("wide", "attention_passed")] for label in right)
    # the command writes the same file
    out = io.StringIO()
    call_command("export_study", study.slug, "dictionary", stdout=out)
    assert dictionary(out.getvalue()) == d


def test_a_gridworld_data_dictionary_describes_the_yards(db, tmp_path_factory):
    domain = get_domain("gridworld")
    preset = smallest_preset(domain)
    out = built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))
    study = build_study(real_spec(TrajectoryTable.load(out), out, slug="yard-dictionary"))
    d = dictionary(exports.dictionary_csv(study))
    assert d[("long", "env_id")].startswith("Environment id: one of the 17,460 environments of the gridworld domain "
                                            "(teaching.domains.gridworld), 0 .. 17459, each of one class (mud, dog, "
                                            "cart, other)")
    assert "delivery" in d[("long", "chosen_option")]
    assert "Carried a parcel to the drop-off D" in d[("wide", "attention_passed")]
    for description in d.values():
        assert not CAR_WORDS.search(description.lower()), description


def test_the_dictionary_without_a_study_names_no_robot():
    for description in dictionary(exports.dictionary_csv()).values():
        assert not CAR_WORDS.search(description.lower()), description
        assert "gridworld" not in description


def test_the_driving_study_keeps_its_words():
    """The car's texts are the driving domain's own, as participants read them before."""
    texts = get_domain("driving").texts
    assert texts.choice_required == "Please choose the option that matches the car's driving style."
    assert texts.question == "Which drive matches the autonomous car's driving style?"
    clusters = S.Clusters.of(get_domain("driving"))
    assert all(clusters.siblings(c) == (c ^ 1,) for c in range(8))  # its pairs 2k, 2k + 1, as before
