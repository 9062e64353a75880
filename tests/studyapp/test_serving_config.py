"""nginx closes its idle connections to gunicorn before gunicorn does.

A request nginx sends on a kept-alive connection at the moment gunicorn closes it fails, and
nginx never retries a POST: a participant's answer would get a 503 (it was seen once in CI, in
tests/load/test_supervision.py).  nginx's upstream keepalive_timeout (default 60 s) must therefore
be shorter than gunicorn's keepalive, with room for a busy machine's late timers.
"""
import re
import runpy
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def rendered_nginx(tmp_path) -> str:
    out = tmp_path / "nginx.conf"
    env = {"BIND": "127.0.0.1:8000", "GUNICORN_BIND": "unix:/tmp/x.sock", "NGINX_DIR": str(tmp_path),
           "PATH": "/usr/bin:/bin"}
    subprocess.run([sys.executable, str(ROOT / "scripts/render_nginx.py"), str(out)], env=env, check=True)
    return out.read_text()


def seconds(value: str) -> float:
    number, unit = re.fullmatch(r"(\d+)(ms|s|m)?", value).groups()
    return int(number) * {"ms": 0.001, None: 1, "s": 1, "m": 60}[unit]


def test_nginx_drops_idle_upstream_connections_before_gunicorn(tmp_path):
    text = rendered_nginx(tmp_path)
    upstream = re.search(r"upstream gunicorn \{(.*?)\}", text, re.S).group(1)
    found = re.search(r"^\s*keepalive_timeout\s+(\S+);", upstream, re.M)
    assert found, "the upstream block must set keepalive_timeout (nginx's default, 60 s, outlives gunicorn's)"
    gunicorn = runpy.run_path(str(ROOT / "config/gunicorn.conf.py"))
    assert re.search(r"^\s*keepalive\s+\d+;", upstream, re.M)  # nginx does keep connections to gunicorn
    assert seconds(found.group(1)) + 2 <= gunicorn["keepalive"], (found.group(1), gunicorn["keepalive"])
