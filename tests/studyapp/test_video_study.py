"""A study of a robot shown by its lab's videos (docs/importing.md, "Videos"): the tiny gridworld table exported,
given one clip per objective and imported back.  Its pages name each video by its SHA-256 alone, under the
participant's own link; the file served is the clip of that environment's objective, byte for byte; any other
name, another participant's link or a visitor who is not staff gets a 404 or the login page."""
from __future__ import annotations

import hashlib
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from django.test import Client
from django.urls import reverse

from studyapp.models import StepKind
from studyapp.participant.pages.questions import option_letters
from studyapp.researcher.durations import animation_seconds, estimates
from studyapp.researcher.studies import build_study
from teaching.api import TrajectoryTable, domain_names
from teaching.core.domain import unregister
from teaching.importing import registry
from teaching.importing.convert import import_table
from teaching.importing.export import export_table
from teaching.importing.sheet import last_frame
from tests.studyapp.test_stimuli import embedded, real_spec, walk

NAME = "yards-filmed"
VIDEO = re.compile(r"^[0-9a-f]{64}\.webm$")


def clip(k: int, out) -> bytes:
    """A 0.3 s VP9 clip of one colour, the colour objective k's own (so each objective's clip differs)."""
    colour = f"0x{(37 * k) % 256:02x}{(91 * k) % 256:02x}{(53 * k + 40) % 256:02x}"
    subprocess.run(["ffmpeg", "-v", "error", "-f", "lavfi", "-i", f"color=c={colour}:s=32x32:d=0.3", "-c:v",
                    "libvpx-vp9", "-deadline", "realtime", str(out)], check=True, timeout=120)
    return out.read_bytes()


def filmed_folder(table_path, folder, name=NAME):
    """The table exported as a folder with a manifest: objective k's trajectory in every environment is the clip
    clips/k.webm; returns {objective: the clip's bytes}."""
    table = TrajectoryTable.load(table_path)
    export_table(table, folder, name=name)
    (folder / "clips").mkdir()
    clips = {k: clip(k, folder / "clips" / f"{k}.webm") for k in range(table.n_thetas)}
    digest = {k: hashlib.sha256(data).hexdigest() for k, data in clips.items()}
    rows = [f"{int(e)},{k},clips/{k}.webm,{digest[k]}" for e in table.env_ids for k in range(table.n_thetas)]
    (folder / "stimuli.csv").write_text("env_id,objective,file,sha256\n" + "\n".join(rows) + "\n")
    toml = (folder / "table.toml").read_text()
    (folder / "table.toml").write_text('stimuli = "stimuli.csv"\n' + toml)
    return clips


@pytest.fixture(scope="module")
def folder(gridworld_tiny_table, tmp_path_factory):
    """(the filmed folder, {objective: clip bytes}), made once."""
    path = tmp_path_factory.mktemp("filmed") / "folder"
    return path, filmed_folder(gridworld_tiny_table, path)


@pytest.fixture
def filmed(folder, tmp_path, db):
    """(study, {objective: clip bytes}): the filmed table imported and a study built on it."""
    source, clips = folder
    path = tmp_path / "tables" / NAME
    table = import_table(source, path)
    study = build_study(real_spec(table, path, slug="filmed"))
    yield study, clips
    if NAME in domain_names():
        unregister(NAME)
    registry.forget(NAME)


def media_base(html: str) -> str:
    return re.search(r'<meta name="media-base" content="([^"]+)">', html).group(1)


def test_the_robot_of_a_filmed_table_is_shown_by_its_videos(filmed):
    study, _ = filmed
    domain = TrajectoryTable.load(study.source["table"]).domain
    assert domain.scene == "video" and domain.page_keys == () and domain.texts.legend == ()
    assert domain.scene_payload(int(domain.env_ids[0])) == {}
    assert domain.media_file("robot.json") is None and domain.media_file("../robot.json") is None
    with pytest.raises(ValueError, match="no video of objective 99 in environment"):
        domain.stimulus(int(domain.env_ids[0]), 99, None)


def test_each_page_names_its_videos_by_their_hash_and_serves_the_objectives_own_clip(filmed):
    study, clips = filmed
    client = Client()
    pages = list(walk(client, study, "filmed-1"))
    participant = pages[-1][0]
    assert pages[-1][1].kind == StepKind.DONE
    base = reverse("step", args=[study.slug, participant.token]) + "media/"
    shown = 0
    for _, step, html in pages:
        if step.kind not in (StepKind.TRAINING, StepKind.TEST):
            continue
        assert "scenes/video.js" in html and media_base(html) == base
        data = embedded(html)
        if step.kind == StepKind.TRAINING:
            videos = {0: data["env-data"]["robot"]}  # θ*'s, objective 0
            assert set(data["env-data"]) == {"robot"}  # nothing else of the environment
        else:
            test = study.test_set[step.item]
            canonical = dict(option_letters(participant, step.item, StepKind.TEST))  # letter -> canonical index
            videos = {test["options"][canonical[k]]["theta_index"]: robot for k, robot in data["option-robots"].items()}
        for objective, robot in videos.items():
            assert set(robot) == {"video", "seconds"} and VIDEO.match(robot["video"])
            assert robot["seconds"] == pytest.approx(0.3, abs=0.05)  # the clip's own length, as ffprobe read it
            response = client.get(base + robot["video"])
            assert response.status_code == 200 and response["Content-Type"] == "video/webm"
            assert b"".join(response.streaming_content) == clips[objective]
            assert "immutable" in response["Cache-Control"]
            shown += 1
    assert shown == len(participant.condition.training) + 4 * len(study.test_set)


def test_a_participants_page_may_play_videos_from_blobs_and_nothing_from_elsewhere(filmed):
    study, _ = filmed
    client = Client()
    pages = walk(client, study, "filmed-csp")
    next(pages)
    participant = next(pages)[0]
    csp = client.get(participant.get_absolute_url())["Content-Security-Policy"]
    assert "media-src 'self' blob:" in csp and "default-src 'self'" in csp


def test_a_name_that_is_not_one_of_the_robots_videos_is_not_found(filmed):
    study, clips = filmed
    client = Client()
    pages = walk(client, study, "filmed-2")
    participant = next(pages)[0]
    base = reverse("step", args=[study.slug, participant.token]) + "media/"
    real = hashlib.sha256(clips[0]).hexdigest() + ".webm"
    assert client.get(base + real).status_code == 200
    for name in ("robot.json", "videos.npy", "..%2Frobot.json", "0" * 64 + ".webm", real.upper()):
        assert client.get(base + name).status_code == 404, name
    stranger = reverse("step", args=[study.slug, "not-a-participant"]) + "media/" + real
    assert client.get(stranger).status_code == 404
    unregister(NAME)  # the robot gone from this process, its table too: the file is not found, nothing breaks
    registry.forget(NAME)
    Path(study.source["table"]).rename(Path(study.source["table"]).with_name("moved"))
    assert client.get(base + real).status_code == 404


def test_the_researchers_sheet_has_its_own_media_url_for_staff_only(filmed, staff_client):
    study, clips = filmed
    real = hashlib.sha256(clips[1]).hexdigest() + ".webm"
    url = reverse("dashboard_media", args=[study.slug, real])
    assert Client().get(url).status_code == 302  # to the login page
    response = staff_client.get(url)
    assert response.status_code == 200 and b"".join(response.streaming_content) == clips[1]
    assert "no-store" in response["Cache-Control"]  # a researcher's response, as every other
    sheet = staff_client.get(reverse("dashboard_stimuli", args=[study.slug])).content.decode()
    assert media_base(sheet) == reverse("dashboard_study", args=[study.slug]) + "media/"
    assert np.all([VIDEO.match(v) for v in re.findall(r'"video": "([^"]+)"', sheet)])


def test_a_video_study_is_estimated_to_take_its_videos_lengths(filmed):
    """The dashboard's time estimate counts each video watched once, at its length (0.3 s a clip here)."""
    study, _ = filmed
    found = {e.condition: e for e in estimates(study)}
    for condition in study.conditions.all():
        assert found[condition.name].animation_seconds == pytest.approx(0.3 * len(condition.training), rel=0.15)
    options = [o for test in study.test_set for o in test["options"]]
    assert [animation_seconds(o) for o in options] == pytest.approx([0.3] * len(options), rel=0.15)


def test_the_contact_sheet_shows_each_trajectorys_video_by_its_last_frame(filmed, tmp_path):
    """The sheet of a filmed robot: each panel the last frame of its video, read by ffmpeg; clip k is one colour,
    so objective k's frame is that colour (within the rounding of VP9's colour sampling)."""
    study, clips = filmed
    table = TrajectoryTable.load(study.source["table"])
    domain = table.domain
    for k in (0, 5):
        name = domain.stimulus(int(table.env_ids[0]), k, None)["video"]
        frame = last_frame(domain.media_file(name))
        colour = np.array([(37 * k) % 256, (91 * k) % 256, (53 * k + 40) % 256]) / 255
        assert frame.shape[:2] == (32, 32) and np.abs(frame[..., :3].mean(axis=(0, 1)) - colour).max() < 8 / 255
    conditions = {c.name: [p["env_id"] for p in c.training] for c in study.conditions.all()}
    n = domain.render_sheet(table=table, conditions=conditions, tests=study.test_set, out=tmp_path / "sheet.png",
                            no_tests=None, caption="filmed", columns=4, dpi=60)
    assert n == sum(map(len, conditions.values())) + 4 * len(study.test_set)
    assert (tmp_path / "sheet.png").stat().st_size > 10_000
