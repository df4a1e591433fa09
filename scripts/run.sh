#!/usr/bin/env bash
# Install what is missing, then run the main job on the built-in default study (the inline-4
# crank train: gcms run without a study file).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh
exec gcms run --out "${GCMS_OUT:-out/default}" "$@"
