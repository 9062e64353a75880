"""Idempotently create the demo study and, in development only, a staff user with a fixed
password; print the links; optionally serve.

    python manage.py setup_demo            # migrate + create, print links
    python manage.py setup_demo --serve    # ... then run the development server

The fixed demo login (researcher / demo-password) is created only with --demo-login, which
`make demo` passes (scripts/demo.sh); anywhere else researchers get their own accounts from
`manage.py create_researcher`.
"""
import os

from django.contrib.auth import get_user_model
from django.core.management import call_command
from django.core.management.base import BaseCommand, CommandError

from studyapp.models import Study
from studyapp.researcher.studies import SpecError, build_study, demo_is_stale, demo_spec

DEFAULT_USER = "researcher"
DEFAULT_PASSWORD = "demo-password"


class Command(BaseCommand):
    help = "Create a staff login and the demo study (all of the paper's conditions); print the links."

    def add_arguments(self, parser):
        parser.add_argument("--serve", action="store_true", help="Run the development server afterwards.")
        parser.add_argument("--addrport", default="127.0.0.1:8000")
        parser.add_argument("--demo-login", action="store_true", help="Also create the staff login researcher / "
                            "demo-password (make demo only: a public password must never reach a real server).")
        parser.add_argument("--replace", action="store_true",
                            help="Rebuild the demo study (if it has no participants).")
        parser.add_argument("--table", default=None, help="Trajectory table directory (default $DEMO_TABLE or "
                            "$TABLES_DIR/demo; `make demo` builds it).")

    def handle(self, serve, addrport, replace, table, demo_login, **options):
        call_command("migrate", interactive=False, verbosity=0)
        username = os.environ.get("DEMO_USER", DEFAULT_USER)
        password = os.environ.get("DEMO_PASSWORD", DEFAULT_PASSWORD)
        if demo_login:
            User = get_user_model()
            user, created = User.objects.get_or_create(username=username,
                                                       defaults={"is_staff": True, "is_superuser": True})
            if created or not user.check_password(password):
                user.set_password(password)
            user.is_staff = user.is_superuser = True
            user.save()
            login = f"login: {username} / {password}"
        else:
            login = "log in with an account from `manage.py create_researcher NAME`"

        study = Study.objects.filter(slug="demo").first()
        stale = study is not None and demo_is_stale(study, table)
        if study is not None and stale and study.participants.exists():
            self.stdout.write(self.style.WARNING(
                "The demo table has changed since the demo study was built, but the study already has "
                "participants, so it is kept as it is (export its data, then run with --replace)."))
        elif replace or study is None or stale:
            try:
                study = build_study(demo_spec(table), replace=study is not None)
            except SpecError as exc:
                raise CommandError(str(exc)) from None
        host = addrport if ":" in addrport else f"127.0.0.1:{addrport}"
        base = f"http://{host.replace('0.0.0.0', '127.0.0.1')}"
        source = study.source.get("kind")
        self.stdout.write(f"Demo study '{study.slug}': {study.conditions.count()} conditions, "
                          f"{len(study.test_set)} tests (trajectories: {source})")
        self.stdout.write(f"Participant link: {base}{study.get_absolute_url()}")
        self.stdout.write(f"  as Prolific:    {base}{study.get_absolute_url()}"
                          "?PROLIFIC_PID=demo1&STUDY_ID=s&SESSION_ID=x")
        self.stdout.write(f"Dashboard:        {base}/dashboard/{study.slug}/  ({login})")
        if serve:
            call_command("runserver", addrport, use_reloader=False)
