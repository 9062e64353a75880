"""Which learner model explains a study's answers (docs/analysis.md "Fitting learner models").

Reads the study's design (each condition's training examples and the test set, as table rows and θ
indices of the trajectory table the study was built from) and its analysed participants' answers (status
complete: finished and attentive, as the rest of the analysis), and fits every learner model with
``teaching.api.compare_models``.  The result carries the models' table (ranked by cross-validated
log-likelihood, with ΔBIC and exceedance probabilities) and, per condition and test, the accuracy the best
models predict beside the accuracy observed.  Errors a researcher can meet are :class:`ModelFitError`,
one line each.
"""
from __future__ import annotations

import csv
import io
from dataclasses import dataclass

import numpy as np
from django.db.models import Q

from teaching.api import (
    Answers,
    Comparison,
    FitError,
    Question,
    TableError,
    TrajectoryTable,
    compare_models,
    questions_of,
)

from ..models import Answer, Condition, LoopStep, Participant, StepKind, Study

# rank: equal for models whose cross-validated log-likelihoods tie (teaching.core.fitting.tie_ranks);
# tied_with: their labels, "; "-separated; tie_exceedance: the exceedance of the model and those together
CSV_COLUMNS = ["model", "param", "value", "lapse", "log_lik", "cv_log_lik", "aic", "bic", "delta_bic", "frequency",
               "exceedance", "protected_exceedance", "rating_rho", "n_answers", "rank", "tied_with", "tie_exceedance"]


class ModelFitError(ValueError):
    """Why a study's answers cannot be fitted, in one line."""


@dataclass
class StudyDesign:
    """A study's design on its table: sequences {condition: table rows} of its open-loop conditions, tests
    (Questions, the study's option order), star (T,) the option index of θ*'s trajectory in each test,
    clusters (T,) each test's cluster (θ*'s strategy there), loops: its closed-loop conditions (each
    participant's sequence their own: study_answers)."""

    table: TrajectoryTable
    sequences: dict[str, tuple[int, ...]]
    tests: tuple[Question, ...]
    star: np.ndarray
    clusters: list
    loops: tuple[str, ...] = ()


def study_table(study: Study) -> TrajectoryTable:
    """The table `study` was built from (its recorded path and content hash); ModelFitError if gone."""
    source = study.source or {}
    if source.get("kind") != "table" or not source.get("table"):
        raise ModelFitError("this study's trajectories do not come from a trajectory table: there is no model to fit")
    try:
        return TrajectoryTable.load(source["table"], verify=False, expected_hash=source.get("content_hash"))
    except TableError as exc:
        raise ModelFitError(f"the study's trajectory table cannot be read: {exc}") from None


SHOW_NOT_FITTED = ("this study's tests ask participants to show the way, not to choose among options: the "
                   "learner models are fitted to choices, so there is nothing to fit")


def study_design(study: Study, table: TrajectoryTable | None = None) -> StudyDesign:
    if study.test_kind == Study.SHOW:  # before the table: a show study's own reason, not a table's
        raise ModelFitError(SHOW_NOT_FITTED)
    table = table or study_table(study)
    row = table.row_of
    conditions = list(Condition.objects.filter(study=study).order_by("position", "pk"))
    try:
        sequences = {c.name: tuple(row[int(e)] for e in c.env_ids) for c in conditions if not c.closed_loop}
        tests, star = questions_of(table, study.test_set or [])
    except KeyError as exc:
        raise ModelFitError(f"environment {exc} of this study is not in its trajectory table") from None
    return StudyDesign(table, sequences, tests, star, [t.get("cluster") for t in study.test_set or []],
                       loops=tuple(c.name for c in conditions if c.closed_loop))


def loop_paths(design: StudyDesign, people: list[tuple[int, str]]) -> dict[int, tuple[int, ...]]:
    """{participant id: the table rows their closed loop showed them (examples and feedback, in order)} for
    those of `people` ((id, condition)) in a closed-loop condition: one query."""
    ids = [pk for pk, c in people if c in design.loops]
    row = design.table.row_of
    paths = {pk: [] for pk in ids}
    steps = (LoopStep.objects.filter(participant_id__in=ids, kind__in=[LoopStep.EXAMPLE, LoopStep.FEEDBACK])
             .order_by("participant_id", "index").values_list("participant_id", "env_id"))
    for pk, env_id in steps:
        paths[pk].append(row[int(env_id)])
    return {pk: tuple(p) for pk, p in paths.items()}


def study_answers(study: Study, design: StudyDesign) -> tuple[Answers, dict[str, str]]:
    """The analysed participants' choices and ratings (complete: finished, attention check passed), and
    {sequence name: condition}.  A closed-loop condition's participants saw sequences of their own: each
    distinct one is a sequence of the Answers, named "<condition> path <k>"."""
    people = list(Participant.objects.filter(Participant.complete_filter(), study=study)
                  .order_by("pk").values_list("pk", "condition__name"))
    sequences = dict(design.sequences)
    condition_of = {n: n for n in sequences}
    of_path, seq_of = {}, {}  # (condition, rows) -> name; participant -> name
    condition_of_pk = dict(people)
    for pk, rows in loop_paths(design, people).items():
        condition = condition_of_pk[pk]
        if (condition, rows) not in of_path:
            name = f"{condition} path {sum(c == condition for c, _ in of_path) + 1}"
            of_path[(condition, rows)], sequences[name], condition_of[name] = name, rows, condition
        seq_of[pk] = of_path[(condition, rows)]
    names = tuple(sequences)
    index = {pk: i for i, (pk, _) in enumerate(people)}
    n_tests, k = len(design.tests), len(design.tests[0].options) if design.tests else 0
    choice = np.full((len(people), n_tests), -1, np.int64)
    ratings = np.full((len(people), n_tests, k), np.nan)
    rows = (Answer.objects.filter(Q(participant_id__in=list(index)), kind=StepKind.TEST)
            .values_list("participant_id", "item", "chosen_option", "data"))
    for pid, item, chosen, data in rows:
        if item is None or chosen is None or not 0 <= int(item) < n_tests:
            continue
        i, t = index[pid], int(item)
        choice[i, t] = int(chosen)
        given = (data or {}).get("ratings") or []
        if len(given) == k:
            ratings[i, t] = [float(r) for r in given]
    return Answers(sequence_names=names, sequences=tuple(sequences[n] for n in names), tests=design.tests,
                   group=np.array([names.index(seq_of.get(pk, c)) for pk, c in people], np.int64),
                   choice=choice, ratings=ratings,
                   participant_ids=tuple(str(pk) for pk, _ in people)), condition_of


@dataclass
class StudyFit:
    """A study's model comparison and, per condition × test, observed and predicted accuracy."""

    comparison: Comparison
    design: StudyDesign
    answers: Answers
    condition_of: dict[str, str]  # sequence name -> condition (a closed loop's paths -> the loop)

    def accuracy(self, n_models: int = 3) -> list[dict]:
        """One dict per condition × test: n (answers), observed share choosing θ*, and each of the best
        `n_models` models' predicted P(θ*'s option) at its pooled fit (a closed loop: averaged over its
        participants, each after their own path)."""
        out = []
        fits = self.comparison.fits[:n_models]
        names = self.answers.sequence_names
        for condition in dict.fromkeys(self.condition_of[n] for n in names):
            members = np.isin(self.answers.group, [s for s, n in enumerate(names) if self.condition_of[n] == condition])
            for t in range(len(self.design.tests)):
                answered = members & (self.answers.choice[:, t] >= 0)
                if not answered.any():
                    continue
                star, groups = self.design.star[t], self.answers.group[answered]
                correct = self.answers.choice[answered, t] == star
                out.append({"condition": condition, "test": t, "cluster": self.design.clusters[t],
                            "n": int(answered.sum()), "observed": float(correct.mean()),
                            "predicted": {f.label: float(f.predicted[groups, t, star].mean()) for f in fits}})
        return out

    def csv(self) -> str:
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=CSV_COLUMNS, lineterminator="\n")
        writer.writeheader()
        for row in self.comparison.rows():
            writer.writerow({k: _cell("; ".join(row[k]) if k == "tied_with" else row[k]) for k in CSV_COLUMNS})
        return buf.getvalue()


def _cell(v):
    if v is None or (isinstance(v, float) and np.isnan(v)):
        return ""
    return f"{v:.6g}" if isinstance(v, float) else v


def fit_study(study: Study, names=None) -> StudyFit:
    """Every learner model (or those in `names`) fitted to `study`'s analysed answers."""
    design = study_design(study)
    if not design.tests:
        raise ModelFitError("this study has no test set: there is nothing to fit")
    answers, condition_of = study_answers(study, design)
    if not (answers.choice >= 0).any():
        raise ModelFitError("no participant has finished this study yet (finished and passed the attention "
                            "check): there is nothing to fit")
    try:
        comparison = compare_models(design.table, answers, names)
    except (FitError, ValueError) as exc:
        raise ModelFitError(str(exc)) from None
    return StudyFit(comparison, design, answers, condition_of)


LAPSE_FLOOR = 0.01  # a closed loop needs ε > 0: one careless answer may not rule a θ out for good


def best_fit_settings(study: Study) -> dict:
    """The learner model, τ / λ and lapse rate ε of the model that best explains `study`'s answers (ranked by
    cross-validated log-likelihood), as closed-loop settings (model, value, lapse; ε at least LAPSE_FLOOR);
    ModelFitError (one line) when the study cannot be fitted."""
    best = fit_study(study).comparison.fits[0]
    return {"model": best.name, "value": float(best.value) if best.param and best.value is not None else None,
            "lapse": max(float(best.lapse), LAPSE_FLOOR)}


def accuracy_figure(fit: StudyFit, n_models: int = 3):
    """Predicted vs observed accuracy (share choosing θ*'s option), one point per condition × test (its
    area: the answers behind it), one panel per best model; the diagonal is a perfect prediction."""
    import matplotlib.pyplot as plt  # noqa: PLC0415  (matplotlib loads only for a figure)

    cells = fit.accuracy(n_models)
    labels = [f.label for f in fit.comparison.fits[:n_models]]
    fig, axes = plt.subplots(1, len(labels), figsize=(3.6 * len(labels), 3.6), squeeze=False, sharey=True)
    observed = np.array([c["observed"] for c in cells])
    size = np.array([c["n"] for c in cells], float)
    for ax, label in zip(axes[0], labels, strict=True):
        predicted = np.array([c["predicted"][label] for c in cells])
        ax.plot([0, 1], [0, 1], color="#999999", lw=1, ls="--", zorder=1)
        ax.scatter(predicted, observed, s=12 + 60 * size / max(size.max(), 1), color="#4c72b0", alpha=0.7,
                   edgecolor="white", zorder=2)
        r = np.corrcoef(predicted, observed)[0, 1] if len(cells) > 2 and np.ptp(predicted) > 0 else np.nan
        ax.set_title(f"{label}\nr = {r:.2f}" if np.isfinite(r) else label, fontsize=9)
        ax.set_xlim(-0.03, 1.03)
        ax.set_ylim(-0.03, 1.03)
        ax.set_xlabel("predicted P(θ*'s option)")
        ax.set_aspect("equal")
    axes[0][0].set_ylabel("observed share choosing θ*")
    fig.tight_layout()
    return fig
