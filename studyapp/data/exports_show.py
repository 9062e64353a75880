"""The export columns of a show study (``Study.test_kind == "show"``): each test asks the participant to move
the robot the way they think it would go, so a test's answer is a way (its moves), its regret under θ* and
whether it is optimal, not an option, ratings and a confidence score.

Kept apart from :mod:`studyapp.data.exports` so that a choice study's files, columns and dictionary are exactly
what they were: these columns appear only in a show study's files.
"""
from __future__ import annotations

from ..guards.csvsafe import neutralise

# Units, said once: regret is a difference of θ*'s rewards, so it is in whatever units θ*'s reward function has.
_REGRET = ("theta*'s optimal reward in the test's environment minus the reward (under theta*) of the way shown, "
           "in theta*'s units: 0 = an optimal way, larger = further from optimal")

# Long file: test rows of a show study (empty on other rows), before answer_json.
SHOW_LONG_COLUMNS = [
    ("moves", "Show test: the moves the participant made, in order from the start, space separated "
              "(e.g. 'right up pickup')."),
    ("regret", f"Show test or check: {_REGRET}."),
    ("optimal", "Show test or check: 1 if the way shown is optimal for theta* (the most reward under theta*), "
                "else 0."),
]
# The long file's choice cells: a show study's test and check rows have none, so its file leaves them out.
CHOICE_CELLS = ("chosen_option", "chosen_display_position", "chosen_is_theta_star", "chosen_rating",
                "confidence_score", "rating_0", "rating_1", "rating_2", "rating_3", "theta_star_option",
                "display_order")
# Wide file: in a show study these stand where a choice study has mean_confidence_score and n_correct.
SHOW_SUMMARY_COLUMNS = [
    ("mean_regret", f"Mean regret over the tests ({_REGRET}); empty unless every test was answered (status "
                    "complete or excluded): an incomplete participant's testJ_regret columns still hold what they "
                    "answered."),
    ("share_optimal", "Share (0-1) of the tests where the way shown is optimal for theta*; empty unless every test "
                      "was answered, as mean_regret."),
]


def show_long_columns(long_columns: list) -> list[tuple[str, str]]:
    """A show study's long columns: `long_columns` (exports.LONG_COLUMNS) without the choice cells (its
    tests and its closed loops' checks all show the way), and with SHOW_LONG_COLUMNS before answer_json."""
    columns = [c for c in long_columns if c[0] not in CHOICE_CELLS]
    at = [c for c, _ in columns].index("answer_json")
    return columns[:at] + SHOW_LONG_COLUMNS + columns[at:]


def show_wide_columns(wide_columns: list) -> list[tuple[str, str]]:
    """A show study's wide columns before its tests': `wide_columns` (exports.WIDE_COLUMNS) up to
    n_tests_answered, then SHOW_SUMMARY_COLUMNS."""
    names = [c for c, _ in wide_columns]
    return wide_columns[:names.index("n_tests_answered") + 1] + SHOW_SUMMARY_COLUMNS


def show_test_columns(j) -> list[tuple[str, str]]:
    """The wide file's columns of test j of a show study (j = 0, 1, ...; "<j>" in the dictionary)."""
    return [(f"test{j}_env_id", f"Test {j}: environment id."),
            (f"test{j}_moves", f"Test {j}: the moves the participant made, space separated."),
            (f"test{j}_regret", f"Test {j}: regret ({_REGRET})."),
            (f"test{j}_optimal", f"Test {j}: 1 if the way shown is optimal for theta*, else 0.")]


def moves_text(data: dict) -> str:
    """A show answer's moves as one cell; neutralised, as they come from what the participant's page sent."""
    return neutralise(" ".join(str(m) for m in data.get("moves") or []))


def show_test_fields(answer: dict, difficulty: str = "") -> dict:
    """The long file's test cells of a show test's answer."""
    regret = answer["regret"]
    return {"moves": moves_text(answer["data"]), "regret": "" if regret is None else regret,
            "optimal": "" if answer["correct"] is None else int(answer["correct"]), "test_difficulty": difficulty}


def show_wide_fields(tests: list[dict], every_test: bool) -> dict:
    """The wide file's test columns and means of one participant's show tests (`tests`: their answers by
    item); the means only when `every_test` was answered (a mean over some tests is not the measure)."""
    row = {}
    for a in tests:
        j = a["item"]
        row.update({f"test{j}_env_id": a["data"].get("env_id", ""), f"test{j}_moves": moves_text(a["data"]),
                    f"test{j}_regret": "" if a["regret"] is None else a["regret"],
                    f"test{j}_optimal": "" if a["correct"] is None else int(a["correct"])})
    regrets = [a["regret"] for a in tests if a["regret"] is not None]
    whole = every_test and tests and len(regrets) == len(tests)
    row["mean_regret"] = round(sum(regrets) / len(regrets), 6) if whole else ""
    row["share_optimal"] = round(sum(bool(a["correct"]) for a in tests) / len(tests), 6) if whole else ""
    return row
