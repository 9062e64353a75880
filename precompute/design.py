"""The study designer's form: pick a built table (its identity shown), the conditions and the
study's settings; "Build" runs selection and the test set on the workers (precompute/study.py).

The study is built closed: the researcher previews every condition on its dashboard page, then
opens it there.
"""
from __future__ import annotations

from django import forms
from django.core.exceptions import NON_FIELD_ERRORS

from studyapp.conditions import aliased_pairs
from studyapp.models import Participant, Study
from studyapp.researcher import specrules, specschema
from studyapp.researcher.specschema import (
    BONUS_FIELDS,
    CONDITION_FIELDS,
    JOB_FIELDS,
    OUTCOME_FIELDS,
    PLAN_FIELDS,
    STUDY_FIELDS,
    TEXT_FIELDS,
    THRESHOLD_FIELDS,
)
from teaching.api import (
    APPROX_STAR,
    CONDITIONS,
    MAX_EXAMPLES_LIMIT,
    USER_NAMES,
    ClosedLoopError,
    ClosedLoopSpec,
    TableError,
    TrajectoryTable,
    domain_names,
    get_domain,
    has_hyperparameter,
    make_model,
)

from . import designquiz, supply
from .schemafields import param_field_name, schema_field, selector_param_fields
from .tables import table_choices

# The learner models whose τ (deterministic) or λ (probabilistic) the researcher may fix: one
# optional field each, so an error is said under the model it is about.
TUNABLE = [(m, specrules.hyperparameter_symbol(m)) for m in USER_NAMES if has_hyperparameter(make_model(m))]


def fixed_field(model: str) -> str:
    return "fixed_" + model.replace("-", "_")


# The designer's one choice of devices -> the study's allow_phones, allow_tablets ("" is the default: any).
DEVICE_CHOICES = [("", "any device"), ("no-phones", "computers and tablets, no phones"),
                  ("computers", "computers only")]


def device_arguments(data: dict) -> dict:
    """The study's device fields from the designer's cleaned data (studyapp/participant/devices.py)."""
    devices = data.get("devices") or ""
    out = {"allow_phones": devices == "", "allow_tablets": devices != "computers"}
    if data.get("min_screen_width") is not None:
        out["min_screen_width"] = data["min_screen_width"]
    return out


class StudyDesignForm(forms.Form):
    table = forms.ChoiceField(help_text="The trajectory table every condition and test is drawn from: one built "
                                        "below, on the command line, or by a table job. Its domain (the robot "
                                        "participants see) is the study's.")
    slug = schema_field(STUDY_FIELDS["slug"])
    name = schema_field(STUDY_FIELDS["name"])
    conditions = schema_field(JOB_FIELDS["conditions"], initial=list(CONDITIONS), required=False,
                              widget=forms.CheckboxSelectMultiple)
    target_per_condition = schema_field(STUDY_FIELDS["target_per_condition"])
    recruitment = schema_field(STUDY_FIELDS["recruitment"])
    completion_code = schema_field(STUDY_FIELDS["completion_code"])
    approx_star = schema_field(JOB_FIELDS["approx_star"], label="approx* (the model coverage-approx* augments)")
    seed = schema_field(JOB_FIELDS["seed"])
    hand_picked_name = schema_field(CONDITION_FIELDS["name"], required=False, initial="hand-picked",
                                    label="Hand-picked condition: name")
    hand_picked_env_ids = forms.CharField(
        required=False, label="Hand-picked condition: environment ids",
        help_text="Optional: environment ids of the table, comma-separated, shown in this order as one more "
                  "condition.")
    # One closed-loop condition: each participant's next example chosen from their answers.
    loop_name = schema_field(
        CONDITION_FIELDS["name"], required=False, label="Closed-loop condition: name (optional)",
        help_text="Adds a condition that picks each participant's next example from their answers to check "
                  "questions shown between the examples (docs/study.md); empty: none.")
    loop_model = forms.ChoiceField(choices=[(m, m) for m in USER_NAMES], initial=APPROX_STAR, required=False,
                                   label="Closed loop: learner model",
                                   help_text="How the robot assumes participants learn from an example.")
    loop_value = forms.FloatField(required=False, label="Closed loop: τ or λ (optional)",
                                  help_text="The learner model's τ (deterministic) or λ (probabilistic); empty: "
                                            "the model's default.")
    loop_lapse = forms.FloatField(initial=0.1, min_value=0.001, max_value=1, required=False,
                                  label="Closed loop: lapse rate ε",
                                  help_text="The chance that a check answer is a careless guess (above 0, so that "
                                            "one careless answer never rules a θ out for good).")
    loop_max_examples = forms.IntegerField(initial=6, min_value=1, max_value=MAX_EXAMPLES_LIMIT, required=False,
                                           label="Closed loop: most examples",
                                           help_text="It stops after this many examples (or when no example helps).")
    loop_check_every = forms.IntegerField(initial=2, min_value=0, max_value=MAX_EXAMPLES_LIMIT, required=False,
                                          label="Closed loop: a check question every",
                                          help_text="Examples between check questions; 0: no check questions.")
    loop_feedback = forms.BooleanField(initial=True, required=False, label="Closed loop: feedback after each check",
                                       help_text="After a check, show what the robot really does there.")
    loop_fit_from = forms.ChoiceField(
        required=False, label="Closed loop: model from a fit (optional)",
        help_text="A study whose participants' answers set the model, τ / λ and ε above: the learner model that "
                  "best explains them, fitted when this study is built; empty: the settings above.")
    min_regret = schema_field(THRESHOLD_FIELDS["min_regret"], label="Test set: minimum θ*-regret")
    min_distance = schema_field(THRESHOLD_FIELDS["min_distance"], label="Test set: minimum distance (optional)")
    test_difficulty = schema_field(JOB_FIELDS["test_difficulty"], label="Test set: difficulty", required=False)
    test_kind = schema_field(JOB_FIELDS["test_kind"], label="Tests ask to", required=False)
    # Where a problem the schema finds is said: its path there -> the field here (else the same name).
    SCHEMA_PLACES = {"test_set_thresholds.min_regret": "min_regret", "test_set_thresholds.min_distance": "min_distance",
                     "hand_picked.name": "hand_picked_name", "hand_picked.env_ids": "hand_picked_env_ids",
                     "closed_loop.name": "loop_name", "closed_loop.settings": "loop_model",
                     "closed_loop_fit": "loop_fit_from"}

    def __init__(self, *args, tables: list[dict], **kwargs):
        super().__init__(*args, **kwargs)
        self.tables = tables
        # Each selector's parameters right after the conditions in the form's order (the page draws them
        # on the selector's own row: designlayout.py).
        self.selector_params = selector_param_fields()
        fields = list(self.fields.items())
        at = [name for name, _ in fields].index("conditions") + 1
        self.fields = dict(fields[:at] + [(k, f) for k, (_, _, f) in self.selector_params.items()] + fields[at:])
        self.fields["table"].choices = table_choices(tables)
        self.fields["min_distance"].help_text += " (" + "; ".join(  # each domain's, in its own units
            f"{name}: {get_domain(name).min_option_distance}" for name in domain_names()) + ")"
        fitted = (Study.objects.filter(Participant.complete_filter("participants__")).distinct()
                  .order_by("slug").values_list("slug", "name"))
        self.fields["loop_fit_from"].choices = [("", "none: the settings above")] + [
            (slug, f"{name} ({slug})") for slug, name in fitted]
        for model, symbol in TUNABLE:
            rule = "largest τ" if symbol == "τ" else "smallest λ"
            self.fields[fixed_field(model)] = forms.CharField(
                required=False, label=f"{model}: fixed {symbol} (optional)",
                help_text=f"A number > 0 used instead of the paper's rule (the {rule} that still teaches θ*); "
                          "empty: the rule.")
        # The consent page's texts (the Study model's columns, through the schema).
        self.fields.update({k: schema_field(STUDY_FIELDS[k], widget=forms.Textarea if k == "consent_text" else None)
                            for k in TEXT_FIELDS})
        self.fields.update(designquiz.fields(tables))  # the comprehension check after the instructions
        # Who may take part: the device rules the consent page checks (studyapp/participant/devices.py).
        # One choice, not two tick boxes: an unticked box is never sent, so a post without them would turn phones away.
        self.fields["min_screen_width"] = schema_field(STUDY_FIELDS["min_screen_width"], required=False,
                                                       label="Smallest screen width (px)")
        # How a participant's study may end early, and each outcome's code (studyapp/participant/outcomes.py).
        self.fields.update({k: schema_field(STUDY_FIELDS[k], required=False)
                            for k in (*OUTCOME_FIELDS, *BONUS_FIELDS, *PLAN_FIELDS, "language") if k != "keep_trails"})
        self.fields["language"].label = "Participants' language"
        self.fields["time_limit_minutes"].label = "Time limit (minutes)"
        self.fields["duration_tolerance_minutes"].label = "Conditions' durations may differ by (minutes)"
        # a tick box (the schema's boolean would be a text field); unticked, the browser sends nothing: False
        self.fields["keep_trails"] = forms.BooleanField(
            required=False, initial=True, label="Keep each test option's path drawn after it played",
            help_text=STUDY_FIELDS["keep_trails"].help)
        self.fields["payment_amount"].label = "Payment for taking part (amount, optional)"
        self.fields["bonus_currency"].label = "Currency (of the payment and the bonus)"
        self.fields["devices"] = forms.ChoiceField(
            choices=DEVICE_CHOICES, required=False, label="Devices that may take part",
            help_text="Phones and tablets are told on the consent page that they cannot take part, and keep no "
                      "place; the dashboard counts them.")

    def _fixed_values(self) -> dict:
        """{model: τ or λ} the researcher fixed, each read as a number where it is one (the schema judges
        them, in clean())."""
        fixed = {}
        for model, _ in TUNABLE:
            text = (self.cleaned_data.get(fixed_field(model)) or "").strip()
            if text:
                try:
                    fixed[model] = float(text)
                except ValueError:
                    fixed[model] = text
        return fixed

    def clean_hand_picked_env_ids(self):
        text = self.cleaned_data["hand_picked_env_ids"].strip()
        try:
            return [int(t) for t in text.replace(",", " ").split()]
        except ValueError:
            raise forms.ValidationError("Give whole environment ids, separated by commas.") from None

    def clean_slug(self):
        slug = self.cleaned_data["slug"]
        if Study.objects.filter(slug=slug).exists():
            raise forms.ValidationError(f"A study called {slug!r} exists already: choose another name.")
        return slug

    def _closed_loop(self, data: dict) -> None:
        """data["closed_loop"] ({name: settings}) and data["closed_loop_fit"] ({name: study slug}); each
        problem said under its own field."""
        data["closed_loop"], data["closed_loop_fit"] = {}, {}
        name = data.get("loop_name")
        if not name:
            if data.get("loop_fit_from"):
                self.add_error("loop_name", "Name the closed-loop condition that the fit is for.")
            return
        taken = [*(data.get("conditions") or []), *([data["hand_picked_name"]] if data.get("hand_picked_env_ids")
                                                    else [])]
        if name in taken or aliased_pairs([*taken, name]):
            self.add_error("loop_name", f"{name!r} is already (another name of) one of the chosen conditions: "
                                        "choose a name of its own.")
            return
        fields = {"model": "loop_model", "value": "loop_value", "lapse": "loop_lapse",
                  "max_examples": "loop_max_examples", "check_every": "loop_check_every", "feedback": "loop_feedback"}
        if any(f in self.errors for f in fields.values()):
            return
        defaults = ClosedLoopSpec().as_dict()  # a field left empty: teaching's default
        settings = {k: defaults[k] if data.get(f) in (None, "") else data[f] for k, f in fields.items()}
        try:
            ClosedLoopSpec.from_dict(settings)
        except ClosedLoopError as exc:
            text = str(exc)  # ClosedLoopSpec's messages start with the setting's name, or say which
            where = fields.get(text.split()[0]) or ("loop_lapse" if text.startswith("the lapse rate") else
                                                    "loop_value" if any(w in text for w in ("τ", "λ", "hyperparameter"))
                                                    else "loop_model")
            self.add_error(where, text)
            return
        data["closed_loop"] = {name: settings}
        if data.get("loop_fit_from"):
            data["closed_loop_fit"] = {name: data["loop_fit_from"]}

    def clean(self):
        data = super().clean()
        data["hyperparameters"] = self._fixed_values()
        self._closed_loop(data)
        if data.get("recruitment") == Study.PROLIFIC and not (data.get("completion_code") or "").strip():
            self.add_error("completion_code", "Prolific only accepts its study's own completion code: enter it.")
        ids = data.get("hand_picked_env_ids")
        if ids:
            name = data.get("hand_picked_name") or "hand-picked"
            data["hand_picked_name"] = name
            chosen = list(data.get("conditions") or [])
            aliased = aliased_pairs([*chosen, name])
            if name in chosen:
                self.add_error("hand_picked_name", f"{name!r} is already one of the chosen conditions.")
            elif aliased:  # the analysis would pool the two as one group
                first = aliased[0][0]
                self.add_error("hand_picked_name", f"{name!r} is another name of the chosen condition {first!r}: "
                                                   "choose a name of its own.")
            elif data.get("table"):
                self._check_in_table(data["table"], ids)
        elif not data.get("conditions") and not data.get("loop_name") and "conditions" not in self.errors:
            self.add_error("conditions", "Choose at least one condition, or give a hand-picked or closed-loop one.")
        self._check_job(data)
        self._check_tests(data)
        return data

    TEST_FIELDS = ("table", "test_kind", "test_difficulty", "min_regret", "min_distance")

    def _check_tests(self, data: dict) -> None:
        """What the build's last step would refuse about the tests, said under its field before any job
        starts: a robot that cannot be shown the way, or a kind and difficulty no environment of the table can
        hold (precompute/supply.py).  Training may still use the last environments of a level; the build then
        says so on its job page.  After the schema's checks: the values are known to be the schema's."""
        domain = next((t["domain"] for t in self.tables if t["path"] == data.get("table")), None)
        if domain is None or any(f in self.errors for f in self.TEST_FIELDS):
            return
        field, why = supply.problem(data["table"], domain, data.get("test_kind") or Study.CHOOSE,
                                    data.get("test_difficulty") or None, data.get("min_regret"),
                                    data.get("min_distance"))
        if why:
            self.add_error(field, why)
            data.pop("job", None)

    def _selected(self, data: dict) -> list[dict]:
        """The ticked conditions as the job names them: each its selector, with the parameters filled in
        below it (an empty one: the selector's default)."""
        params = {}
        for field, (name, key, _) in self.selector_params.items():
            if data.get(field) is not None:
                params.setdefault(name, {})[key] = data[field]
        return [{"name": c, "selector": c, "params": params.get(c, {})} for c in data.get("conditions") or []]

    def _job_arguments(self, data: dict) -> dict:
        """The study job's design (specschema's JOB_FIELDS and STUDY_FIELDS) from the cleaned data."""
        ids = data.get("hand_picked_env_ids")
        return {"slug": data.get("slug"), "name": data.get("name") or None, "seed": data.get("seed"),
                "is_open": False,  # built closed: the researcher previews every condition, then opens it
                "approx_star": data.get("approx_star"), "conditions": self._selected(data),
                "test_difficulty": data.get("test_difficulty") or None, "test_kind": data.get("test_kind") or None,
                "target_per_condition": data.get("target_per_condition"), "hyperparameters": data["hyperparameters"],
                "hand_picked": {data.get("hand_picked_name") or "hand-picked": ids} if ids else {},
                "test_set_thresholds": {k: data[k] for k in THRESHOLD_FIELDS if data.get(k) is not None},
                "closed_loop": data["closed_loop"], "closed_loop_fit": data["closed_loop_fit"],
                "completion_code": (data.get("completion_code") or "").strip(), "recruitment": data.get("recruitment"),
                **{k: data.get(k) for k in TEXT_FIELDS},
                **{k: data[k] for k in (*OUTCOME_FIELDS, *BONUS_FIELDS, *PLAN_FIELDS, "language")
                   if data.get(k) not in (None, "")},
                **device_arguments(data), **designquiz.arguments(data)}

    def _check_job(self, data: dict) -> None:
        """The job's arguments through the study spec's checks (studyapp/researcher/specschema.py), each problem under
        its own field (unless one is said there already); data["job"]: the CheckedStudy, once all is well."""
        checked, problems = specschema.job_problems(self._job_arguments(data))
        for problem in problems:
            place = self.SCHEMA_PLACES.get(problem.field, problem.field)
            if problem.field.startswith("conditions."):  # a selector's parameter: under its own field
                place = param_field_name(*problem.field.split(".")[1:3])
            message = str(problem)
            if problem.field.startswith("hyperparameters."):
                place = fixed_field(problem.field.split(".", 1)[1])
                message += "; leave it empty for the paper's rule."
            place = place if place in self.fields else None
            if (place or NON_FIELD_ERRORS) not in self.errors:
                self.add_error(place, message)
        if not self.errors:
            data["job"] = checked

    def _check_in_table(self, table_path: str, ids: list[int]) -> None:
        try:
            table = TrajectoryTable.load(table_path, verify=False)
        except (TableError, OSError, ValueError) as exc:
            self.add_error("table", f"Cannot read this table: {exc}")
            return
        missing = sorted(set(ids) - {int(e) for e in table.env_ids})
        if missing:
            self.add_error("hand_picked_env_ids", f"Not in this table: {', '.join(map(str, missing[:10]))}"
                           f"{' ...' if len(missing) > 10 else ''} (it has {table.n_envs:,} environments).")
