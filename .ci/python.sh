#!/usr/bin/env bash
# find_python X.Y: print the path of a working CPython X.Y interpreter, or fail naming where it looked.
# Looks on PATH (python3.12), then pyenv's versions (a pyenv shim on PATH can exist yet refuse to run a
# version that is not selected), then /usr/bin and /usr/local/bin.

find_python() {
  local want="$1" cand found=""
  local -a cands=("python$want")
  local root="${PYENV_ROOT:-$HOME/.pyenv}"
  if [ -d "$root/versions" ]; then
    # Newest patch release first.
    while IFS= read -r dir; do cands+=("$dir/bin/python$want"); done \
      < <(ls -d "$root/versions/$want".* 2>/dev/null | sort -t. -k3,3nr)
  fi
  cands+=("/usr/bin/python$want" "/usr/local/bin/python$want")
  for cand in "${cands[@]}"; do
    if "$cand" -c "import sys, venv; sys.exit(0 if sys.version_info[:2] == tuple(map(int, '$want'.split('.'))) else 1)" \
        >/dev/null 2>&1; then
      found="$(command -v "$cand" || echo "$cand")"
      break
    fi
  done
  if [ -z "$found" ]; then
    echo "error: no working Python $want found (tried: ${cands[*]}); install it (e.g. 'pyenv install $want')" >&2
    return 1
  fi
  echo "$found"
}
