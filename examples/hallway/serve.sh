#!/usr/bin/env bash
# The hallway robot, from its own planner to a study served locally (docs/importing.md, "A worked example"):
# its table folder written by its planner, imported, taught (`python -m teaching teach`), made a study and
# served on the embedded default (SQLite).  Each step is skipped when its output is already there.
set -euo pipefail
cd "$(dirname "$0")/../.."
export DEBUG=${DEBUG:-1}
PY=.venv/bin/python
ADDR=${EXAMPLE_ADDR:-127.0.0.1:8000}
TABLES=${TABLES_DIR:-${VAR_DIR:-var}/tables}
WORK=${VAR_DIR:-var}/examples
[ -f "$WORK/hallway/table.toml" ] || $PY examples/hallway/make_folder.py --out "$WORK/hallway"
[ -f "$TABLES/hallway/meta.json" ] || $PY -m teaching import-table "$WORK/hallway" --out "$TABLES/hallway"
[ -f "$WORK/hallway-teach/sequences.json" ] || \
  $PY -m teaching teach --table "$TABLES/hallway" --out "$WORK/hallway-teach" --no-progress
$PY manage.py migrate --verbosity 0
# a study that already has participants is kept as it is
$PY manage.py create_study "$WORK/hallway-teach" --slug hallway --name "A robot crossing a hallway" \
  --replace 2>/dev/null || echo "keeping the existing study 'hallway'"
echo "take part: http://$ADDR/s/hallway/"
exec $PY manage.py runserver "$ADDR" --noreload
