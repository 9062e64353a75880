"""Study, condition, participant, answer (DESIGN §7).

Longer than 400 lines because Django reads an app's models from one module, and each model keeps the
rules about its own rows (a study's opening problems, a participant's consent version) beside its fields.

A condition is frozen: its training environments (with the trajectories
needed to draw them) are stored as JSON, and the study holds the test set
shared by all of its conditions, so serving a study never needs the
trajectory table.
"""
from __future__ import annotations

import hashlib
import secrets
from datetime import timedelta
from decimal import Decimal
from pathlib import Path

from django.core.exceptions import ValidationError
from django.db import models
from django.urls import reverse
from django.utils import timezone

from . import status

PROLIFIC_COMPLETION_URL = "https://app.prolific.com/submissions/complete?cc={code}"
MTURK_SUBMIT_URL = "https://www.mturk.com/mturk/externalSubmit"


def new_token() -> str:
    return secrets.token_urlsafe(18)


def new_code() -> str:
    return secrets.token_hex(4).upper()


_VIEWS: dict[tuple, dict] = {}  # Study.scene_view, per study version


class Study(models.Model):
    slug = models.SlugField(unique=True)
    name = models.CharField(max_length=200)
    domain = models.CharField(
        max_length=40, default="driving", editable=False,
        help_text="The robot and world of its stimuli (a teaching domain): its table's, set when it is built.")
    is_open = models.BooleanField(default=True, help_text="Closed studies accept no new participants.")
    target_per_condition = models.PositiveIntegerField(default=30)
    active_timeout_minutes = models.PositiveIntegerField(
        default=30, help_text="An unfinished participant seen within this many minutes still holds a place.")
    completion_code = models.CharField(
        max_length=64, blank=True,
        help_text="Prolific's study completion code; blank gives each participant their own code.")
    # One code per way a participant's study can end (studyapp.participant.outcomes): Prolific takes several, each with
    # its own action (approve, review, pay a screen-out fee).  Blank: see outcomes.code_for.
    excluded_code = models.CharField(
        max_length=64, blank=True,
        help_text="The code of a participant who finished but failed the attention check; blank: the completion code.")
    screened_out_code = models.CharField(
        max_length=64, blank=True, help_text="The code of a participant screened out (the comprehension check).")
    timed_out_code = models.CharField(
        max_length=64, blank=True, help_text="The code of a participant who ran out of time.")
    # A performance bonus (studyapp.participant.bonuses): per correct test and per point of total confidence score,
    # capped.
    bonus_per_correct = models.DecimalField(
        max_digits=7, decimal_places=3, default=0,
        help_text="Bonus per test answered correctly (the study's currency); 0: none.")
    bonus_per_point = models.DecimalField(
        max_digits=7, decimal_places=3, default=0,
        help_text="Bonus per point of the total confidence score (tests that ask to choose; a total below 0 earns "
                  "nothing); 0: none.")
    bonus_cap = models.DecimalField(
        max_digits=7, decimal_places=2, default=0, help_text="The most bonus one participant can earn; 0: no cap.")
    CURRENCIES = [("GBP", "£ (GBP)"), ("USD", "$ (USD)"), ("EUR", "€ (EUR)")]
    bonus_currency = models.CharField(max_length=3, choices=CURRENCIES, default="GBP",
                                      help_text="The study's currency, of its payment and its bonus (the recruiting "
                                                "platform's).")
    LANGUAGES = [("en", "English"), ("de", "Deutsch (German)")]
    language = models.CharField(
        max_length=8, choices=LANGUAGES, default="en",
        help_text="The language of every page and message participants read (researchers keep theirs).")
    time_limit_minutes = models.PositiveIntegerField(
        default=0, help_text="A participant not finished this many minutes after arriving is timed out and their "
                             "place freed; 0: no limit.")
    prolific_completion_url = models.CharField(
        max_length=300, default=PROLIFIC_COMPLETION_URL, help_text="{code} is replaced by the completion code.")
    mturk_submit_url = models.CharField(max_length=300, default=MTURK_SUBMIT_URL)
    LINK, PROLIFIC, MTURK = "link", "prolific", "mturk"
    RECRUITMENTS = [(LINK, "a link (anyone)"), (PROLIFIC, "Prolific"), (MTURK, "Mechanical Turk")]
    recruitment = models.CharField(
        max_length=12, choices=RECRUITMENTS, default=LINK,
        help_text="Prolific studies cannot open without Prolific's completion code.")
    # What the consent page tells participants (the ethics-approved texts), per study.
    consent_text = models.TextField(
        blank=True, help_text="The approved consent text (paragraphs separated by blank lines); blank: the default.")
    estimated_minutes = models.PositiveIntegerField(default=15, help_text="Shown on the consent page.")
    keep_trails = models.BooleanField(
        default=True, help_text="At the end of a test option's animation its whole path stays drawn (its Trail button "
                                "on), so that the options can be compared at a glance.")
    duration_tolerance_minutes = models.PositiveIntegerField(
        default=5, help_text="How far apart, in minutes, the conditions' estimated durations may lie before the "
                             "study's page warns: a condition that takes longer is a confound.")
    payment = models.CharField(max_length=300, blank=True, help_text="e.g. '£2.50, paid through Prolific'.")
    payment_amount = models.DecimalField(
        max_digits=7, decimal_places=2, null=True, blank=True,
        help_text="What taking part pays, in the study's currency: the consent page writes it as the participant's "
                  "language writes money, the payment text after it; blank: the payment text alone.")
    contact = models.CharField(max_length=300, blank=True, help_text="Who answers questions: name and email.")
    ethics_reference = models.CharField(max_length=200, blank=True, help_text="The approval's reference.")
    CHOOSE, SHOW = "choose", "show"
    TEST_KINDS = [(CHOOSE, "choose the robot's way among four"),
                  (SHOW, "show the robot's way (grid worlds from a file)")]
    test_kind = models.CharField(
        max_length=8, choices=TEST_KINDS, default=CHOOSE, editable=False,
        help_text="What every test asks: choose among options, or show the way; set when the study is built.")
    # Which devices may take part (studyapp/participant/devices.py): checked on the consent page, before a place is
    # kept.
    min_screen_width = models.PositiveIntegerField(
        default=0, help_text="Smallest screen width (CSS pixels) a participant may take part on; 0: any.")
    allow_phones = models.BooleanField(default=True, help_text="Phones may take part.")
    allow_tablets = models.BooleanField(default=True, help_text="Tablets may take part.")
    device_refusals = models.PositiveIntegerField(
        default=0, editable=False, help_text="Arrivals turned away for their device (no place was kept for them).")
    # The comprehension check after the instructions (studyapp/participant/comprehension.py); off by default, so a study
    # without it keeps its steps' indices.
    comprehension_check = models.BooleanField(
        default=False, help_text="Ask questions about the instructions before the examples; screen out whoever "
                                 "fails them too often.")
    comprehension_questions = models.JSONField(
        default=list, blank=True, help_text="[{question, choices, right: [indices]}]; empty: the domain's own.")
    comprehension_attempts = models.PositiveIntegerField(
        default=3, help_text="Failed attempts at the comprehension check after which a participant is screened out.")
    test_set = models.JSONField(
        default=list, help_text="Shared test environments: with 4 options each (choose), or θ*'s way (show).")
    source = models.JSONField(default=dict, blank=True, help_text="Where the trajectories came from (table, seed).")
    created_at = models.DateTimeField(auto_now_add=True)

    class Meta:
        verbose_name_plural = "studies"
        ordering = ["-created_at"]

    def __str__(self):
        return self.name

    def get_absolute_url(self):
        return reverse("entry", args=[self.slug])

    @property
    def active_timeout(self) -> timedelta:
        return timedelta(minutes=self.active_timeout_minutes)

    @property
    def time_limit(self) -> timedelta | None:
        return timedelta(minutes=self.time_limit_minutes) if self.time_limit_minutes else None

    def running_problems(self) -> list[str]:
        """Why this study cannot run on this server now, open or not (empty: it can): its robot is not
        registered here, it has no test question (its build did not finish), or the data a closed-loop condition
        reads, built from its table, is gone.  Cheap (one small query), and never raises:
        every participant page asks it first."""
        from teaching.api import domain_names  # noqa: PLC0415 (numpy and the domains load when needed)

        from .trajectories import find_robot  # noqa: PLC0415

        find_robot(self)
        if self.domain not in domain_names():
            return [f"Its robot '{self.domain}' is not registered on this server (registered: "
                    f"{', '.join(domain_names())}): start the site, workers and commands with the setting that "
                    "registers it (a world file: TEACHING_WORLDS, docs/gridworlds.md; an imported table: "
                    "TEACHING_TABLES, docs/importing.md)."]
        if not self.test_set:
            return ["It has no test questions: its build did not finish (its job page says why), and a "
                    "participant would answer nothing. Build it again."]
        return self._missing_packs()

    def _missing_packs(self) -> list[str]:
        """A closed-loop condition decides each participant's next example from data its build wrote beside
        the table (studyapp/participant/closedloop.py): where that directory is gone, its participants could not
        go on."""
        out = []
        for name, data in self.conditions.filter(closed_loop__isnull=False).values_list("name", "closed_loop"):
            pack = (data or {}).get("pack")
            if pack and not Path(pack).is_dir():
                out.append(f"The data of its closed-loop condition '{name}', built from its table, is missing "
                           f"({pack}): build the study again.")
        return out

    def opening_problems(self) -> list[str]:
        """Why this study may not accept participants yet (empty: it may)."""
        running = self.running_problems()
        if running:
            return running
        if (self.source or {}).get("kind") != "table":  # e.g. an early version's synthesised placeholder
            return ["Its trajectories do not come from a trajectory table, so they say nothing about "
                    "theta*: rebuild the study from a table (create_study or the study designer)."]
        aliased = self.aliased_conditions()
        if aliased:
            return [f"{aliased}. The analysis would pool them as one group, so this study takes no participants "
                    "and is not analysed: rebuild it (create_study or the study designer)."]
        if self.recruitment == self.PROLIFIC and not self.completion_code.strip():
            return ["Prolific only accepts its study's own completion code: set the completion code "
                    "(Prolific's study page, 'Completion paths') before opening."]
        language = self.language_problem()
        return [language] if language else []

    def language_problem(self) -> str:
        """Why its participants would read some of the robot's texts in English ("" if none): creating the
        study checks it, but its language may be changed later (the admin) or its world file edited."""
        from .i18n import language_problem  # noqa: PLC0415 (teaching loads only when needed)
        from .trajectories import study_domain  # noqa: PLC0415

        return language_problem(study_domain(self), self.language)

    def aliased_conditions(self) -> str:
        """Which of this study's condition names are one condition ("" if none): creating a study
        refuses that, but one stored before could have them (studyapp/conditions.py)."""
        from .conditions import ConditionError, check_distinct_conditions  # noqa: PLC0415 (pandas)

        try:
            check_distinct_conditions(self.conditions.values_list("name", flat=True))
        except ConditionError as exc:
            return str(exc)
        return ""

    def clean(self):
        problems = self.opening_problems() if self.is_open else []
        if problems:
            raise ValidationError({"is_open": problems})

    @property
    def completion_url(self) -> str:
        """Where a finished Prolific participant is sent, exactly."""
        return self.prolific_completion_url.format(code=self.completion_code)

    def scene_view(self) -> dict:
        """What every canvas of this study shares (trajectories.study_view: a scale, say);
        computed once per study version: the trajectories are frozen while it has participants."""
        stored = (self.source or {}).get("scene_view")  # closed loops: computed at build over every example
        if stored is not None:
            return stored
        key = (self.pk, self.created_at, len(self.test_set))
        if key not in _VIEWS:
            from .trajectories import study_domain, study_view  # noqa: PLC0415  (numpy and teaching)
            _VIEWS[key] = study_view(study_domain(self), [c.training for c in self.conditions.all()], self.test_set)
        return _VIEWS[key]

    @property
    def has_device_rules(self) -> bool:
        return bool(self.min_screen_width) or not (self.allow_phones and self.allow_tablets)

    def default_consent(self) -> str:
        from .i18n import participant_texts  # noqa: PLC0415  (teaching loads only for a page)
        from .trajectories import study_domain  # noqa: PLC0415

        return participant_texts(study_domain(self)).consent  # in the participant's language (the page's)

    def consent_version(self) -> str:
        """12 hex digits naming what the consent page says (its paragraphs and facts): stored with each
        participant's consent, so a text changed during a study tells who agreed to which."""
        shown = [*self.consent_paragraphs(), str(self.estimated_minutes), self.payment, self.contact,
                 self.ethics_reference]
        if self.time_limit_minutes:  # appended only when set: a study without one keeps its version
            shown.append(f"limit {self.time_limit_minutes}")
        if self.payment_amount is not None:  # likewise: an amount the page writes
            shown.append(f"pay {Decimal(str(self.payment_amount)):.2f} {self.bonus_currency}")
        if self.bonus_per_correct or self.bonus_per_point:  # likewise: the bonus rule the page states
            rates = (Decimal(str(v or 0)) for v in (self.bonus_per_correct, self.bonus_per_point, self.bonus_cap))
            shown.append("bonus " + " ".join(f"{v:.2f}" for v in rates) + f" {self.bonus_currency}")
        return hashlib.sha256("\x1f".join(shown).encode()).hexdigest()[:12]

    def consent_paragraphs(self) -> list[str]:
        text = self.consent_text.strip() or self.default_consent()
        return [p.strip() for p in text.split("\n\n") if p.strip()]


class Condition(models.Model):
    study = models.ForeignKey(Study, models.CASCADE, related_name="conditions")
    name = models.CharField(max_length=100)
    position = models.PositiveIntegerField(default=0)
    target = models.PositiveIntegerField(null=True, blank=True, help_text="Blank: the study's target.")
    training = models.JSONField(default=list, help_text="Frozen training environments, in order.")
    closed_loop = models.JSONField(
        null=True, blank=True,
        help_text="A closed-loop condition: its settings, the files its decisions are computed from and its check "
                  "questions; empty for a fixed sequence.")

    class Meta:
        ordering = ["study", "position", "pk"]
        constraints = [models.UniqueConstraint(fields=["study", "name"], name="unique_condition_name")]

    def __str__(self):
        return f"{self.study.slug}/{self.name}"

    @property
    def target_count(self) -> int:
        return self.target if self.target is not None else self.study.target_per_condition

    @property
    def env_ids(self) -> list[int]:
        return [env["env_id"] for env in self.training]


class Participant(models.Model):
    PROLIFIC, MTURK, ANONYMOUS, PREVIEW = "prolific", "mturk", "anonymous", "preview"
    PLATFORMS = [(PROLIFIC, "Prolific"), (MTURK, "Mechanical Turk"), (ANONYMOUS, "anonymous"),
                 (PREVIEW, "staff preview")]

    study = models.ForeignKey(Study, models.CASCADE, related_name="participants")
    condition = models.ForeignKey(Condition, models.PROTECT, related_name="participants")
    token = models.CharField(max_length=40, unique=True, default=new_token)
    platform = models.CharField(max_length=12, choices=PLATFORMS, default=ANONYMOUS)
    platform_pid = models.CharField(max_length=100, blank=True, help_text="PROLIFIC_PID or workerId.")
    platform_study_id = models.CharField(max_length=100, blank=True, help_text="STUDY_ID or hitId.")
    platform_session_id = models.CharField(max_length=100, blank=True, help_text="SESSION_ID or assignmentId.")
    platform_session_ids = models.JSONField(
        default=list, blank=True, help_text="Every SESSION_ID or assignmentId this participant arrived with.")
    turk_submit_to = models.CharField(max_length=300, blank=True)
    position = models.PositiveIntegerField(default=0, help_text="Index of the current step of the flow.")
    option_orders = models.JSONField(default=list, help_text="Display order of the options, per test.")
    started_at = models.DateTimeField(default=timezone.now)
    last_seen_at = models.DateTimeField(default=timezone.now)
    completed_at = models.DateTimeField(null=True, blank=True)
    excluded = models.BooleanField(default=False, help_text="Failed the attention check: kept, not analysed.")
    completion_code = models.CharField(max_length=64, blank=True)
    # How a participant's study ended before its last step (studyapp.status): kept, never analysed, holds no place.
    RETURNED, TIMED_OUT, SCREENED_OUT = status.RETURNED, status.TIMED_OUT, status.SCREENED_OUT
    OUTCOMES = [(RETURNED, "returned (the platform says they left)"), (TIMED_OUT, "timed out"),
                (SCREENED_OUT, "screened out")]
    outcome = models.CharField(max_length=16, choices=OUTCOMES, blank=True,
                               help_text="Returned, timed out or screened out; blank for everyone else.")
    ended_at = models.DateTimeField(null=True, blank=True, help_text="When the outcome was set.")
    bonus = models.DecimalField(max_digits=7, decimal_places=2, null=True, blank=True,
                                help_text="The performance bonus earned, set once on finishing.")

    class Meta:
        ordering = ["-started_at"]
        constraints = [
            models.UniqueConstraint(
                fields=["study", "platform", "platform_pid"], condition=~models.Q(platform_pid=""),
                name="one_participant_per_platform_id"),
        ]
        indexes = [models.Index(fields=["study", "condition", "completed_at", "last_seen_at"])]

    def __str__(self):
        return f"{self.platform}:{self.platform_pid or self.token[:8]}"

    @property
    def is_preview(self) -> bool:
        return self.platform == self.PREVIEW

    def get_absolute_url(self):
        return reverse("step", args=[self.study.slug, self.token])

    @classmethod
    def complete_filter(cls, prefix: str = "") -> models.Q:
        """The participants whose status is complete (studyapp.status), the analysed set: finished, not
        excluded, no recorded outcome, no staff preview.  `prefix` is "participants__" when filtering
        studies or conditions by their participants."""
        return models.Q(**{prefix + "completed_at__isnull": False, prefix + "excluded": False,
                           prefix + "outcome": ""}) & ~models.Q(**{prefix + "platform": cls.PREVIEW})


class StepKind(models.TextChoices):
    """The kinds of step in a participant's flow (studyapp.participant.flow), in order.  The values are what
    Answer.kind stores and the exports carry, and name the step's template (step_<kind>.html):
    never change one.  DONE is the completion page, which takes no answer."""

    CONSENT = "consent"
    INSTRUCTIONS = "instructions"
    COMPREHENSION = "comprehension"  # questions about the instructions, when the study asks them
    TRAINING = "training"
    CHECK = "check"  # closed-loop conditions: a check question between examples
    FEEDBACK = "feedback"  # closed-loop conditions: θ*'s trajectory after a check
    TEST = "test"
    ATTENTION = "attention"
    DEMOGRAPHICS = "demographics"
    DONE = "done"


class Answer(models.Model):
    """One row per answered step; the unique constraint makes answers write-once."""

    participant = models.ForeignKey(Participant, models.CASCADE, related_name="answers")
    step = models.PositiveIntegerField(help_text="Index of the step in the participant's flow.")
    kind = models.CharField(max_length=20, choices=StepKind.choices)
    item = models.IntegerField(null=True, blank=True, help_text="Training or test index within its kind.")
    data = models.JSONField(default=dict)
    # Tests: derived exactly from data + the study's test set, stored for convenience.  A show test's
    # `correct` says whether the way shown is optimal for θ*; it has a regret and no option or score.
    chosen_option = models.IntegerField(null=True, blank=True)
    correct = models.BooleanField(null=True, blank=True)
    confidence_score = models.IntegerField(null=True, blank=True)
    regret = models.FloatField(
        null=True, blank=True,
        help_text="Show tests: θ*'s optimum minus the reward of the way shown, in θ*'s units (0: optimal).")
    created_at = models.DateTimeField(default=timezone.now)

    class Meta:
        ordering = ["participant", "step"]
        constraints = [models.UniqueConstraint(fields=["participant", "step"], name="one_answer_per_step")]

    def __str__(self):
        return f"{self.participant} step {self.step} ({self.kind})"


class ComprehensionAttempt(models.Model):
    """One attempt at a study's comprehension check, failed or passed: each is kept (and exported), while
    the step's Answer is written once, when it is passed.  ``number`` (1, 2, ...) is unique per participant,
    so a replayed post of an attempt is recognised instead of counted again."""

    participant = models.ForeignKey(Participant, models.CASCADE, related_name="comprehension_attempts")
    number = models.PositiveIntegerField(help_text="1 for the first attempt, then 2, ...")
    answers = models.JSONField(default=list, help_text="Per question, the indices of the choices ticked.")
    missed = models.JSONField(default=list, help_text="Indices (0-based) of the questions answered wrongly.")
    passed = models.BooleanField(default=False)
    created_at = models.DateTimeField(default=timezone.now)

    class Meta:
        ordering = ["participant", "number"]
        constraints = [models.UniqueConstraint(fields=["participant", "number"], name="one_comprehension_attempt")]

    def __str__(self):
        return f"{self.participant} comprehension attempt {self.number}"


class LoopStep(models.Model):
    """One step of a participant's closed-loop teaching (studyapp.participant.closedloop): decided once, from their
    answers so far, stored, and served again on every reload, Back or second tab.  ``decision`` is
    teaching's Decision (what it was based on), ``payload`` what the page draws."""

    EXAMPLE, CHECK, FEEDBACK, DONE = "example", "check", "feedback", "done"

    participant = models.ForeignKey(Participant, models.CASCADE, related_name="loop_steps")
    index = models.PositiveIntegerField(help_text="0, 1, ... within the participant's closed-loop teaching.")
    kind = models.CharField(max_length=10)
    env_id = models.IntegerField(null=True, blank=True)
    question = models.IntegerField(null=True, blank=True, help_text="Check questions: which one.")
    option_order = models.JSONField(default=list, help_text="Check questions: display order of the options.")
    decision = models.JSONField(default=dict)
    payload = models.JSONField(default=dict)
    seconds = models.FloatField(default=0.0, help_text="How long the decision took to compute.")
    created_at = models.DateTimeField(default=timezone.now)

    class Meta:
        ordering = ["participant", "index"]
        constraints = [models.UniqueConstraint(fields=["participant", "index"], name="one_decision_per_loop_step")]

    def __str__(self):
        return f"{self.participant} loop step {self.index} ({self.kind})"
