# Sourced by the run and test scripts: the venv, the JIT cache inside the repo, mpirun as root.
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="$REPO/.venv/bin:$PATH"
export XDG_CACHE_HOME="${XDG_CACHE_HOME:-$REPO/.cache}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
