"""A closed-loop condition built by the study job: `build_study --closed-loop` and the
designer send its settings with the job; the last task prepares it once the test set is known (check
questions apart from the final tests, its pack, the study's one scale) and runs simulated participants of
every learner model through it for the pilot."""
from __future__ import annotations

import io

import numpy as np
import pytest
from django.core.management import CommandError, call_command

from precompute import jobs
from precompute.models import Job
from precompute.steps import closed_loop_refusal
from precompute.study import StudyJobError, create_study_job, parse_closed_loop
from studyapp.analysis.simulate import run_participant
from studyapp.models import Participant, Study
from studyapp.participant import closedloop
from studyapp.researcher.specschema import SpecError, check_job
from teaching.api import ClosedLoopError, TrajectoryTable, select_checks
from tests.conftest import TINY_TEST_SET
from tests.precompute.refusals import assert_refused_in_one_line

LOOP = "loop:model=prob-euclidean,value=1,max_examples=4,check_every=2,feedback=yes"


@pytest.mark.slow
def test_build_study_prepares_a_closed_loop_condition_with_the_test_set(inprocess_worker, transactional_db,
                                                                        demo_table, settings, tmp_path):
    settings.VAR_DIR = tmp_path
    out = io.StringIO()
    call_command("build_study", "--table", str(demo_table), "--slug", "looped", "--conditions", "random",
                 "--closed-loop", LOOP, "--wait", "--no-progress", "--timeout", "240", stdout=out)
    job = Job.objects.get(kind=Job.STUDY)
    assert job.status == Job.SUCCEEDED, job.error
    assert job.params["closed_loop"]["loop"]["check_every"] == 2 and job.chunks_total == 2  # random + test set
    study = Study.objects.get(slug="looped")
    assert study.is_open and [c.name for c in study.conditions.all()] == ["random", "loop"]
    loop = study.conditions.get(name="loop")
    assert loop.training == [] and loop.closed_loop["settings"]["model"] == "prob-euclidean"
    assert loop.closed_loop["settings"]["value"] == 1.0 and loop.closed_loop["settings"]["feedback"] is True
    checks = {t["env_id"] for t in loop.closed_loop["checks"]}
    tests = {t["env_id"] for t in study.test_set}
    assert checks and not checks & tests  # the final tests stay the same for every condition
    assert not tests & set(study.conditions.get(name="random").env_ids)
    assert "scene_view" in study.source  # one scale that holds whatever the loop may show
    assert "closed loop: prob-euclidean, up to 4 examples, a check every 2" in out.getvalue()
    assert job.result["closed_loop"]["loop"]["checks"] == [t["env_id"] for t in loop.closed_loop["checks"]]

    # the pilot: a row for the loop, from simulated participants of every user model run through it
    pilot = study.source["pilot"]
    assert pilot["conditions"] == ["random", "loop"] and pilot["closed_loop"]["loop"]["participants"] == 40
    row = np.array(pilot["matrix"][1])
    assert row.shape == (len(pilot["users"]),) and (row > pilot["prior"]).any() and (row <= 1).all()
    choice = np.array(pilot["predicted"]["choice"]["exact"]["loop"])
    assert choice.shape == (len(study.test_set), 4) and np.allclose(choice.sum(axis=1), 1)

    # a participant goes through it and every stored decision replays from the stored answers
    rng = np.random.default_rng(3)
    people = [run_participant(study, rng) for _ in range(2)]
    looper = next(p for p in people if p.condition.name == "loop")
    assert looper.completed_at and looper.loop_steps.filter(kind="check").exists()
    assert closedloop.replay(Participant.objects.get(pk=looper.pk)) == []

    # a retry of the finished job changes nothing
    before = loop.closed_loop
    job = jobs.wait(jobs.retry(job), progress=False, timeout=240)
    assert job.status == Job.SUCCEEDED or "participants" in job.error  # refused once people have started
    assert study.conditions.get(name="loop").closed_loop == before


@pytest.mark.slow
def test_a_study_of_one_closed_loop_condition_alone(inprocess_worker, transactional_db, tiny_table, settings,
                                                    tmp_path):
    settings.VAR_DIR = tmp_path
    job = create_study_job(tiny_table, check_job({"slug": "only-loop", "test_set_thresholds": TINY_TEST_SET,
                                                 "closed_loop": {"solo": {"check_every": 0, "max_examples": 3}}}))
    job = jobs.wait(job, progress=False, timeout=240)
    assert job.status == Job.SUCCEEDED, job.error
    study = Study.objects.get(slug="only-loop")
    assert [c.name for c in study.conditions.all()] == ["solo"] and study.is_open
    assert study.conditions.get().closed_loop["settings"]["max_examples"] == 3


@pytest.mark.slow
def test_a_closed_loop_condition_the_build_cannot_prepare_is_said_in_one_line(inprocess_worker, transactional_db,
                                                                              tiny_table, settings, tmp_path,
                                                                              staff_client):
    """The last task writes each closed-loop condition's pack under VAR_DIR; where it cannot (here a file
    stands where its folder goes), the job page says so in one line with what to change, not as an
    exception, and the study stays closed."""
    settings.VAR_DIR = tmp_path
    (tmp_path / "closedloop").write_text("not a folder")
    job = create_study_job(tiny_table, check_job({"slug": "unwritable-loop", "test_set_thresholds": TINY_TEST_SET,
                                                 "closed_loop": {"loop": {"max_examples": 3}}}))
    job = jobs.wait(job, progress=False, timeout=240)
    assert_refused_in_one_line(job, staff_client, "unwritable-loop", "ClosedLoopError",
                               "A closed-loop condition could not be prepared")
    assert job.error.startswith("A closed-loop condition could not be prepared: cannot write a closed-loop "
                                f"condition to {tmp_path / 'closedloop'}/unwritable-loop--loop--")
    assert job.error.endswith("The server's data folder (VAR_DIR) must be writable by the worker, with room to "
                              "spare; ask whoever runs the server, then build again.")


def test_a_table_that_leaves_no_check_question_is_refused_with_what_to_change(tiny_table):
    """Checks come from the environments the final tests leave over: none left, the refusal names the
    settings that would leave some."""
    table = TrajectoryTable.load(tiny_table)
    every_environment = [{"env_id": int(e)} for e in table.env_ids]
    with pytest.raises(ClosedLoopError) as caught:
        select_checks(table, every_environment)
    assert closed_loop_refusal(caught.value) == (
        "A closed-loop condition could not be prepared: no environment left over from the final tests can be a "
        "check question. Lower the test set's thresholds, choose another difficulty or test kind, or build the "
        "study without a closed-loop condition.")


@pytest.mark.parametrize("text, settings", [
    ("loop", {}),
    ("cl:model=det-reward,value=none,feedback=off", {"model": "det-reward", "value": None, "feedback": False}),
    ("cl: max_examples = 5 , lapse=0.2,", {"max_examples": 5, "lapse": 0.2}),
])
def test_parse_closed_loop_reads_each_setting_as_its_type(text, settings):
    assert parse_closed_loop(text)[1] == settings


@pytest.mark.parametrize("text, message", [
    (":model=exact", "give the condition's name first"),
    ("cl:speed=2", "'speed=2' is not setting=value with a setting of model, value"),
    ("cl:feedback=maybe", "feedback='maybe' is not a bool"),
    ("cl:max_examples=2.5", "max_examples='2.5' is not a int"),
])
def test_parse_closed_loop_says_what_it_cannot_read(text, message):
    with pytest.raises(StudyJobError, match=message.replace("(", r"\(")):
        parse_closed_loop(text)


@pytest.mark.parametrize("loops, message", [
    ({"cl": {"lapse": 0}}, "closed-loop condition 'cl': the lapse rate must lie in (0, 1]"),
    ({"cl": {"model": "nonsense"}}, "closed-loop condition 'cl': unknown learner model"),
    ({"random": {}}, "a condition is listed twice"),
    ({"cl": "det-reward"}, "closed-loop condition 'cl': 'closed_loop' must be an object of settings"),
])
def test_bad_closed_loop_settings_are_refused_before_any_task(db, tiny_table, loops, message):
    with pytest.raises(SpecError, match=message.replace("(", r"\(").replace("]", r"\]")):
        check_job({"slug": "bad-loop", "conditions": ["random"], "closed_loop": loops})
    assert not Study.objects.filter(slug="bad-loop").exists()


def test_the_command_reports_bad_closed_loop_settings_in_one_line(db, tiny_table):
    with pytest.raises(CommandError, match="--closed-loop cl: max_examples='many'"):
        call_command("build_study", "--table", str(tiny_table), "--slug", "x", "--closed-loop",
                     "cl:max_examples=many", stdout=io.StringIO())


# --- the designer ----------------------------------------------------------------------------------
DESIGN = {"slug": "designed-loop", "name": "Designed loop", "conditions": ["random"], "target_per_condition": "20",
          "recruitment": "link", "approx_star": "det-euclidean", "seed": "0", "min_regret": "0.001",
          "min_distance": "0.5", "estimated_minutes": "15", "loop_name": "adaptive", "loop_model": "det-euclidean",
          "loop_value": "", "loop_lapse": "0.2", "loop_max_examples": "4", "loop_check_every": "2",
          "loop_feedback": "on"}


@pytest.mark.slow
def test_the_designer_builds_a_closed_loop_condition_with_its_model_from_a_fit(
        inprocess_worker, transactional_db, demo_table, settings, tmp_path, staff_client):
    """The fit's study is simulated with learners of det-euclidean (τ = 1, lapse 0.1): the loop takes that
    model, its τ and a lapse rate near 0.1 from it, in place of the form's det-euclidean defaults."""
    from studyapp.analysis.simulate import simulate  # noqa: PLC0415
    from studyapp.researcher.studies import make_study  # noqa: PLC0415
    from teaching.api import SimulatedLearner  # noqa: PLC0415

    settings.VAR_DIR, settings.TABLES_DIR = tmp_path, demo_table.parent
    source = make_study(demo_table, "pilot-answers")
    simulate(source, n_per_condition=12, seed=2, learner=SimulatedLearner("det-euclidean", 1.0, 0.1))
    page = staff_client.get("/precompute/design/").content.decode()
    assert "Closed-loop condition: name" in page and 'value="pilot-answers"' in page
    form = dict(DESIGN, table=str(demo_table), loop_model="prob-reward", loop_fit_from="pilot-answers")
    r = staff_client.post("/precompute/design/", form)
    assert r.status_code == 302, r.content.decode()[-3000:]
    job = jobs.wait(Job.objects.get(kind=Job.STUDY, params__slug="designed-loop"), progress=False, timeout=300)
    assert job.status == Job.SUCCEEDED, job.error
    assert job.params["closed_loop_fit"] == {"adaptive": "pilot-answers"}
    loop = Study.objects.get(slug="designed-loop").conditions.get(name="adaptive").closed_loop["settings"]
    # τ: the middle of the likelihood's best step, near the generating 1.0 (within half a grid step)
    assert loop["model"] == "det-euclidean" and abs(np.log10(loop["value"])) < 0.125 and abs(loop["lapse"] - 0.1) < 0.06
    assert (loop["max_examples"], loop["check_every"], loop["feedback"]) == (4, 2, True)  # the form's
    assert "the best fit to study 'pilot-answers': det-euclidean" in job.result["closed_loop"]["adaptive"]["from_fit"]


@pytest.mark.parametrize("change, field, message", [
    ({"loop_name": "random"}, "loop_name", "already (another name of) one of the chosen conditions"),
    ({"loop_check_every": "5"}, "loop_check_every", "check_every must be a whole number from 0"),
    ({"loop_lapse": "0"}, "loop_lapse", "greater than or equal to 0.001"),
    ({"loop_name": "", "loop_fit_from": "fitted"}, "loop_name", "Name the closed-loop condition"),
    ({"loop_value": "-1"}, "loop_value", "must be"),
])
def test_the_designers_closed_loop_errors_are_said_under_their_fields(db, demo_table, settings, make_study,
                                                                      change, field, message):
    from precompute.design import StudyDesignForm  # noqa: PLC0415
    from precompute.tables import built_tables  # noqa: PLC0415

    settings.TABLES_DIR = demo_table.parent
    make_study(slug="fitted")
    form = StudyDesignForm(dict(DESIGN, table=str(demo_table), **change), tables=built_tables())
    if change.get("loop_fit_from"):
        form.fields["loop_fit_from"].choices += [("fitted", "fitted")]
    assert not form.is_valid()
    assert any(message in e for e in form.errors.get(field, [])), form.errors
