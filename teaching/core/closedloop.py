"""Closed-loop teaching: each participant's next example chosen from their answers (docs/decisions.md).

The robot keeps, for each participant, a belief b(θ) over the θ the participant takes the robot to
have: their hypothesis.  It starts uniform over the table's thetas and is updated

* by every example shown in environment E (a training example, or the feedback after a check, which
  shows θ*'s trajectory in the check's environment), with the learner model's own likelihood, tempered
  by the chance η (``example_lapse``) that the participant did not take the example in:

      b(θ) ← b(θ) · ((1 − η) L_M(E, θ) + η),   L_M(E, θ) = P_M(ξ^{θ*}_E | θ)

  With η = 0 and no checks, b is the model's posterior P_M(θ | S) and the closed loop shows exactly the
  open-loop greedy sequence of selection.greedy (tests/teaching/core/test_closedloop.py).  With η > 0 no
  example rules a θ out for good, so a wrong check answer can bring back the θ it points to: under a
  deterministic model and η = 0 every θ but the few the examples left is gone, a wrong answer reads as
  a lapse, and the loop never changes course (docs/results.md, bench/closedloop.py);
* by every check answer k in environment E with options ξ_1..ξ_K, with the choice model
  (teaching.core.choice) of a learner certain of θ:

      b(θ) ← b(θ) · P(k | θ, E),   P(k | θ, E) = (1 − ε) · L_k(θ) / Σ_j L_j(θ) + ε / K

  where L_k(θ) = P_M(ξ_k | θ, E), and a guess (1 / K) when no option fits θ.  The lapse rate ε must be
  above 0: a careless answer may not rule a θ out for good.  A check where the participant shows the
  way (``Question.shown``) is a choice among every distinct trajectory the table's θ take in E (a finite
  stand-in for every way, as SCOT's alternatives are); a way none of them takes (answer K) leaves b as
  it is: it says nothing about which of the table's θ the participant holds.

The next example is the environment E that maximises the participant's P(θ*) once they have seen it,
in expectation under b:  b'(θ*) = b(θ*) L'(E, θ*) / Σ_θ b(θ) L'(E, θ), L' = (1 − η) L + η  —
selection.greedy's step, taken on b (lowest table row on ties, repeats allowed, only ``eligible``
environments).

The steps: examples; after every ``check_every`` examples a check question (the next of the reserved
ones, while any are left), then, with feedback on, θ*'s trajectory in that check's environment; done
after ``max_examples`` examples, once b(θ*) reaches ``stop_at``, or when no example raises it.
:meth:`ClosedLoop.decide` is a pure function of a participant's events so far, so every stored decision
can be recomputed from the stored answers alone (:meth:`ClosedLoop.replay`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from .answers import Question, questions_of
from .choice import OptionDistances, option_choice
from .learners import Distances, LearnerModel, check_value, make_model, posterior
from .selection import APPROX_STAR, IMPROVEMENT_RTOL, _candidate_p, showable
from .showtests import is_show, select_show_tests
from .testset import TestSetError, select_test_set

EXAMPLE, CHECK, FEEDBACK, DONE = "example", "check", "feedback", "done"
EVENT_KINDS = (EXAMPLE, CHECK, FEEDBACK)
TOP = 5  # hypotheses and candidate examples kept in each decision's record
MAX_EXAMPLES_LIMIT = 30


class ClosedLoopError(ValueError):
    """A closed-loop specification or a participant's events that cannot be used; one line."""


@dataclass(frozen=True)
class ClosedLoopSpec:
    """How a closed-loop condition teaches: the learner model the robot assumes (its τ / λ, None for the
    model's default), the lapse rate ε of check answers and η of examples (the chance one was not taken
    in); at most ``max_examples`` examples; a check
    after every ``check_every`` examples (0: none); feedback after each check; stop early once the
    participant's P(θ*) reaches ``stop_at`` (1: never early)."""

    model: str = APPROX_STAR
    value: float | None = None
    lapse: float = 0.1
    example_lapse: float = 0.1
    max_examples: int = 6
    check_every: int = 2
    feedback: bool = True
    stop_at: float = 1.0

    def __post_init__(self):
        try:
            make_model(self.model, self.value)
            if self.value is not None:
                check_value(self.model, self.value)
        except (KeyError, ValueError) as exc:
            raise ClosedLoopError(str(exc).strip("'\"")) from None
        if not 0 < self.lapse <= 1:
            raise ClosedLoopError(f"the lapse rate must lie in (0, 1], got {self.lapse} (0 would let one careless "
                                  f"answer rule a θ out for good)")
        if not 0 <= self.example_lapse < 1:
            raise ClosedLoopError(f"the example lapse rate must lie in [0, 1), got {self.example_lapse}")
        if not (isinstance(self.max_examples, int) and 1 <= self.max_examples <= MAX_EXAMPLES_LIMIT):
            raise ClosedLoopError(f"max_examples must be a whole number from 1 to {MAX_EXAMPLES_LIMIT}, "
                                  f"got {self.max_examples!r}")
        if not (isinstance(self.check_every, int) and 0 <= self.check_every <= self.max_examples):
            raise ClosedLoopError(f"check_every must be a whole number from 0 (no checks) to max_examples "
                                  f"({self.max_examples}), got {self.check_every!r}")
        if not 0 < self.stop_at <= 1:
            raise ClosedLoopError(f"stop_at must lie in (0, 1], got {self.stop_at}")

    @property
    def learner_model(self) -> LearnerModel:
        return make_model(self.model, self.value)

    def as_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> ClosedLoopSpec:
        unknown = set(data) - {f.name for f in fields(cls)}
        if unknown:
            raise ClosedLoopError(f"unknown closed-loop setting(s): {', '.join(sorted(unknown))}")
        return cls(**data)


@dataclass(frozen=True)
class Event:
    """What a participant was shown or answered, in order: an example or feedback in a table row, or
    the option they chose (0..K-1) in check question ``question``."""

    kind: str
    env_index: int
    question: int | None = None
    answer: int | None = None

    def as_dict(self) -> dict:
        return {k: v for k, v in asdict(self).items() if v is not None}

    @classmethod
    def from_dict(cls, data: dict) -> Event:
        return cls(**data)


@dataclass(frozen=True)
class Decision:
    """What the robot decided for step ``step`` and what it was based on: its belief's P(θ*), entropy
    (bits) and most likely hypotheses (θ index, probability), and for an example the best candidates
    (table row, P(θ*) after it)."""

    step: int
    kind: str
    env_index: int | None
    question: int | None
    reason: str
    p_theta_star: float
    entropy_bits: float
    top_thetas: tuple[tuple[int, float], ...]
    candidates: tuple[tuple[int, float], ...] = ()

    def as_dict(self) -> dict:
        d = asdict(self)
        d["top_thetas"] = [list(t) for t in self.top_thetas]
        d["candidates"] = [list(c) for c in self.candidates]
        return d

    @classmethod
    def from_dict(cls, data: dict) -> Decision:
        data = dict(data)
        data["top_thetas"] = tuple((int(t), float(p)) for t, p in data.get("top_thetas", ()))
        data["candidates"] = tuple((int(e), float(p)) for e, p in data.get("candidates", ()))
        return cls(**data)


def answer_likelihood(option_likelihood: np.ndarray, lapse: float) -> np.ndarray:
    """(K, N) P(k | θ_n, E): the choice model for a learner certain of θ_n, from (K, N) L_k(θ_n)."""
    lik = np.asarray(option_likelihood, np.float64)
    k = lik.shape[0]
    total = lik.sum(0)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = (1.0 - lapse) * lik / total + lapse / k
    return np.where(total > 0, p, 1.0 / k)


def answer_rows(p: np.ndarray, question) -> np.ndarray:
    """The (K, N) P(k | θ, E) of `question`'s options, and for a shown check a last row of ones: a way no
    θ of the table takes leaves the belief as it is."""
    if not getattr(question, "shown", False):
        return p
    return np.vstack([p, np.ones((1, p.shape[1]), p.dtype)])


def distinct_ways(table, env_index: int) -> tuple[int, ...]:
    """The lowest θ index of each distinct trajectory the table's θ take in table row `env_index`, in θ
    order (θ* first): a shown check's options."""
    controls = np.asarray(table.controls[env_index]).reshape(table.n_thetas, -1)
    _, first = np.unique(controls, axis=0, return_index=True)
    return tuple(int(t) for t in np.sort(first))


class ClosedLoop:
    """One closed-loop condition on one table.

    lik: (M, N) float32 L_M(E, θ) for every table row (a read-only memory map serves many processes);
    checks: the reserved check Questions, asked in order; check_lik: (K, N) P(k | θ, E) of each;
    eligible: (M,) bool, the rows examples may come from.
    """

    def __init__(self, spec: ClosedLoopSpec, lik: np.ndarray, checks, check_lik, eligible: np.ndarray):
        self.spec, self.lik = spec, lik
        self.checks = tuple(checks)
        self.check_lik = [np.asarray(c, np.float32) for c in check_lik]
        self.eligible = np.asarray(eligible, bool)
        if self.eligible.shape != (lik.shape[0],):
            raise ClosedLoopError(f"eligible must have one entry per table row ({lik.shape[0]})")

    @classmethod
    def build(cls, table, spec: ClosedLoopSpec, checks, exclude=(), dist: Distances | None = None,
              lik: np.ndarray | None = None) -> ClosedLoop:
        """The condition on `table`: examples from showable rows other than the check questions' and
        `exclude` (table rows: the study's final tests); `lik` if it was computed before."""
        model = spec.learner_model
        if lik is None:
            lik = model.likelihood(dist or Distances(table))
        checks = tuple(checks)
        check_lik = [answer_rows(answer_likelihood(model.likelihood(OptionDistances(table, q.env_index, q.options)),
                                                   spec.lapse), q) for q in checks]
        eligible = showable(table).copy()
        eligible[[q.env_index for q in checks]] = False
        eligible[np.asarray(list(exclude), np.int64)] = False
        return cls(spec, lik, checks, check_lik, eligible)

    # --- the belief -------------------------------------------------------------------------------
    def weights(self, events) -> np.ndarray:
        """(N,) float32 b(θ) up to a factor (largest 1), after `events` (the module's updates)."""
        w = np.ones(self.lik.shape[1], np.float32)
        eta = self.spec.example_lapse
        for e in events:
            if e.kind == CHECK:
                w *= self.check_lik[e.question][e.answer]
            elif eta:
                w *= np.float32(1 - eta) * self.lik[e.env_index] + np.float32(eta)
            else:
                w *= self.lik[e.env_index]
            w /= w.max()  # as selection.greedy: away from float32 underflow; b is scale-free
        return w

    def _check_events(self, events) -> None:
        for i, e in enumerate(events):
            if e.kind not in EVENT_KINDS:
                raise ClosedLoopError(f"event {i}: unknown kind {e.kind!r}")
            if not 0 <= e.env_index < self.lik.shape[0]:
                raise ClosedLoopError(f"event {i}: table row {e.env_index} is not in the table")
            if e.kind == CHECK:
                if e.question is None or not 0 <= e.question < len(self.checks):
                    raise ClosedLoopError(f"event {i}: no check question {e.question!r}")
                if e.answer is None or not 0 <= e.answer < len(self.check_lik[e.question]):
                    raise ClosedLoopError(f"event {i}: answer {e.answer!r} is not an option of check {e.question}")

    # --- the decision -----------------------------------------------------------------------------
    def decide(self, events) -> Decision:
        """The next step after `events` (a participant's, in order): the module's rules."""
        events = list(events)
        self._check_events(events)
        spec, step = self.spec, len(events)
        w = self.weights(events)
        b = w.astype(np.float64) / w.sum()
        top = np.argsort(-b, kind="stable")[:TOP]
        nz = b[b > 0]
        base = dict(step=step, p_theta_star=float(b[0]), entropy_bits=float(-(nz * np.log2(nz)).sum()),
                    top_thetas=tuple((int(t), float(b[t])) for t in top))
        n_examples = sum(e.kind == EXAMPLE for e in events)
        n_checks = sum(e.kind == CHECK for e in events)
        since_check = 0
        for e in reversed(events):
            if e.kind == CHECK:
                break
            since_check += e.kind == EXAMPLE
        if events and events[-1].kind == CHECK and spec.feedback:
            return Decision(kind=FEEDBACK, env_index=events[-1].env_index, question=events[-1].question,
                            reason=f"feedback on check {events[-1].question + 1}", **base)
        if spec.check_every and since_check >= spec.check_every and n_checks < len(self.checks):
            return Decision(kind=CHECK, env_index=self.checks[n_checks].env_index, question=n_checks,
                            reason=f"a check after every {spec.check_every} examples", **base)
        if n_examples >= spec.max_examples:
            return Decision(kind=DONE, env_index=None, question=None, reason=f"{spec.max_examples} examples shown",
                            **base)
        if b[0] >= spec.stop_at:
            return Decision(kind=DONE, env_index=None, question=None,
                            reason=f"P(θ*) {b[0]:.3f} reached {spec.stop_at:g}", **base)
        p = self._candidate_p(w)
        p[~self.eligible] = -1.0
        best = int(np.argmax(p))
        p_now = float(w[0] / w.sum(dtype=np.float32))
        if p[best] <= p_now * (1 + IMPROVEMENT_RTOL):
            return Decision(kind=DONE, env_index=None, question=None, reason="no example raises P(θ*)", **base)
        order = np.argsort(-p, kind="stable")[:TOP]
        order = order[p[order] >= 0]  # ineligible rows (-1) sort last: only when fewer than TOP may be shown
        return Decision(kind=EXAMPLE, env_index=best, question=None,
                        reason=f"P(θ*) {p_now:.3f} -> {float(p[best]):.3f}",
                        candidates=tuple((int(e), float(p[e])) for e in order), **base)

    def _candidate_p(self, w: np.ndarray) -> np.ndarray:
        """(M,) b'(θ*) after each environment, for weights w (N,): with η, from L·w and Σ w, without the
        (M, N) tempered matrix (85 MB at paper size, per decision)."""
        eta = self.spec.example_lapse
        if not eta:
            return _candidate_p(self.lik, w)  # exactly selection.greedy's arithmetic
        score = np.float32(1 - eta) * (self.lik @ w) + np.float32(eta) * w.sum(dtype=np.float32)
        num = (np.float32(1 - eta) * self.lik[:, 0] + np.float32(eta)) * w[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(score > 0, num / score, 0.0)

    def replay(self, events, decisions) -> list[str]:
        """Recompute every stored decision from the stored events alone: a line per disagreement
        (none when the study replays), including an event that is not what its decision asked for."""
        events, decisions = list(events), list(decisions)
        problems = []
        for s, stored in enumerate(decisions):
            again = self.decide(events[:s])
            if again != stored:
                problems.append(f"step {s}: stored {stored.kind} {stored.env_index}, recomputed {again.kind} "
                                f"{again.env_index} ({again.reason})")
            if s < len(events) and (events[s].kind, events[s].env_index) != (stored.kind, stored.env_index):
                problems.append(f"step {s}: the participant's event {events[s].kind} {events[s].env_index} is not "
                                f"the decision {stored.kind} {stored.env_index}")
        return problems


def select_checks(table, final_tests: list[dict], seed: int = 1) -> list[dict]:
    """Check questions, stored as a test set is: one per test cluster where the environments the final
    tests leave over allow one (the final tests stay the same for every condition of a study)."""
    checks = select_test_set(table, [[t["env_id"] for t in final_tests]], seed=seed, skip_missing=True)
    if not checks:
        raise ClosedLoopError("no environment left over from the final tests can be a check question")
    return checks


def select_show_checks(table, final_tests: list[dict], seed: int = 1) -> list[dict]:
    """Check questions where the participant shows the way (showtests.select_show_tests' dicts, each with
    ``ways``: its options, distinct_ways), on environments apart from the final tests."""
    try:
        checks = select_show_tests(table, [[int(t["env_id"]) for t in final_tests]], seed=seed)
    except TestSetError:
        raise ClosedLoopError("no environment left over from the final tests can be a check question") from None
    return [{**c, "ways": list(distinct_ways(table, table.row_of[int(c["env_id"])]))} for c in checks]


def check_questions(table, test_set) -> tuple[Question, ...]:
    """The Questions of check questions stored as a test set is (dicts with env_id and options), or as
    select_show_checks gives them (kind "show", with ways)."""
    if test_set and all(is_show(t) for t in test_set):
        return tuple(Question(table.row_of[int(t["env_id"])], tuple(int(w) for w in t["ways"]), shown=True)
                     for t in test_set)
    return questions_of(table, test_set)[0]


def run_learner(loop: ClosedLoop, table, learner, rng: np.random.Generator,
                dist: Distances | None = None) -> tuple[list[Event], list[Decision]]:
    """One simulated participant through the closed loop: `learner` (simulate.SimulatedLearner, the
    model the participant really learns by, which need not be the robot's) believes P(θ | everything
    shown) and answers each check by the choice model.  Returns their events and the decisions."""
    dist = dist or Distances(table)
    model = learner.learner_model
    events, decisions, shown = [], [], []
    while True:
        d = loop.decide(events)
        decisions.append(d)
        if d.kind == DONE:
            return events, decisions
        if d.kind == CHECK:
            q = loop.checks[d.question]
            p = option_choice(model, posterior(model, dist, shown), table, q.env_index, q.options, learner.lapse)
            events.append(Event(CHECK, q.env_index, d.question, int(rng.choice(len(p), p=p / p.sum()))))
        else:
            events.append(Event(d.kind, d.env_index))
            shown.append(d.env_index)
