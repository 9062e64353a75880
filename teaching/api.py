"""What the web side (``studyapp``) and the workers (``precompute``) use from ``teaching``.

They import from here only, so the numeric core can move its modules around behind this list
(tests may still reach into the modules).  The core (``teaching.core``) knows no robot; the
names under "World and environments" and "Strategies" are the driving domain's
(``teaching.domains.driving``), kept for scripts about the car; the web side reads a study's robot
through ``get_domain(study.domain)`` only.  Plain re-exports: every name below is the module's
own object, documented here with its shapes and units.  Like the rest of the package this
module never imports Django (tests/teaching/test_api.py checks it in a fresh interpreter).

Units: positions in ft (x across the road, y along it, relative to the robot's start), speeds
in ft/s, time in s (a drive is ``WORLD.horizon`` = 20 steps of ``WORLD.dt`` = 0.25 s).
M environments, N candidate objectives θ (θ* is θ index 0), T+1 = 21 states per trajectory.

World and environments
    WORLD: World             lane_width, lane_centres (ft), car_length, car_width (ft), horizon,
                             dt (s), road_half_width (ft), ...: the constants a drawing needs
    GOAL_NAMES               ("merge right", "drive forward"), indexed by an environment's goal
    N_ENVIRONMENTS           21,216: environment ids are 0 .. N_ENVIRONMENTS - 1
    CLASS_NAMES              ("merging", "braking", "tailgating", "other"), indexed by class
    get_environments(ids)    Environments: parallel (n,) arrays (goal, other_y0 ft, other_lane,
                             other_v0 ft/s, accel_time s, v_final ft/s); all 21,216 without ids
    environment_class(envs)  (n,) int8 class index into CLASS_NAMES
    other_car_states(envs)   (n, T+1, 2) float64 other car's [x, y] in ft at every step
    stratified_sample(n, seed=0)  (n,) int64 sorted environment ids, equal share per class

Strategies (what a trajectory does; the paper's coverage clusters)
    N_CLUSTERS, CLUSTER_NAMES  8 clusters, two per class (2k, 2k+1 belong to class k)
    strategy_labels(states, envs)  states (n, T+1, 5) or (n, N, T+1, 5) [x, y, heading rad,
                             v ft/s, steer rad] -> (n,) or (n, N) int8 cluster (8: no strategy)

Domains (teaching.core.domain)
    Domain                   the interface a robot implements, in three declared parts: WorldPart
                             (names, classes, clusters, features, θ*), PlannerPart (planning, the
                             stored encoding, states) and PagesPart (scene payloads, palette, texts);
                             shows_the_way(domain): whether it has the optional ShowWayPart;
                             stimulus_of(domain, env_id, theta_index, states) what a page shows of
                             a trajectory (its recording's opaque name under the optional
                             RecordingsPart, else its path rows); recording_file(domain, name)
                             get_domain(name=None) the registered one (None: default),
                             domain_names() every registered name, default_domain_name()
    ParticipantTexts, LegendEntry  what a domain's pages tell participants
    TranslatableError        a refusal a participant reads (teaching.core.i18n): English str(), and
                             its marked message and values to say it in their language

Choice model (teaching.core.choice; docs/analysis.md)
    option_choice(model, belief, table, env_index, options, lapse)  (K,) P(a learner of `model`
                             believing `belief` (N,) picks option k), the options being the optimal
                             trajectories of θ indices `options`; OptionDistances, choice_probabilities

Fitting learner models to answers (teaching.core.fitting, .bms, .simulate; docs/analysis.md)
    Question(env_index, options)  one test: a table row and the θ indices of its K options
    questions_of(table, test_set) -> (Questions, (T,) position of θ*'s option): a study's test set
    Answers                  what a study collected: sequence_names, sequences (table rows), tests,
                             group (P,), choice (P, T) option index or -1, ratings (P, T, K) or None
    compare_models(table, answers, names=None) -> Comparison: .fits (ModelFit each: τ / λ, ε,
                             log_lik, cv_log_lik, aic, bic, per participant), .bms (exceedance
                             probabilities), .rows() one dict per model (rank: equal within
                             TIE_TOLERANCE, tied_with); FitError (one line) if unfittable
    SimulatedLearner(model, value, lapse)  who a model-based simulated participant is; AnswerModel(
                             table, learner, tests) its P(option) per test for a sequence, .answer()
    pilot_predictions(table, models, sequences, test_set)  a study's model-based pilot as JSON: each
                             model's (T, K) P(option) with no lapse after each condition's examples
    predicted_scores(choice (T, K), star (T,), lapse) -> PredictedScores(accuracy, mean, sd): what
                             those participants score (the confidence score, -7 .. 7), in expectation

Closed-loop teaching (teaching.core.closedloop; docs/study.md)
    ClosedLoopSpec(model, value, lapse, max_examples, check_every, feedback, stop_at)  how a
                             closed-loop condition teaches; ClosedLoopError (one line) if bad
    select_checks(table, final_tests, seed=1)  check questions, dicts as select_test_set's, on
                             environments apart from the final tests; select_show_checks(table, final_tests,
                             seed=1) the same where the participant shows the way (each with its ``ways``:
                             distinct_ways(table, row), the distinct trajectories it is a choice among);
                             check_questions(table, checks) their Questions
    ClosedLoop.build(table, spec, checks, exclude=final test rows)  .decide(events) -> Decision: the
                             next step (example / check / feedback / done, a table row) with what it
                             was based on; .replay(events, decisions) -> a line per disagreement
    Event(kind, env_index, question=None, answer=None)  what a participant was shown or answered
    run_learner(loop, table, learner, rng)  a SimulatedLearner through the loop: (events, decisions)
    loop_pilot(loop, table, models, test_set)  the pilot's row of a closed loop: each user model's simulated
                             participants through it, averaged (P(θ*), P(option) in each test)
    write_pack(path, table, loop), load_pack(path, expected_hash=None) -> Pack  the condition on disk
                             for web workers: .loop (its arrays memory-mapped read-only), θ*'s
                             trajectories .star_states (M, T+1, S), .env_ids, .env_class, .star_cluster

Tables (teaching.core.table: a directory of .npy arrays plus meta.json with its content hash)
    TrajectoryTable          .load(path, verify=True, expected_hash=None); thetas (N, D),
                             env_ids (M,) int64, features (M, N, D), strategy (M, N) int8,
                             d_euclid (M, N) float32; .states(env_index, theta_index) ->
                             (..., T+1, S); .domain its Domain; .env_class (M,) int8;
                             .meta["content_hash"] identifies the table
    TableError               ValueError: a missing, altered or foreign table (one-line message)
    register_table_robot(path)  the robot a table made by import-table carries, registered by name for a
                             process that looks it up before loading the table; its name (TableError if broken)

Building a table in chunks (teaching.core.build; precompute/work.py runs one chunk per task)
    Preset, PRESETS, get_preset(name), customised(preset, n_envs=, n_thetas=, seed=, sampler=,
                             theta_star=)  what to build (M environments x N thetas, seeded)
    SAMPLERS                 the ways the other θs are drawn
    default_normalisers()    (5,) float64 feature scales, part of a table's identity
    table_identity(preset, thetas, normalisers)  dict naming the table chunks belong to
    chunks_of(env_ids, size) list of (<= size,) int64 id arrays
    chunk_key(identity, env_ids), chunk_path(out, key)  where a chunk is stored
    build_chunk(out, identity, env_ids, thetas, normalisers, domain)  plan and store one chunk
    assemble(out, preset, identity, env_ids, thetas, normalisers)  publish the table
    check_writable(out)      TableError unless chunks can be written under out
    code_fingerprint(domain=None)  16 hex digits over teaching/core and the domain's code_roots

Learners and selection (DESIGN §5-6)
    MODEL_NAMES              the 7 learner models (the paper's ideal users)
    model_names()            every registered model: the 7 and the hierarchical learner
    make_model(name, value=None)  a learner; value is τ or λ (> 0), ValueError if bad
    has_hyperparameter(model)  whether τ / λ changes that model's likelihoods
    parse_hyperparameters(["MODEL=VALUE", ...])  {model: τ or λ}, ValueError if bad
    CONDITIONS               the study's 9 conditions, in the paper's order
    ALL_CONDITIONS           those and the conditions a study may add ("hierarchical": its learner's
                             greedy sequence)
    APPROX_STAR              "det-euclidean": the model coverage-approx* augments by default
    SelectionSettings        frozen: grid (τ / λ values swept), epsilon, max_examples, allow_repeats
    build_sequences(table, seed=0, ...)  {condition: environment ids in the order shown}
    condition_sequence(table, name, seed=0, ..., params=None)  (Sequence of table row indices, with
                             P(θ*) after each example; its model; whether the τ / λ rule held or None);
                             name: any registered selector; condition_params(name, params=None,
                             approx_star=) every parameter it runs with (approx* as a coverage condition's
                             model unless params name one, defaults filled): what a study records
    selector_names()         every registered selector (teaching.core.selectors): the conditions above
                             (greedy under each learner model, random, coverage-approx*, coverage-random)
                             and any added; get_selector(name) -> Selector (.params: {name: Param
                             (default, check, doc)}, .doc); check_params(name, params) -> every
                             parameter checked, defaults filled (ValueError, one line, naming it);
                             parse_selector("bec-scaffold:k=2") -> (label, name, checked parameters)
    select_test_set(table, training_env_ids, seed=0, min_regret=, min_distance=, difficulty=None)  6 dicts:
                             env_id, env_index, cluster and 4 options {theta_index, is_theta_star, cluster,
                             regret}; with a difficulty also difficulty, bec_size (exact, in [0, 1]),
                             bec_tertiles and graded ("all" or "cluster": the tertiles' scale)
    DIFFICULTIES             ("low", "medium", "high"): a graded test's levels, by tertile of exact BEC size
                             (large BEC = easy = low; teaching.core.difficulty); TeachOutput.test_difficulty
    MIN_REGRET, MIN_OPTION_DISTANCE  the test set's default thresholds: θ*-reward units (1e-3), and
                             scaled state units between options (0.5)
    select_show_tests(table, training_env_ids, seed=0, min_regret=MIN_REGRET, min_share=MIN_SHARE,
                      difficulty=None)
                             "show the way" tests (teaching.core.showtests), one per test cluster that has an
                             eligible environment: dicts {env_id, kind: "show", cluster, share_worse (the
                             fraction of the N θ clearly worse under θ* there, >= min_share = 0.25)}
    supply_of_tests(table, kind="choose", training_env_ids=(), min_regret=, min_distance=)  TestSupply: per
                             test cluster, how many environments could hold its test, at any difficulty
                             and per level (.counts(d), .feasible(d), .problem(d): one line, .describe());
                             clusters_without_a_test(table, kind): the clusters none can (quick);
                             ungraded_problem(kind, clusters, missing): why those cannot (one line)
    TEST_KINDS               ("choose", "show"): what a test asks; TeachOutput.test_kind, one per output;
                             is_show(test) whether a test's dict asks to show the way (its "kind" is SHOW)

The teaching benchmark (teaching.benchmark; docs/benchmark.md)
    plan_benchmark(table_hash, selectors=None, learners=None, seeds=10)  [Cell]: every (selector, learner,
                             seed) of one table, content-addressed (Cell.key, 32 hex digits)
    run_benchmark_cells(table, cells, out)  [result dict]: each cell's P(θ*) after each example, computing
                             those not yet in out/cells/ (resumable); benchmark_batches(cells) the cells
                             grouped by the selection they share (a worker's unit);
                             read_benchmark_results(out, cells) their stored results, in order
    timed_benchmark(out, content_hash, cells, runner, compute)  compute()'s results, its wall time recorded in
                             out/runs/<content hash>.json where it computed cells (the leaderboard quotes it)
    write_benchmark_summary(out, [(table path, table, results)])  out/summary.md and summary.json
    read_benchmark_board(out, content_hash)  the leaderboard of one table as data (rows per selector: each
                             learner's rank and mean P(θ*), the held-out tests' measures), None if not run
                             there; ValueError (one line) for a file that is not one
    benchmark_arguments(parser, out_default=None), benchmark_plan(args)  the command's arguments, and
                             [(table path, table, cells)] as they ask (manage.py benchmark runs the same
                             on Celery workers)

Ideal users (the paper's simulated learners; teaching.core.evaluation)
    USER_NAMES               the matrix's columns: the 7 learner models (MODEL_NAMES) and the
                             hierarchical learner
    study_matrix(table, sequences, hyperparameters=None)  sequences {name: table row indices} ->
                             ((S, 8) float64 P_user(θ* | sequence's θ* demonstrations), {user: model
                             with its τ / λ: fixed in hyperparameters, else the paper's rule})
"""
from __future__ import annotations

from .benchmark.board import read_board as read_benchmark_board
from .benchmark.cells import plan_cells as plan_benchmark
from .benchmark.commands import add_arguments as benchmark_arguments
from .benchmark.commands import plan as benchmark_plan
from .benchmark.commands import write_summary as write_benchmark_summary
from .benchmark.run import batches as benchmark_batches
from .benchmark.run import read_results as read_benchmark_results
from .benchmark.run import run_cells as run_benchmark_cells
from .benchmark.run import timed as timed_benchmark
from .core.answers import Answers, FitError, Question, questions_of
from .core.build import (
    PRESETS,
    Preset,
    assemble,
    build_chunk,
    check_writable,
    chunk_key,
    chunk_path,
    chunks_of,
    code_fingerprint,
    customised,
    get_preset,
    table_identity,
)
from .core.candidates import SAMPLERS
from .core.choice import OptionDistances, choice_probabilities, option_choice
from .core.closedloop import (
    MAX_EXAMPLES_LIMIT,
    ClosedLoop,
    ClosedLoopError,
    ClosedLoopSpec,
    Decision,
    Event,
    check_questions,
    distinct_ways,
    run_learner,
    select_checks,
    select_show_checks,
)
from .core.closedloop_pack import Pack, load_pack, write_pack
from .core.closedloop_pilot import loop_pilot
from .core.conditions import build_sequences, condition_params, condition_sequence
from .core.difficulty import DIFFICULTIES
from .core.domain import (
    Domain,
    LegendEntry,
    ParticipantTexts,
    default_domain_name,
    domain_names,
    get_domain,
    shows_the_way,
)
from .core.evaluation import USER_NAMES, study_matrix
from .core.fitting import TIE_TOLERANCE, Comparison, compare_models
from .core.i18n import TranslatableError
from .core.learners import MODEL_NAMES, has_hyperparameter, make_model, model_names, parse_hyperparameters
from .core.recordings import recording_file, stimulus_of
from .core.selection import ALL_CONDITIONS, APPROX_STAR, CONDITIONS, SelectionSettings
from .core.selectors import check_params, get_selector, parse_selector, selector_names
from .core.showtests import MIN_SHARE, SHOW, is_show, select_show_tests
from .core.simulate import (
    AnswerModel,
    PredictedScores,
    SimulatedLearner,
    draw_answers,
    pilot_predictions,
    predicted_scores,
)
from .core.table import TableError, TrajectoryTable, register_table_robot
from .core.teachout import TEST_KINDS, TeachOutput, TeachOutputError, read_teach
from .core.testset import MIN_REGRET, TestSetError, select_test_set
from .core.testsupply import TestSupply, clusters_without_a_test, supply_of_tests, ungraded_problem
from .domains.driving.domain import DOMAIN as _DRIVING
from .domains.driving.environments import (
    CLASS_NAMES,
    N_ENVIRONMENTS,
    environment_class,
    get_environments,
    other_car_states,
    stratified_sample,
)
from .domains.driving.features import default_normalisers
from .domains.driving.strategies import CLUSTER_NAMES, N_CLUSTERS, strategy_labels
from .domains.driving.world import GOAL_NAMES, WORLD

MIN_OPTION_DISTANCE = _DRIVING.min_option_distance  # the car's; a table's own: table.domain.min_option_distance

__all__ = [
    "ALL_CONDITIONS", "APPROX_STAR", "CLASS_NAMES", "CLUSTER_NAMES", "CONDITIONS", "GOAL_NAMES", "MIN_OPTION_DISTANCE",
    "MIN_REGRET",
    "Domain", "LegendEntry", "ParticipantTexts", "TranslatableError", "default_domain_name", "domain_names",
    "get_domain", "recording_file", "shows_the_way", "stimulus_of",
    "MODEL_NAMES", "N_CLUSTERS", "USER_NAMES",
    "N_ENVIRONMENTS", "PRESETS", "SAMPLERS", "WORLD", "Preset", "SelectionSettings", "TableError",
    "TrajectoryTable", "assemble", "build_chunk", "build_sequences", "check_writable", "chunk_key", "chunk_path",
    "chunks_of", "code_fingerprint", "condition_params", "condition_sequence", "customised", "default_normalisers",
    "environment_class", "get_environments", "get_preset", "has_hyperparameter", "make_model", "other_car_states",
    "parse_hyperparameters", "select_test_set", "strategy_labels", "stratified_sample", "study_matrix",
    "table_identity",
    "OptionDistances", "choice_probabilities", "option_choice",
    "AnswerModel", "Answers", "Comparison", "FitError", "Question", "SimulatedLearner", "TIE_TOLERANCE",
    "compare_models", "model_names",
    "PredictedScores", "draw_answers", "pilot_predictions", "predicted_scores", "questions_of",
    "ClosedLoop", "ClosedLoopError", "ClosedLoopSpec", "Decision", "Event", "check_questions", "distinct_ways",
    "select_show_checks", "run_learner", "loop_pilot", "MAX_EXAMPLES_LIMIT",
    "select_checks", "Pack", "load_pack", "write_pack",
    "TeachOutput", "TeachOutputError", "read_teach",
    "check_params", "get_selector", "parse_selector", "selector_names", "DIFFICULTIES",
    "MIN_SHARE", "SHOW", "TEST_KINDS", "is_show", "select_show_tests",
    "TestSetError", "TestSupply", "clusters_without_a_test", "supply_of_tests",
    "ungraded_problem", "register_table_robot",
    "plan_benchmark", "run_benchmark_cells", "benchmark_batches", "read_benchmark_results",
    "write_benchmark_summary", "benchmark_arguments", "benchmark_plan", "read_benchmark_board",
    "timed_benchmark",
]
