"""The documentation as a site (mkdocs.yml): it builds strictly, so that a broken link or anchor fails the
suite; its API reference comes from the docstrings; and every command, address and button the tutorial
tells a researcher to use exists."""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from django.core.management import get_commands
from django.urls import resolve

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = (ROOT / "docs" / "tutorial.md").read_text()


def build(config: Path, site: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config), "--site-dir",
                           str(site)], cwd=ROOT, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    done = build(ROOT / "mkdocs.yml", out)
    assert done.returncode == 0, done.stdout + done.stderr
    return out


def test_the_site_builds_strictly_with_every_page_in_its_navigation(site):
    config = yaml.load((ROOT / "mkdocs.yml").read_text(), Loader=yaml.Loader)  # its tags need the full loader
    assert config["strict"] is True

    def pages(nav):
        for item in nav:
            for value in item.values():
                yield from pages(value) if isinstance(value, list) else [value]

    listed = set(pages(config["nav"]))
    assert listed == {p.name for p in (ROOT / "docs").glob("*.md")}  # no page left out of the reader's path
    assert all((site / Path(page).stem / "index.html").exists() or page == "index.md" for page in listed)


def test_the_api_reference_is_made_from_the_docstrings(site):
    page = (site / "api" / "index.html").read_text()
    for name in ("WorldPart", "PlannerPart", "PagesPart", "ShowWayPart", "missing_members"):
        assert f'id="teaching.core.domain.{name}"' in page
    assert "The numbers the core needs about the robot" in page  # WorldPart's docstring


def test_a_broken_link_fails_the_build(tmp_path):
    docs = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", docs)
    with (docs / "tutorial.md").open("a") as f:
        f.write("\nSee [the missing page](no-such-page.md) and [a missing part](study.md#no-such-heading).\n")
    config = (ROOT / "mkdocs.yml").read_text().replace("docs_dir: docs", f"docs_dir: {docs}").replace(
        "paths: [.]", f"paths: [{ROOT}]")
    (tmp_path / "mkdocs.yml").write_text(config)
    done = build(tmp_path / "mkdocs.yml", tmp_path / "site")
    assert done.returncode != 0
    assert "no-such-page.md" in done.stderr and "no-such-heading" in done.stderr


def _commands() -> list[str]:
    blocks = re.findall(r"```sh\n(.*?)```", TUTORIAL, re.S)
    return [line.strip() for block in blocks for line in block.splitlines() if line.strip()]


def test_every_command_of_the_tutorial_exists():
    targets = set(re.findall(r"^([a-z][\w-]*):", (ROOT / "Makefile").read_text(), re.M))
    django = set(get_commands())
    seen = 0
    for line in _commands():
        words = line.split()
        if words[0] == "make":
            assert words[1] in targets, line
        elif words[0] == ".venv/bin/python" and words[1] == "manage.py":
            assert words[2] in django, line
        else:
            assert words[0] in ("git", "cd"), line
            continue
        seen += 1
    assert seen >= 3


def test_every_address_and_button_of_the_tutorial_exists():
    paths = re.findall(r"http://127\.0\.0\.1:8000(/[^\s)>`]*)", TUTORIAL)
    assert len(paths) >= 4
    for path in paths:
        resolve(path.split("?")[0])  # Resolver404 for an address the site does not have
    templates = "".join(p.read_text() for p in ROOT.glob("**/templates/**/*.html") if ".venv" not in p.parts)
    for button in re.findall(r"\*\*(Build|Preview|Open study)\*\*", TUTORIAL):
        assert f">{button}</button>" in templates, button
