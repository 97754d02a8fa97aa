#!/usr/bin/env bash
# Configures and builds the package standalone (devel space in $CM_BUILD/devel).
# Extra arguments go to cmake's configure step.
set -euo pipefail
source "$(dirname "$0")/env.sh"
cmake -S "$CM_ROOT" -B "$CM_BUILD" -DPYTHON_EXECUTABLE="$CM_PYTHON" "$@" >"$CM_BUILD.configure.log" 2>&1 \
  || { cat "$CM_BUILD.configure.log"; exit 1; }
cmake --build "$CM_BUILD" -j"$(nproc)"
