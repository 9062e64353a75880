"""Create (or reset the password of) a researcher account: staff, not superuser.

    python manage.py create_researcher alice               # asks for the password twice
    printf '%s\n' "$PASSWORD" | python manage.py create_researcher alice --password-stdin

The password must pass Django's validators (AUTH_PASSWORD_VALIDATORS: length, similarity to
the user name, common passwords, all digits).  Researchers log in at /login/.
"""
import getpass
import sys

from django.contrib.auth import get_user_model, password_validation
from django.core.exceptions import ValidationError
from django.core.management.base import BaseCommand, CommandError


class Command(BaseCommand):
    help = "Create a researcher account (staff) with a validated password, or reset its password."

    def add_arguments(self, parser):
        parser.add_argument("username")
        parser.add_argument("--email", default="")
        parser.add_argument("--password-stdin", action="store_true", help="read the password from standard input")

    def handle(self, username, email, password_stdin, **options):
        User = get_user_model()
        username = username.strip()
        if not username:
            raise CommandError("the user name is empty")
        password = self.read_password(password_stdin)
        user = User.objects.filter(username=username).first() or User(username=username, email=email)
        try:
            password_validation.validate_password(password, user)
        except ValidationError as exc:
            raise CommandError("password refused: " + " ".join(exc.messages)) from None
        created = user.pk is None
        user.is_staff = True
        user.set_password(password)
        user.save()
        self.stdout.write(f"researcher {username} {'created' if created else 'updated'}; log in at /login/")

    def read_password(self, from_stdin: bool) -> str:
        if from_stdin:
            password = sys.stdin.readline().rstrip("\n")
        else:
            password = getpass.getpass("Password: ")
            if getpass.getpass("Password (again): ") != password:
                raise CommandError("the two passwords differ")
        if not password:
            raise CommandError("the password is empty")
        return password
