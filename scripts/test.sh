#!/usr/bin/env bash
# Install what is missing, then run the tests: the whole suite (what CI runs), or with
# --quick the quick tier, every test not marked slow (a few minutes; docs/cli.md). The tests
# run in GCMS_TEST_WORKERS processes (pytest-xdist; default 2, the CI machine's cores).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh
workers=(-n "${GCMS_TEST_WORKERS:-2}")
if [[ "${1:-}" == "--quick" ]]; then
    shift
    exec python -m pytest -q "${workers[@]}" -m "not slow" "$@"
fi
exec python -m pytest -q "${workers[@]}" "$@"
