#!/usr/bin/env bash
# Prints the dependencies that maturin, building capsule_py alone, would compile with other
# features than `cargo build --workspace` did (so compile again); nothing when they agree.
# capsule_py/Cargo.toml names the workspace's features for that reason.
set -euo pipefail
cd "$(dirname "$0")/.."
tree() {
  cargo tree --quiet --locked "$@" -e normal,build -f '{p} [{f}]' --prefix none \
    | sed 's/ (\*)$//; s/ (proc-macro)//' | sort -u
}
comm -13 <(tree --workspace) <(tree -p capsule_py)
