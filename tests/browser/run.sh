#!/usr/bin/env bash
# `raytracer view` in headless Chromium (tests/browser/view_test.py), as `.ci/run`
# runs it: as root, Debian's chromium and chromium-driver are installed if missing;
# without them (and without root to install them) the test says so and is skipped.
#
#   tests/browser/run.sh RAYTRACER [view_test.py's options]
set -euo pipefail

[ $# -ge 1 ] || { echo "usage: $0 RAYTRACER [--screenshot PNG] [--measure]" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
if ! command -v chromium >/dev/null 2>&1 || ! command -v chromedriver >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "browser test: installing Debian's chromium and chromium-driver" >&2
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null
  else
    echo "browser test: SKIPPED: chromium and chromedriver are missing (root installs them)" >&2
    exit 0
  fi
fi
exec python3 "$here/view_test.py" "$@"
