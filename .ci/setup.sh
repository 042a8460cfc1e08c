#!/usr/bin/env bash
# Idempotent setup for a fresh machine: system packages (virtual display, Mesa, iproute2, xdotool) and a venv
# with dbglog, the ROS 2 Jazzy wheels, Dear PyGui and the test tools. Sourced by .ci/run and .ci/demo.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${DBGLOG_VENV:-$ROOT/.venv}"

apt_install() {  # apt_install PACKAGE...: quietly, as root or through sudo
  local sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

need_apt=()
command -v Xvfb >/dev/null 2>&1 || need_apt+=(xvfb xauth)
[ -e /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so ] || [ -e /usr/lib/x86_64-linux-gnu/dri/llvmpipe_dri.so ] \
  || ls /usr/lib/*/dri/*swrast* >/dev/null 2>&1 || need_apt+=(libgl1-mesa-dri)
command -v ip >/dev/null 2>&1 || need_apt+=(iproute2)
command -v xdotool >/dev/null 2>&1 || need_apt+=(xdotool)
# A C compiler builds the SDK's hot path (dbglog/api/_hot.c); without one dbglog installs in pure Python.
command -v cc >/dev/null 2>&1 || need_apt+=(gcc libc6-dev)
if [ ${#need_apt[@]} -gt 0 ]; then
  echo "setup: installing system packages: ${need_apt[*]}"
  apt_install "${need_apt[@]}"
fi

PY="${PYTHON:-python3.11}"
command -v "$PY" >/dev/null 2>&1 || PY=python3
# The C hot path needs the interpreter's headers: pyenv builds have them, a distribution's Python has
# them in its -dev package (optional: without it dbglog installs in pure Python).
if ! "$PY" -c 'import os, sys, sysconfig; sys.exit(0 if os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")) else 1)'; then
  pydev="python$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')-dev"
  echo "setup: installing $pydev (Python.h, for dbglog's compiled hot path)"
  apt_install "$pydev" || echo "setup: could not install $pydev: dbglog's hot path will run in Python" >&2
fi
if [ ! -x "$VENV/bin/python" ]; then
  echo "setup: creating $VENV"
  "$PY" -m venv "$VENV"
fi
# Editable install, plus a .pth that puts the clone itself on sys.path. setuptools' editable import hook
# is asked only after the path finder, so without the .pth a script run from the folder that holds the
# clone (a folder named dbglog, no __init__.py) imported that folder as an empty namespace package:
# "module 'dbglog' has no attribute 'logfloat'". With the clone on sys.path the path finder finds the
# real package, which wins over a namespace portion. (setuptools' own editable_mode=compat does the same
# but is marked transitional.) The stamp records the mode, so a venv installed the old way is redone once.
install_mode="editable+clone-pth"
stamp="$VENV/.dbglog-installed"
# The editable install compiles dbglog/api/*.c in place: a changed source (or setup.py) installs again.
if [ ! -f "$stamp" ] || [ "$ROOT/pyproject.toml" -nt "$stamp" ] || [ "$ROOT/setup.py" -nt "$stamp" ] \
    || [ -n "$(find "$ROOT/dbglog/api" -name '*.[ch]' -newer "$stamp")" ] \
    || [ "$(cat "$stamp")" != "$install_mode" ]; then
  echo "setup: installing dbglog[ros,viewer,test] into $VENV"
  "$VENV/bin/python" -m pip install -q --upgrade pip >/dev/null
  "$VENV/bin/python" -m pip install -q -e "$ROOT[ros,viewer,test]"
  site="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
  printf '%s\n' "$ROOT" >"$site/dbglog_clone.pth"
  echo "$install_mode" >"$stamp"
fi
export PATH="$VENV/bin:$PATH"
# Demos, tests and benchmarks keep DDS discovery on this machine unless the user chose otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
