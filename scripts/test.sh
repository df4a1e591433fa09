#!/usr/bin/env bash
# Install what is missing, then run the tests: the whole suite (what CI runs), or with
# --quick the quick tier, every test not marked slow (a few minutes; docs/cli.md).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh
if [[ "${1:-}" == "--quick" ]]; then
    shift
    exec python -m pytest -q -m "not slow" "$@"
fi
exec python -m pytest -q "$@"
