"""Export benchmark: the wide and long CSV of a 10,000-participant study through the dashboard's real
export view, time and peak memory, the earlier whole-file exporter beside the streaming one.

    python bench/exports.py [--participants 10000] [--no-old] [--json PATH]
    python bench/exports.py --update-doc JSON docs/benchmarks.md

A fresh SQLite database in a temporary folder gets a study built by the real pipeline on the tiny
trajectory table (built here, a few seconds), one participant per condition answers every step
through studyapp.participant.flow, and their answers are copied (bulk_create) to --participants participants.
Each export then runs in a child process of its own: a staff user's Django test client GETs
/dashboard/SLUG/export/{wide,long}.csv and reads the response to the end (counting bytes and rows,
keeping none); the child reports the seconds to the first byte and to the last, and its peak
resident memory (VmHWM: the whole process, Django included).  "before" is the earlier
whole-file exporter (tests/studyapp/exports_before.py, verbatim), sent through the same view as
one piece, exactly as its HttpResponse did.  Bars: 10 s and 500 MB each.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.doc_section import rewrite_section  # noqa: E402  (needs ROOT on sys.path)

SEQUENCES = {"alpha": [500, 5780, 12165], "beta": [7107, 15245], "gamma": [586, 20132]}  # tiny-table envs
SLUG, STAFF = "bench-exports", "bench-staff"
BAR_SECONDS, BAR_MB = 10.0, 500.0
BEGIN, END = "<!-- bench/exports.py: begin -->", "<!-- bench/exports.py: end -->"


def django_setup(folder: Path) -> None:
    os.environ.update({"DJANGO_SETTINGS_MODULE": "config.settings", "DEBUG": "1", "VAR_DIR": str(folder),
                       "DATABASE_URL": f"sqlite:///{folder / 'db.sqlite3'}"})
    os.environ.pop("CACHE_URL", None)
    import django  # noqa: PLC0415

    django.setup()


def populate(folder: Path, n: int) -> dict:
    """The study, one real participant per condition, n copies of them; returns what was made."""
    from django.contrib.auth import get_user_model  # noqa: PLC0415
    from django.core.management import call_command  # noqa: PLC0415
    from django.http import QueryDict  # noqa: PLC0415
    from django.utils import timezone  # noqa: PLC0415

    from studyapp.models import Answer, Participant, StepKind, new_token  # noqa: PLC0415
    from studyapp.participant import assignment, flow  # noqa: PLC0415
    from studyapp.researcher.studies import build_study, table_spec  # noqa: PLC0415
    from teaching.core.build import PRESETS, build_table  # noqa: PLC0415

    logging.getLogger("studyapp").setLevel(logging.WARNING)  # not a line per template participant
    call_command("migrate", verbosity=0)
    build_table(PRESETS["tiny"], folder / "tiny")
    spec = table_spec(folder / "tiny", slug=SLUG, sequences=SEQUENCES, min_distance=0.1)
    study = build_study({**spec, "name": "Export benchmark", "completion_code": "BENCH"})
    get_user_model().objects.create_user(STAFF, password="bench-pw-123", is_staff=True)

    def post(p, step):  # a valid answer for every step: theta*'s option chosen and rated 6
        body = {StepKind.CONSENT: {"consent": ["yes"]}, StepKind.INSTRUCTIONS: {"ack": ["1"]},
                StepKind.TRAINING: {"played": ["1"]}, StepKind.ATTENTION: {"goals": ["merge", "forward"]},
                StepKind.DEMOGRAPHICS: {"age": ["34"], "gender": ["female"]}}.get(step.kind)
        if body is None:
            shown = flow.option_letters(p, step.item)
            options = study.test_set[step.item]["options"]
            star = next(letter for letter, k in shown if options[k]["is_theta_star"])
            body = {"choice": [star], "played": [letter for letter, _ in shown]}
            body.update({f"rating_{letter}": ["6" if letter == star else "2"] for letter, _ in shown})
        q = QueryDict(mutable=True)
        for k, v in body.items():
            q.setlist(k, v)
        return q

    templates = []
    for condition in study.conditions.all():
        p = assignment.assign(study, Participant.PROLIFIC, f"template-{condition.name}")
        p.condition = condition
        p.save(update_fields=["condition"])
        for step in flow.steps_for(p)[:-1]:
            p = flow.record(p, step.index, post(p, step))
        templates.append((p, list(p.answers.order_by("step"))))
    now, batch = timezone.now(), 1000
    for start in range(0, n - len(templates), batch):
        people = []
        for i in range(start, min(start + batch, n - len(templates))):
            t = templates[i % len(templates)][0]
            people.append(Participant(
                study=study, condition_id=t.condition_id, token=new_token(), platform=Participant.PROLIFIC,
                platform_pid=f"P{i:06d}", platform_study_id="BENCH", platform_session_id=f"S{i}",
                platform_session_ids=[f"S{i}"], position=t.position, option_orders=t.option_orders,
                started_at=now, last_seen_at=now, completed_at=now, completion_code="BENCH"))
        people = Participant.objects.bulk_create(people)
        Answer.objects.bulk_create([
            Answer(participant_id=p.pk, step=a.step, kind=a.kind, item=a.item, data=a.data,
                   chosen_option=a.chosen_option, correct=a.correct, confidence_score=a.confidence_score,
                   created_at=now)
            for k, p in enumerate(people, start) for a in templates[k % len(templates)][1]])
    return {"participants": Participant.objects.filter(study=study).count(),
            "answers": Answer.objects.filter(participant__study=study).count(),
            "test_set_kb": len(json.dumps(study.test_set)) / 1024}


def peak_rss_mb() -> float:
    """This process's peak resident memory.  VmHWM, not getrusage's ru_maxrss: Linux carries the
    parent's resident size at fork over the child's exec into ru_maxrss, so a child started by a
    parent holding 450 MB would report at least that whatever it used itself."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def measure(which: str, kind: str) -> dict:
    """In this (child) process: one export through the view, read to the end."""
    from django.contrib.auth import get_user_model  # noqa: PLC0415
    from django.test import Client  # noqa: PLC0415
    from django.urls import reverse  # noqa: PLC0415

    from studyapp.data import exports  # noqa: PLC0415

    if which == "before":
        from tests.studyapp import exports_before  # noqa: PLC0415

        old = {"long": exports_before.long_csv, "wide": exports_before.wide_csv}[kind]
        exports.STREAMS[kind] = lambda study: iter([old(study)])  # the whole file, as HttpResponse had it
    client = Client()
    client.force_login(get_user_model().objects.get(username=STAFF))
    client.get(reverse("dashboard_export", args=[SLUG, "dictionary"]))  # warm: URL conf, views, connection
    url = reverse("dashboard_export", args=[SLUG, kind])
    base = peak_rss_mb()
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    response = client.get(url)
    first = None
    size = lines = 0
    for piece in response.streaming_content:
        first = first or time.perf_counter() - t0
        size += len(piece)
        lines += piece.count(b"\n")
    seconds = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu = cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime
    return {"which": which, "kind": kind, "status": response.status_code, "seconds": seconds, "cpu_seconds": cpu,
            "first_byte_seconds": first, "mb": size / 2**20, "rows": lines - 1, "baseline_rss_mb": base,
            "peak_rss_mb": peak_rss_mb()}


def markdown(fig: dict) -> str:
    ok = {True: "pass", False: "**fail**"}
    rows = []
    for m in fig["runs"]:
        bar = ""
        if m["which"] == "streamed":
            bar = (f"≤ {BAR_SECONDS:.0f} s: {ok[m['seconds'] <= BAR_SECONDS]}; "
                   f"≤ {BAR_MB:.0f} MB: {ok[m['peak_rss_mb'] <= BAR_MB]}")
        rows.append(f"| {m['kind']} | {m['which']} | {m['rows']:,} rows, {m['mb']:.0f} MB | "
                    f"**{m['seconds']:.1f} s** (CPU {m['cpu_seconds']:.1f} s; first byte "
                    f"{m['first_byte_seconds']:.2f} s) | "
                    f"**{m['peak_rss_mb']:,.0f} MB** ({m['baseline_rss_mb']:.0f} before the request) | {bar} |")
    head = (f"`{fig['command']}`, {fig['date']} UTC, {fig['participants']:,} participants "
            f"({fig['answers']:,} answers, a {fig['test_set_kb']:.0f} KB test set) in a fresh SQLite database, "
            f"on {fig['cores']} cores (load average {fig['load_average_start']:.2f} at the start).  Each export "
            "is one GET of the dashboard's export view with Django's test client, read to the end, in a child "
            "process of its own; CPU is that process's user + system time for the request (what the load on "
            "the machine does not stretch); memory is its peak resident size (VmHWM), Django included.  "
            "\"before\" is the earlier whole-file exporter, through the same view.  Generated by "
            "`python bench/exports.py --update-doc JSON docs/benchmarks.md`.")
    table = ["| file | exporter | output | time | peak memory | bar |", "|---|---|---|---|---|---|", *rows]
    return f"{BEGIN}\n{head}\n\n" + "\n".join(table) + f"\n{END}"


def update_doc(json_path: Path, doc: Path) -> None:
    rewrite_section(json_path, doc, BEGIN, END, markdown, "exports")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--participants", type=int, default=10_000)
    ap.add_argument("--no-old", action="store_true", help="skip the earlier whole-file exporter (~20 s, ~4 GB each)")
    ap.add_argument("--json", metavar="PATH", help="also write the figures to PATH as JSON")
    ap.add_argument("--update-doc", nargs=2, metavar=("JSON", "DOC"),
                    help="rewrite DOC's exports section from a --json output; no run")
    ap.add_argument("--measure", nargs=3, metavar=("FOLDER", "WHICH", "KIND"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.update_doc:
        return update_doc(Path(args.update_doc[0]), Path(args.update_doc[1]))
    if args.measure:
        folder, which, kind = args.measure
        django_setup(Path(folder))
        print(json.dumps(measure(which, kind)))
        return None

    fig = {"command": " ".join(["bench/exports.py", *sys.argv[1:]]), "date": time.strftime("%Y-%m-%d %H:%M"),
           "cores": os.cpu_count(), "load_average_start": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory(prefix="bench-exports-") as tmp:
        folder = Path(tmp)
        t0 = time.perf_counter()
        django_setup(folder)
        fig.update(populate(folder, args.participants))
        print(f"{fig['participants']:,} participants, {fig['answers']:,} answers, test set "
              f"{fig['test_set_kb']:.0f} KB: made in {time.perf_counter() - t0:.1f} s "
              f"(load average {fig['load_average_start']:.2f})")
        fig["runs"] = []
        for kind in ("wide", "long"):
            for which in ("streamed", *(() if args.no_old else ("before",))):
                out = subprocess.run([sys.executable, __file__, "--measure", tmp, which, kind],
                                     capture_output=True, text=True, check=True, cwd=ROOT)
                m = json.loads(out.stdout.strip().splitlines()[-1])
                assert m["status"] == 200 and m["rows"] >= args.participants, m
                fig["runs"].append(m)
                print(f"{kind:4} {which:8}: {m['seconds']:6.2f} s (first byte {m['first_byte_seconds']:.2f} s, "
                      f"CPU {m['cpu_seconds']:.2f} s), "
                      f"peak {m['peak_rss_mb']:7,.0f} MB ({m['baseline_rss_mb']:.0f} MB before), "
                      f"{m['rows']:,} rows, {m['mb']:.1f} MB")
    streamed = [m for m in fig["runs"] if m["which"] == "streamed"]
    fig["pass"] = all(m["seconds"] <= BAR_SECONDS and m["peak_rss_mb"] <= BAR_MB for m in streamed)
    print(f"bars ({BAR_SECONDS:.0f} s, {BAR_MB:.0f} MB per streamed export): {'PASS' if fig['pass'] else 'FAIL'}")
    if args.json:
        Path(args.json).write_text(json.dumps(fig, indent=1))
    return None


if __name__ == "__main__":
    main()
