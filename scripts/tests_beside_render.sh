#!/usr/bin/env bash
# `make test`'s unit-test step: the site renders (scripts/render_site.sh, one Quarto process) while
# the unit tests run, instead of before them. The render takes a core for about 100 s; the pytest
# processes keep working beside it, and the tests that read _site/ wait for it (tests/_site.py
# reads the exit status this script writes to _site/.render.status when the render ends).
#
#   bash scripts/tests_beside_render.sh [pytest arguments...]
#
# Exit status: pytest's when the render succeeded or found no Quarto (then the site tests skip
# and say why); 1 when the render failed or warned (its output is printed), whatever pytest says.
set -uo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-.venv/bin/python}

status=_site/.render.status
rm -f "$status"
out=$(mktemp)
(
  bash scripts/render_site.sh >"$out" 2>&1
  rc=$?
  mkdir -p _site
  cp "$out" _site/.render.out
  echo "$rc" >"$status.tmp" && mv "$status.tmp" "$status"  # whole, so a reader never sees it empty
) &
render=$!
PKMLIB_RENDER_STATUS="$PWD/$status" "$PYTHON" -m pytest "$@"
rc=$?
wait "$render"
render_rc=$(cat "$status" 2>/dev/null || echo 1)
rm -f "$out"
case "$render_rc" in
  0) tail -n 1 _site/.render.out ;;
  3) echo "no Quarto: the rendered-site tests skipped ($(tail -n 2 _site/.render.out | head -n 1))" ;;
  *)
    cat _site/.render.out >&2
    echo "tests_beside_render: scripts/render_site.sh failed (exit $render_rc); output above" >&2
    exit 1
    ;;
esac
exit "$rc"
