#!/usr/bin/env bash
# Render the Quarto site into _site/ from the notebooks' stored outputs (no --execute) and fail on
# any Quarto warning: an unresolved cross-reference, citation, include or link is one. The log is
# kept in _site/.render.log, which tests/test_site.py reads along with the rendered HTML.
#
# Quarto: built from ../shared/quarto into .quarto-tools/ (git-ignored; quick when already built)
# when that folder exists, else .quarto-tools/bin/quarto if built before, else `quarto` on PATH.
# Exit status: 0 rendered without a warning; 1 Quarto failed or warned; 3 no Quarto found.
set -uo pipefail
cd "$(dirname "$0")/.."

if [ -d ../shared/quarto ]; then
  if ! bash ../shared/quarto/install.sh .quarto-tools >/dev/null; then
    echo "render_site: building Quarto from ../shared/quarto into .quarto-tools failed" >&2
    exit 1
  fi
fi
if [ -x .quarto-tools/bin/quarto ]; then
  QUARTO=.quarto-tools/bin/quarto
elif command -v quarto >/dev/null 2>&1; then
  QUARTO=quarto
else
  rm -f _site/.render.log  # no stale "rendered" marker for the site tests
  echo "render_site: no Quarto (neither ../shared/quarto nor quarto on PATH): site not rendered." >&2
  echo "  Install Quarto from https://quarto.org/docs/get-started/ or build it with ../shared/quarto/install.sh." >&2
  exit 3
fi
# the build stamp's JAX version is read by the Python that Quarto runs scripts/site_build.py with
if [ -z "${QUARTO_PYTHON:-}" ] && [ -x .venv/bin/python ]; then
  export QUARTO_PYTHON="$PWD/.venv/bin/python"
fi

# MathJax, served with the site (package-lock.json pins it): installed when missing or older than the lock
if [ ! -f node_modules/mathjax/es5/tex-chtml-full.js ] || [ package-lock.json -nt node_modules/.package-lock.json ]; then
  if ! command -v npm >/dev/null 2>&1; then
    echo "render_site: npm not found: it installs MathJax from package-lock.json (Debian: apt-get install -y npm)" >&2
    exit 1
  fi
  if ! npm ci --ignore-scripts --no-audit --no-fund >&2; then
    echo "render_site: npm ci (MathJax from package-lock.json) failed" >&2
    exit 1
  fi
fi

rm -rf _site
log="$(mktemp)"
NO_COLOR=1 "$QUARTO" render 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}
mkdir -p _site && cp "$log" _site/.render.log && rm -f "$log"
if [ "$rc" -ne 0 ]; then
  echo "render_site: quarto render failed (exit $rc)" >&2
  exit 1
fi
if grep -n -E 'WARN|\[WARNING\]|ERROR|Unable to resolve' _site/.render.log >&2; then
  echo "render_site: quarto render printed the warnings above (see _site/.render.log)" >&2
  exit 1
fi
echo "render_site: $("$QUARTO" --version), _site/ rendered without warnings"
