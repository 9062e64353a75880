"""In Debian's Chromium, a participant shows the way in a "show" test of a grid world written only as a
file (tests/teaching/domains/worlds/key-room.toml): by keyboard on a laptop, and by touch on a phone
(390 x 844).  They move, keep their way across a reload, undo a move, cannot walk into a wall or off the
grid, cannot submit before the robot has finished, and submit; the stored moves and regret, and the
export's, are the way they showed.  Screenshots: test-output/show_way_<laptop|phone>.png."""
from __future__ import annotations

import csv
import io

import pytest
from playwright.sync_api import expect

from studyapp.data.exports import long_csv
from studyapp.models import Answer, Participant, StepKind, Study
from studyapp.participant import flow
from studyapp.researcher.studies import build_study, spec_from_teach
from tests.browser.grid_pages import OUT
from tests.browser.test_participant_flow import ready
from tests.conftest import complete_flow
from tests.studyapp.helpers import record
from tests.teaching.domains.worlds import brute, key_room
from tests.teaching.domains.worlds.shipped import shipped, teach_show

pytestmark = [pytest.mark.browser, pytest.mark.slow]

KEYS = {"right": "ArrowRight", "left": "ArrowLeft", "up": "ArrowUp", "down": "ArrowDown"}
STEP = {"right": (1, 0), "left": (-1, 0), "up": (0, -1), "down": (0, 1)}
BACK = {"right": "left", "left": "right", "up": "down", "down": "up"}
# the screen position (page px) of the centre of the cell at (col, row) of the page's canvas
CELL_AT = """([col, row]) => { const c = document.querySelector("[data-show-scene] canvas"), s = c.scene;
  const b = c.getBoundingClientRect(), k = b.width / s.w;
  return [b.left + (s.ox + (col + 0.5) * s.cell) * k, b.top + (s.oy + (row + 0.5) * s.cell) * k]; }"""


def shown(page) -> list[str]:
    return page.locator("[data-show-scene]").get_attribute("data-moves").split()


def a_wall_or_edge(domain, test) -> str:
    """A direction the robot cannot go from its start (off the grid or into a blocked cell)."""
    col, row = test["world"]["start"]
    blocked = domain.world.blocked(test["variant"])
    for name, (dc, dr) in STEP.items():
        c, r = col + dc, row + dr
        if not (0 <= c < domain.world.width and 0 <= r < domain.world.height) or blocked[r, c]:
            return name
    raise AssertionError("the start has no wall or edge beside it")


def a_free_step(domain, test, best: list[str]) -> str:
    """A direction the robot can go from its start and come back from, other than the way's first."""
    col, row = test["world"]["start"]
    blocked = domain.world.blocked(test["variant"])
    goals = {(f.at[1], f.at[0]) for f in domain.world.features if f.counts == "reach"}
    for name, (dc, dr) in STEP.items():
        c, r = col + dc, row + dr
        if name != best[0] and 0 <= c < domain.world.width and 0 <= r < domain.world.height and not blocked[r, c] \
                and (c, r) not in goals:
            return name
    raise AssertionError("the start has no second free neighbour")


def test_a_participant_shows_the_way_by_keyboard_and_by_touch(transactional_db, live_server, tmp_path_factory,
                                                             browser):
    errors = []
    with key_room.registered() as domain:
        _, teach_dir = key_room.built(tmp_path_factory)
        spec = spec_from_teach(teach_dir)
        spec.update(slug="key-room-show", name="Key room, shown", recruitment="prolific", completion_code="KEY2026",
                    test_set=[{"env_id": t["env_id"], "kind": "show"} for t in spec["test_set"]])
        study = build_study(spec)
        Study.objects.filter(pk=study.pk).update(is_open=True)
        test = study.test_set[0]
        best = brute.actions_of(domain.world, test["robot"])
        wall, free = a_wall_or_edge(domain, test), a_free_step(domain, test, best)
        OUT.mkdir(exist_ok=True)
        for device, options in (("laptop", {"viewport": {"width": 1200, "height": 900}}),
                                ("phone", {"viewport": {"width": 390, "height": 844}, "has_touch": True,
                                           "is_mobile": True, "device_scale_factor": 2})):
            page = browser.new_context(**options).new_page()
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            pid = f"show-{device}-000000000000000000"
            page.goto(f"{live_server.url}/s/{study.slug}/?PROLIFIC_PID={pid}&STUDY_ID=S&SESSION_ID=X")
            participant = complete_flow(Participant.objects.get(platform_pid=pid), stop_before=StepKind.TEST)
            page.goto(f"{live_server.url}{participant.get_absolute_url()}")
            ready(page)
            submit = page.locator('#show-form button[type="submit"]')
            expect(submit).to_be_disabled()
            if device == "laptop":
                page.keyboard.press(KEYS[wall])  # into a wall or off the grid: nothing happens
                assert shown(page) == []
                page.keyboard.press(KEYS[free])
                assert shown(page) == [free]
                page.reload()  # the way so far is kept across a reload
                ready(page)
                assert shown(page) == [free]
                page.keyboard.press("Backspace")  # undo
                assert shown(page) == []
                for move in best:
                    if move in KEYS:
                        page.keyboard.press(KEYS[move])
                    else:
                        page.click(f'[data-move="{move}"]')
                want = best
            else:
                expect(page.locator(f'[data-move="{wall}"]')).to_be_disabled()
                page.tap(f'[data-move="{free}"]')
                assert shown(page) == [free]
                page.tap('[data-action="undo"]')
                assert shown(page) == []
                # a detour by tapping the cells: out and back, then θ*'s way
                col, row = test["world"]["start"]
                want = [free, BACK[free], *best]
                for move in want:
                    if move not in STEP:
                        page.tap(f'[data-move="{move}"]')
                        continue
                    x, y = page.evaluate(CELL_AT, [col + STEP[move][0], row + STEP[move][1]])
                    page.touchscreen.tap(x, y)
                    col, row = col + STEP[move][0], row + STEP[move][1]
            assert shown(page) == want
            expect(submit).to_be_enabled()
            for move in STEP:  # finished: no more moves
                expect(page.locator(f'[data-move="{move}"]')).to_be_disabled()
            page.screenshot(path=str(OUT / f"show_way_{device}.png"), full_page=True)
            if device == "laptop":
                submit.click()
            else:
                submit.tap()
            page.wait_for_function("() => !document.querySelector('#show-form')")
            answer = Answer.objects.get(participant__platform_pid=pid, kind=StepKind.TEST, item=0)
            assert answer.data == {"env_id": test["env_id"], "moves": want}
            score = domain.score_shown(test["env_id"], want)
            assert answer.regret == pytest.approx(score["regret"]) and answer.correct is score["optimal"]
            assert (answer.regret == pytest.approx(0)) is (device == "laptop")
            row = next(r for r in csv.DictReader(io.StringIO(long_csv(study)))
                       if r["kind"] == "test" and r["item"] == "0"
                       and r["participant_id"] == str(answer.participant_id))
            assert row["moves"] == " ".join(want) and float(row["regret"]) == pytest.approx(answer.regret)
            assert row["optimal"] == str(int(answer.correct))
    assert not errors, errors


def test_the_taxi_picks_up_and_delivers_its_passenger_by_the_buttons_and_by_a_tap(transactional_db, live_server,
                                                                                tmp_path_factory, browser):
    """The augmented taxi's show test (teach --tests show): θ*'s way, whose pick-up and drop are the page's
    buttons (laptop) or a tap on the robot's own cell (phone); the drop on the destination ends the
    episode as a delivery, and the way is stored with regret 0."""
    errors = []
    with shipped("taxi") as domain:
        _, teach_dir = teach_show(tmp_path_factory, domain)
        spec = {**spec_from_teach(teach_dir), "slug": "taxi-show", "recruitment": "prolific",
                "completion_code": "TAXI2026"}
        study = build_study(spec)
        j, test = next((j, t) for j, t in enumerate(study.test_set)
                       if {"pickup", "drop"} <= set(brute.actions_of(domain.world, t["robot"])))
        best = brute.actions_of(domain.world, test["robot"])
        for device, options in (("laptop", {"viewport": {"width": 1200, "height": 900}}),
                                ("phone", {"viewport": {"width": 390, "height": 844}, "has_touch": True,
                                           "is_mobile": True})):
            page = browser.new_context(**options).new_page()
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            pid = f"taxi-{device}-0000000000000000000"
            page.goto(f"{live_server.url}/s/{study.slug}/?PROLIFIC_PID={pid}&STUDY_ID=S&SESSION_ID=X")
            # one scale for the world: an example's grid is drawn as wide as the show page's
            participant = complete_flow(Participant.objects.get(platform_pid=pid), stop_before=StepKind.TRAINING)
            page.goto(f"{live_server.url}{participant.get_absolute_url()}")
            ready(page)
            trained = page.locator(".scene.card canvas").bounding_box()["width"]
            participant = complete_flow(participant, stop_before=StepKind.TEST)
            for _ in range(j):  # the earlier show tests, answered with θ*'s way
                participant = _answer_show(participant, domain)
            page.goto(f"{live_server.url}{participant.get_absolute_url()}")
            ready(page)
            shown_width = page.locator("[data-show-scene] canvas").bounding_box()["width"]
            assert abs(trained - shown_width) < 1, (device, trained, shown_width)
            col, row = test["world"]["start"]
            for move in best:
                if move in STEP and device == "laptop":
                    page.keyboard.press(KEYS[move])
                elif move in STEP:
                    page.tap(f'[data-move="{move}"]')
                elif device == "phone" and move in ("pickup", "drop"):
                    x, y = page.evaluate(CELL_AT, [col, row])  # a tap on the robot's own cell
                    page.touchscreen.tap(x, y)
                else:
                    page.click(f'[data-move="{move}"]')
                if move in STEP:
                    col, row = col + STEP[move][0], row + STEP[move][1]
            assert shown(page) == best
            assert page.locator("[data-show-scene]").get_attribute("data-ended") == "delivered"
            expect(page.locator("[data-status]")).to_contain_text("the robot delivered the passenger")
            page.screenshot(path=str(OUT / f"show_way_taxi_{device}.png"), full_page=True)
            heading = page.locator("h1").text_content()
            page.locator('#show-form button[type="submit"]').click()
            # retried until the next page's heading is there: a one-shot check of document.querySelector('h1')
            # can run between the two pages, find no h1 and throw
            expect(page.locator("h1")).not_to_have_text(heading)
            answer = Answer.objects.get(participant__platform_pid=pid, kind=StepKind.TEST, item=j)
            assert answer.data["moves"] == best and answer.correct and answer.regret == pytest.approx(0)
    assert not errors, errors


def _answer_show(participant, domain):
    """Store θ*'s way for the show test the participant stands on (as the flow would from its page)."""
    step = flow.current_step(participant)
    test = flow.question_of(participant, step.kind, step.item)
    return record(participant, step.index, moves=" ".join(brute.actions_of(domain.world, test["robot"])))
