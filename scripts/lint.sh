#!/usr/bin/env bash
# The scripts' own checks: shellcheck (every note, info level up; .shellcheckrc) over the shell
# scripts, pyflakes over the Python ones (tests, scripts, examples). Exits non-zero on any finding.
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t shell < <(git ls-files '*.sh' .ci/run)
# Python: *.py, and the extensionless files that start with a python3 shebang.
mapfile -t python < <(git ls-files '*.py'
  git ls-files | grep -v '\.[^/]*$' | while read -r f; do
    head -c 40 "$f" 2>/dev/null | grep -q '^#!.*python3' && echo "$f"
  done)
rc=0
shellcheck -S info "${shell[@]}" || rc=1
/usr/bin/python3 -m pyflakes "${python[@]}" || rc=1
echo "lint.sh: ${#shell[@]} shell scripts (shellcheck), ${#python[@]} Python files (pyflakes): $([ "$rc" -eq 0 ] && echo clean || echo FINDINGS)"
exit "$rc"
