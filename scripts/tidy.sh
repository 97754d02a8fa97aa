#!/usr/bin/env bash
# clang-tidy over the package's own sources (src/ and examples/, and the headers of include/ and
# src/ they include) with the checks of .clang-tidy, every finding an error. Needs a configured
# and built standalone tree ($CM_BUILD, or the first argument): its compile_commands.json, and the
# message and dynamic_reconfigure headers generated into its devel space. Exits non-zero on any
# finding, printing them.
set -euo pipefail
source "$(dirname "$0")/env.sh"
BUILD="${1:-$CM_BUILD}"
DB="$BUILD/compile_commands.json"
if [ ! -f "$DB" ]; then
  echo "tidy.sh: no $DB (configure and build the tree first: scripts/build.sh)" >&2
  exit 1
fi
TIDY="$(command -v clang-tidy || command -v clang-tidy-14 || true)"
if [ -z "$TIDY" ]; then
  echo "tidy.sh: clang-tidy not found (apt-get install clang-tidy)" >&2
  exit 1
fi
# The translation units of the database under src/ and examples/, each once, less those a clean
# run found clean with everything they are built from as it is now (scripts/tidy_units.py; the
# cache is $CM_TIDY_CACHE, ~/.cache/collision_monitor/tidy by default; CM_TIDY_CACHE= runs all).
CACHE="${CM_TIDY_CACHE-${XDG_CACHE_HOME:-$HOME/.cache}/collision_monitor/tidy}"
[ -z "$CACHE" ] || mkdir -p "$CACHE"
FILTER="^$CM_ROOT/(include|src)/"
UNITS_TEXT="$("$CM_PYTHON" "$CM_ROOT/scripts/tidy_units.py" "$DB" "$CM_ROOT" "$TIDY" "$FILTER" "$CACHE")"
if [ -z "$UNITS_TEXT" ]; then
  echo "tidy.sh: no sources of src/ or examples/ in $DB" >&2
  exit 1
fi
mapfile -t UNITS <<<"$UNITS_TEXT"
FILES=()
KEYS=()
CACHED=0
for unit in "${UNITS[@]}"; do
  if [ "${unit%% *}" = cached ]; then
    CACHED=$((CACHED + 1))
  else
    KEYS+=("${unit%% *}")
    FILES+=("${unit#* }")
  fi
done
LOG="$BUILD/tidy.log"
rc=0
: >"$LOG"
[ "${#FILES[@]}" -eq 0 ] || printf '%s\n' "${FILES[@]}" | xargs -P"$(nproc)" -n1 "$TIDY" -p "$BUILD" --quiet \
  --header-filter="$FILTER" >"$LOG" 2>&1 || rc=1
findings="$(grep -cE '^/.*: (error|warning): ' "$LOG" || true)"
if [ "$rc" -ne 0 ] || [ "$findings" -ne 0 ]; then
  grep -E -A3 '^/.*: (error|warning): ' "$LOG" >&2 || tail -50 "$LOG" >&2
  echo "tidy.sh: $findings finding(s) in ${#FILES[@]} files (full log: $LOG)" >&2
  exit 1
fi
if [ -n "$CACHE" ]; then
  for key in "${KEYS[@]}"; do : >"$CACHE/$key"; done
fi
echo "clang-tidy: ${#UNITS[@]} files, no finding (${#FILES[@]} run, $CACHED unchanged since a clean run)"
