"""How many participants per condition a study needs (studyapp/analysis/power.py).

    python manage.py power                         # the paper's effects, alpha .05, power .8
    python manage.py power --effect "my guess=0.4" --alpha 0.05 --power 0.9 --n 30
    python manage.py power --study SLUG            # the power at that study's target per condition
    python manage.py power --study SLUG --model det-euclidean --lapse 0.1
                                                   # and the effects that model's learners predict there
"""
from django.core.management.base import BaseCommand, CommandError

from studyapp.analysis.power import (
    ALPHA_MAX,
    ALPHA_MIN,
    D_MAX,
    D_MIN,
    POWER_MAX,
    effect_problem,
    input_problems,
    power_table,
)
from studyapp.models import Study
from studyapp.researcher.pilot import DEFAULT_LAPSE, model_effects, stored_predictions


def parse_effect(text: str) -> tuple[str, float]:
    name, sep, value = text.rpartition("=")
    try:
        d = float(value)
    except ValueError:
        d = None
    if not sep or not name.strip() or d is None:
        raise CommandError(f"--effect expects NAME=D with D a Cohen's d, got {text!r}")
    problem = effect_problem(d)
    if problem:
        raise CommandError(f"--effect {text}: {problem}")
    return name.strip(), d


class Command(BaseCommand):
    help = "Participants per condition needed to detect the paper's effects (and yours), Welch/t-test power."

    def add_arguments(self, parser):
        parser.add_argument("--alpha", type=float, default=0.05,
                            help=f"two-sided, {ALPHA_MIN:g} to {ALPHA_MAX:g} (default %(default)s)")
        parser.add_argument("--power", type=float, default=0.8,
                            help=f"above alpha, at most {POWER_MAX:g} (default %(default)s)")
        parser.add_argument("--effect", action="append", default=[], metavar="NAME=D",
                            help=f"another effect to plan for, as Cohen's d from {D_MIN:g} to {D_MAX:g} (repeatable)")
        parser.add_argument("--n", type=int, help="also print the power at this many participants per condition")
        parser.add_argument("--study", help="use this study's target per condition as --n")
        parser.add_argument("--model", help="with --study: add the effects this learner model predicts between "
                                            "the study's conditions (its simulated pilot)")
        parser.add_argument("--lapse", type=float, default=DEFAULT_LAPSE,
                            help="with --model: the learners' lapse rate, 0 to 1 (default %(default)s)")

    def handle(self, alpha, power, effect, n, study, model, lapse, **options):
        problems = input_problems(alpha=alpha, power=power)
        if problems:
            raise CommandError("; ".join(problems))
        effects = dict(parse_effect(e) for e in effect)
        if study:
            found = Study.objects.filter(slug=study).first()
            if found is None:
                raise CommandError(f"no study {study!r}")
            n = found.target_per_condition
        predicted = self.predicted(found if study else None, model, lapse)
        if n is not None and n < 2:
            raise CommandError(f"--n must be at least 2, got {n}")
        try:
            rows = power_table(alpha=alpha, power=power, n_per_condition=n, effects=effects, predicted=predicted)
        except ValueError as exc:
            raise CommandError(str(exc)) from None
        head = f"{'comparison':32s} {'d':>6s} {'needed':>7s}" + (f" {'power@' + str(n):>9s}" if n else "")
        self.stdout.write(f"two-sided t-test, alpha = {alpha:g}, power = {power:g}, equal groups "
                          "(participants per condition)")
        self.stdout.write(head)
        for r in rows:
            if r["needed"] is None:
                d = "—" if r["d"] is None else f"{r['d']:.3f}"
                self.stdout.write(f"{r['comparison']:32s} {d:>6s} {'—':>7s}   {r['source']} "
                                  "(no difference to plan for)")
                continue
            line = f"{r['comparison']:32s} {r['d']:6.3f} {r['needed']:7d}"
            if n:
                line += f" {r['power_at_n']:9.3f}"
            self.stdout.write(f"{line}   {r['source']}")

    @staticmethod
    def predicted(study, model, lapse) -> list[dict]:
        """The rows `model`'s learners predict in `study` (none without --model); one-line errors."""
        if model is None:
            return []
        if study is None:
            raise CommandError("--model needs --study: the predictions are a study's (its simulated pilot)")
        if not 0 <= lapse <= 1:
            raise CommandError(f"--lapse must lie between 0 and 1, got {lapse:g}")
        stored = stored_predictions(study)
        if stored is None:
            raise CommandError(f"study {study.slug!r} has no learner-model predictions: build it with the "
                               "designer (or manage.py build_study) or create it from a recent teach output")
        if model not in stored["choice"]:
            raise CommandError(f"--model {model!r}: choose from {', '.join(stored['choice'])}")
        return model_effects(stored, model, lapse)
