"""Render config/nginx.conf.template into the file named by its first argument (scripts/serve.sh).

Values come from the environment serve.sh exports: BIND (where nginx listens), GUNICORN_BIND
(the Unix socket it forwards to), NGINX_DIR (its pid and temporary files), MAX_REQUEST_BODY,
CONN_PER_ADDRESS, PARTICIPANT_MAX_BODY, NGINX_WORKER_CONNECTIONS, BEHIND_PROXY.
"""
import os
import re
import resource
import sys
from pathlib import Path

TEMPLATE = Path(__file__).resolve().parent.parent / "config" / "nginx.conf.template"


def open_file_limit(wanted: int) -> int:
    """`wanted`, or the hard limit on open files if lower: nginx may raise its workers' limit only
    up to it (beyond, setrlimit fails unless the process holds CAP_SYS_RESOURCE)."""
    hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
    return wanted if hard == resource.RLIM_INFINITY else min(wanted, hard)


def values(env) -> dict:
    connections = int(env.get("NGINX_WORKER_CONNECTIONS", "16384"))
    return {
        "LISTEN": env["BIND"],
        "UPSTREAM": env["GUNICORN_BIND"],
        "NGINX_DIR": env["NGINX_DIR"],
        "MAX_BODY": env.get("MAX_REQUEST_BODY", str(64 * 1024)),
        "CONN_PER_ADDRESS": env.get("CONN_PER_ADDRESS", "32"),
        "PARTICIPANT_BODY": env.get("PARTICIPANT_MAX_BODY", str(16 * 1024)),
        # per nginx worker: ~500 addresses at their cap of 32 even if one worker takes them all (docs/operations.md)
        "WORKER_CONNECTIONS": str(connections),
        "WORKER_RLIMIT_NOFILE": str(open_file_limit(2 * connections + 1024)),
        "UNAVAILABLE_DIR": str(TEMPLATE.parent / "unavailable"),
        # behind a TLS proxy its X-Forwarded-Proto passes through; otherwise a client's claim is overwritten
        "FORWARDED_PROTO": "$http_x_forwarded_proto" if env.get("BEHIND_PROXY") == "1" else "$scheme",
        # as root (CI, a container) nginx's workers would drop to "nobody", who may not connect to
        # gunicorn's socket: keep them as the user that runs everything else here
        "USER_LINE": "user root root;" if os.geteuid() == 0 else "",
    }


def main() -> None:
    v = values(os.environ)
    text = TEMPLATE.read_text()
    unknown = sorted(set(re.findall(r"@([A-Z_]+)@", text)) - set(v))
    if unknown:
        sys.exit(f"serve: {TEMPLATE} has placeholders nothing fills in: {', '.join(unknown)}")
    text = re.sub(r"@([A-Z_]+)@", lambda m: v[m.group(1)], text)
    Path(sys.argv[1]).write_text(text)


if __name__ == "__main__":
    main()
