"""The web side speaks no robot's words of its own: whatever a page says of the robot comes from the
study's domain (Domain.texts, its cluster and class names), so the code, templates and generic
scripts of ``studyapp/``, ``precompute/``, ``templates/`` and ``static/`` never name the car.  The
driving domain's own scene files (``static/studyapp/scenes/driving.*``) are the car's to draw."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DIRS = ("studyapp", "precompute", "templates", "static")
SUFFIXES = {".py", ".html", ".js", ".css", ".txt"}
DRIVING_WORDS = {"car", "cars", "drive", "drives", "driven", "driver", "drivers", "driving", "lane", "lanes",
                 "highway", "highways", "road", "roads", "merging", "braking", "tailgating", "tailgate", "steer",
                 "steering", "ft", "autonomous", "overtake"}
# The driving domain's own files: its scene script and style sheet draw the car.
OWN_FILES = {"static/studyapp/scenes/driving.js", "static/studyapp/scenes/driving.css"}
# (file, text of the line): the only lines that may name the car, and why.
ALLOWED = {
    # Study.domain's default: the domain a study stored before domains existed was drawn in (its
    # migrations say the same); a callable default would only move the name.
    ("studyapp/models.py", 'max_length=40, default="driving", editable=False,'),
}


def files() -> list[Path]:
    out = []
    for top in DIRS:
        for path in sorted((ROOT / top).rglob("*")):
            rel = path.relative_to(ROOT).as_posix()
            if (path.is_file() and path.suffix in SUFFIXES and "migrations" not in path.parts
                    and "__pycache__" not in path.parts and rel not in OWN_FILES):
                out.append(path)
    return out


def words_of(line: str) -> list[str]:
    """Every word of a line, snake_case, kebab-case and CamelCase split into parts."""
    return [part.lower() for run in re.findall(r"[A-Za-z]+", line) for part in re.findall(r"[a-z]+|[A-Z][a-z]*", run)]


def hits(path: Path) -> list[str]:
    rel = path.relative_to(ROOT).as_posix()
    found = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if (rel, line.strip()) in ALLOWED:
            continue
        bad = sorted(set(words_of(line)) & DRIVING_WORDS)
        if bad:
            found.append(f"{rel}:{number} {bad}: {line.strip()[:100]}")
    return found


def test_the_web_side_names_no_car():
    found = [h for path in files() for h in hits(path)]
    assert not found, "\n".join(found)


def test_the_check_reads_every_kind_of_file_and_would_catch_the_car(tmp_path):
    scanned = {p.relative_to(ROOT).as_posix() for p in files()}
    assert {"studyapp/participant/forms.py", "studyapp/data/exports.py", "studyapp/conditions.py",
            "templates/studyapp/step_test.html", "precompute/templates/precompute/design.html",
            "static/studyapp/player.js", "static/studyapp/study.css", "static/studyapp/scenes/gridworld.js"} <= scanned
    assert not scanned & OWN_FILES
    for line in ('"required": "Please choose the option that matches the car\'s driving style.",',
                 "// every canvas is drawn at one px/ft", "const otherCar = env.other;",
                 'help_text="the optimal drive of each θ"', "<p>the car_length</p>"):
        assert words_of(line) and set(words_of(line)) & DRIVING_WORDS, line
    sample = tmp_path / "sample.py"
    sample.write_text('x = "gridworld yard"\n')
    assert not set(words_of(sample.read_text())) & DRIVING_WORDS


def test_every_allowed_line_is_still_there():
    """An allowance outlives its line by mistake only: each is a line of its file today."""
    for rel, text in ALLOWED:
        assert text in [line.strip() for line in (ROOT / rel).read_text().splitlines()], (rel, text)


def test_the_designers_hints_name_every_domains_own_numbers(db):
    """What was the car's and the yard's numbers written into the help texts is each registered domain's."""
    from precompute.design import StudyDesignForm  # noqa: PLC0415  (Django only here)
    from precompute.tables import TableBuildForm  # noqa: PLC0415
    from teaching.api import domain_names, get_domain  # noqa: PLC0415

    distance = StudyDesignForm(tables=[]).fields["min_distance"].help_text
    envs = TableBuildForm().fields["envs"].help_text
    for name in domain_names():
        domain = get_domain(name)
        assert f"{name}: {domain.min_option_distance}" in distance
        assert f"{name}: {domain.n_environments:,}" in envs
