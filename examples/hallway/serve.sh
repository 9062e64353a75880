#!/usr/bin/env bash
# The hallway robot, from its own planner to a study served locally (docs/importing.md, "A worked example"):
# its table folder written by its planner, imported, taught (`python -m teaching teach`), made a study and
# served on the embedded default (SQLite).  Each step is skipped when its output is already there.
#
#   serve.sh           the study drawn from the robot's recorded paths (robot "hallway", 300 environments)
#   serve.sh --videos  the study shown by the clips videos.py renders (robot "hallway-video", 120 environments:
#                      a clip of every distinct way in each, about a minute on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/../.."
export DEBUG=${DEBUG:-1}
PY=.venv/bin/python
ADDR=${EXAMPLE_ADDR:-127.0.0.1:8000}
TABLES=${TABLES_DIR:-${VAR_DIR:-var}/tables}
WORK=${VAR_DIR:-var}/examples
NAME=hallway TITLE="A robot crossing a hallway" MAKE=()
if [ "${1:-}" = "--videos" ]; then
  NAME=hallway-video TITLE="A robot crossing a hallway (videos)" MAKE=(--videos --envs 120 --candidates 39)
fi
[ -f "$WORK/$NAME/table.toml" ] || $PY examples/hallway/make_folder.py --out "$WORK/$NAME" "${MAKE[@]}"
[ -f "$TABLES/$NAME/meta.json" ] || $PY -m teaching import-table "$WORK/$NAME" --out "$TABLES/$NAME"
[ -f "$WORK/$NAME-teach/sequences.json" ] || \
  $PY -m teaching teach --table "$TABLES/$NAME" --out "$WORK/$NAME-teach" --no-progress
$PY manage.py migrate --verbosity 0
# a study that already has participants is kept as it is
$PY manage.py create_study "$WORK/$NAME-teach" --slug "$NAME" --name "$TITLE" \
  --replace 2>/dev/null || echo "keeping the existing study '$NAME'"
echo "take part: http://$ADDR/s/$NAME/"
exec $PY manage.py runserver "$ADDR" --noreload
