"""Adapter from the numeric core (``teaching``) to the JSON a study stores, for any domain.

A condition stores, per training environment, everything the browser needs to draw it, and the
study stores the shared test set with each option's path, so the server never needs the
trajectory table while a study runs.  What a scene holds is the domain's
(``Domain.scene_payload``: what its page script draws, docs/domains.md); this module adds what
every domain's payload has::

    {"env_id": 123, "env_class": 0, "class_name": "...", "cluster": 1, "cluster_name": "...",
     **domain.scene_payload(123), "robot": stimulus_of(domain, 123, theta_index, states)}

A test adds ``options``: ``[{"theta_index", "is_theta_star", "cluster", "cluster_name", "robot"}] * 4``
in canonical order (the display order is drawn per participant).  A "show the way" test has no options:
it adds ``"kind": "show"`` and ``"optimum"`` (θ*'s reward there); its ``robot`` is θ*'s own way, kept on
the server to score and review, never sent to the participant's page.

Both read a real ``teaching.core.table.TrajectoryTable`` and draw with the table's own domain:
:func:`training_from_table` (theta*'s optimal trajectory in each training environment) and
:func:`test_set_from_table` (each test option's, from ``teaching.core.testset.select_test_set``).
No trajectory is drawn from anywhere else.
"""
from __future__ import annotations

import logging

import numpy as np

from teaching.api import (
    SHOW,
    Domain,
    TableError,
    domain_names,
    get_domain,
    is_show,
    register_table_robot,
    shows_the_way,
    stimulus_of,
)


def study_domain(study) -> Domain:
    """The domain a study's stimuli were drawn in (Study.domain)."""
    find_robot(study)
    return get_domain(study.domain)


def find_robot(study) -> None:
    """A study of an imported robot registers the robot its table carries (docs/importing.md) the first time this
    process needs it, so the site and the workers need no setting for it; a study of a registered robot costs a
    lookup.  A table gone or broken is logged, and the study then reads as one whose robot is not here."""
    table = (getattr(study, "source", None) or {}).get("table")  # a study's stand-in may carry no source
    if study.domain in domain_names() or not table:
        return
    try:
        register_table_robot(table)
    except TableError as exc:
        logging.getLogger(__name__).warning("study %s: %s", study.slug, exc)


def env_payload(domain: Domain, env_id: int, env_class: int, states, cluster: int, theta_index: int) -> dict:
    """JSON for one environment of class `env_class`: its scene, and what it shows of objective `theta_index`'s
    path `states` (T+1, S) labelled `cluster` (``stimulus_of``: its rows, or its recording's opaque name)."""
    cls = int(env_class)
    return {"env_id": int(env_id), "env_class": cls, "class_name": domain.class_names[cls],
            "cluster": int(cluster), "cluster_name": domain.cluster_names[int(cluster)],
            **domain.scene_payload(int(env_id)), "robot": stimulus_of(domain, env_id, theta_index, states)}


def drawn_scene(payload: dict, *, robot: bool, domain: Domain) -> dict:
    """What a participant's page may carry of an environment payload: what it draws.

    The domain's ``page_keys`` of it (``Domain.page_scene``), and with `robot` the robot's path
    too (a training example).  A test page draws four options, sent separately under their
    display letters; everything else in a payload (environment and theta ids, classes, strategy
    clusters, theta*'s own trajectory) stays on the server."""
    scene = domain.page_scene(payload)
    if robot:
        scene["robot"] = payload["robot"]
    return scene


def study_view(domain: Domain, conditions, test_set, extra=()) -> dict:
    """What every canvas of a study shares (``Domain.study_view``) over all its training examples
    and test options, and `extra` (page scene, robot path) pairs: e.g. one scale that holds every
    canvas's motion."""
    scenes = [(domain.page_scene(env), env["robot"]) for training in conditions for env in training]
    scenes += [(domain.page_scene(t), o["robot"]) for t in test_set for o in t.get("options", ())]
    scenes += [(domain.page_scene(t), t["robot"]) for t in test_set if is_show(t)]
    return domain.study_view(scenes + list(extra))


def option_payload(domain: Domain, env_id: int, theta_index, is_theta_star, cluster, states) -> dict:
    return {
        "theta_index": None if theta_index is None else int(theta_index),
        "is_theta_star": bool(is_theta_star),
        "cluster": int(cluster),
        "cluster_name": domain.cluster_names[int(cluster)],
        "robot": stimulus_of(domain, env_id, theta_index, states),
    }


def test_kind_of(tests: list[dict]) -> str:
    """"show" when every test asks to show the way, "choose" when every test has options; ValueError for a
    mix (a study's tests are one kind: the analysis compares one measure across its conditions)."""
    kinds = {SHOW if is_show(t) else "choose" for t in tests}
    if len(kinds) > 1:
        raise ValueError("a test set mixes 'show' tests with tests that have options; a study's tests are one kind")
    return kinds.pop() if kinds else "choose"


def check_test_set(tests: list[dict]) -> None:
    """Tests of one kind: a choice test needs >= 2 options and exactly one that is theta*'s; a show
    test has no options."""
    test_kind_of(tests)
    for j, test in enumerate(tests):
        if is_show(test):
            if test.get("options"):
                raise ValueError(f"test {j} asks to show the way and cannot have options")
            continue
        if len(test["options"]) < 2:
            raise ValueError(f"test {j} has fewer than 2 options")
        if sum(bool(o["is_theta_star"]) for o in test["options"]) != 1:
            raise ValueError(f"test {j} must have exactly one theta* option")


# --- from a real trajectory table ----------------------------------------
def _env_index(table, env_id: int) -> int:
    hits = np.flatnonzero(np.asarray(table.env_ids) == env_id)
    if not len(hits):
        raise ValueError(f"environment {env_id} is not in the table")
    return int(hits[0])


def _star_payload(table, env_id: int) -> tuple[int, dict]:
    i = _env_index(table, int(env_id))
    star = table.theta_star_index
    return i, env_payload(table.domain, int(env_id), table.env_class[i], table.states(i, star),
                          table.strategy[i, star], star)


def training_from_table(table, env_ids) -> list[dict]:
    """Payloads of theta*'s trajectories in the given environments, in order."""
    return [_star_payload(table, env_id)[1] for env_id in env_ids]


# What a graded test (select_test_set with a difficulty) says of itself, kept with its payload: the
# analysis reports scores by difficulty.
GRADED_KEYS = ("difficulty", "bec_size", "bec_tertiles", "graded")


def cannot_show(domain: Domain) -> str | None:
    """Why `domain` can have no "show the way" tests (one line), or None: it must replay and score a way
    a participant shows (``Domain.score_shown``)."""
    if shows_the_way(domain):
        return None
    return (f"the {domain.name} domain cannot replay and score a way a participant shows, so it has no 'show the "
            "way' tests (grid worlds from a file have them)")


def show_tests_from_table(table, tests) -> list[dict]:
    """Payloads of "show the way" tests (``teaching.api.select_show_tests``' dicts, or any with an
    ``env_id``): the environment's scene, θ*'s way in it and its reward (``optimum``).  ValueError if
    the table's domain cannot have them (:func:`cannot_show`).  A graded test keeps its GRADED_KEYS."""
    problem = cannot_show(table.domain)
    if problem:
        raise ValueError(problem)
    star = table.theta_star_index
    theta_star = np.asarray(table.theta_star, np.float64)
    out = []
    for test in tests:
        i, payload = _star_payload(table, int(test["env_id"]))
        payload.update(kind=SHOW, optimum=float(np.asarray(table.features[i, star], np.float64) @ theta_star))
        payload.update({k: test[k] for k in GRADED_KEYS if k in test})
        out.append(payload)
    check_test_set(out)
    return out


def test_set_from_table(table, test_set) -> list[dict]:
    """Payloads of a test set from ``teaching.core.testset.select_test_set`` (a graded test keeps its
    GRADED_KEYS)."""
    out = []
    star = table.theta_star_index
    for test in test_set:
        i, payload = _star_payload(table, int(test["env_id"]))
        for o in test["options"]:
            if not 0 <= int(o["theta_index"]) < table.n_thetas:
                raise ValueError(f"test in environment {test['env_id']}: theta index {o['theta_index']} is not "
                                 f"in the table (0..{table.n_thetas - 1})")
            if bool(o["is_theta_star"]) != (int(o["theta_index"]) == star):
                raise ValueError(f"test in environment {test['env_id']}: option theta {o['theta_index']} says "
                                 f"is_theta_star={o['is_theta_star']}, but theta* is theta {star} in this table")
        payload["options"] = [
            option_payload(table.domain, test["env_id"], o["theta_index"], o["is_theta_star"],
                           table.strategy[i, o["theta_index"]], table.states(i, o["theta_index"]))
            for o in test["options"]]
        payload.update({k: test[k] for k in GRADED_KEYS if k in test})
        out.append(payload)
    check_test_set(out)
    return out
