#!/usr/bin/env bash
# The system packages the tests need, from scripts/system-packages.txt.
#
#   scripts/system_packages.sh missing [--all]   print the missing ones, one a line
#   scripts/system_packages.sh install [--all]   install the missing ones (apt-get; as root)
#   scripts/system_packages.sh ensure            what `make test` runs first: nothing missing,
#       or install them (as root, or with sudo that needs no password), or stop naming the
#       one command to run
#
# Without --all, the PostgreSQL packages count only when TEST_DATABASE_URL is set.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
list="$here/system-packages.txt"

missing() {
  local all=$1 package when check
  while read -r package when check; do
    case "$package" in ''|'#'*) continue ;; esac
    if [ "$when" = pg ] && [ "$all" != yes ] && [ -z "${TEST_DATABASE_URL:-}" ]; then
      continue
    fi
    bash -c "$check" >/dev/null 2>&1 || echo "$package"
  done < "$list"
}

install() {
  local packages=("$@")
  [ ${#packages[@]} -gt 0 ] || return 0
  echo "system packages: installing ${packages[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq "${packages[@]}" >/dev/null
}

all=no
[ "${2:-}" = --all ] && all=yes
mapfile -t need < <(missing "$all")

case "${1:-}" in
  missing)
    printf '%s\n' "${need[@]}" | sed '/^$/d'
    ;;
  install)
    if [ "$(id -u)" -ne 0 ]; then
      echo "Run this as root: sudo $0 install${2:+ $2}" >&2
      exit 1
    fi
    install "${need[@]}"
    ;;
  ensure)
    [ ${#need[@]} -gt 0 ] || exit 0
    if ! command -v apt-get >/dev/null 2>&1; then
      echo "The tests need these system packages (Debian/Ubuntu names), which are missing:" \
        "${need[*]}. Install them with your system's package manager, then run make test again." >&2
      exit 1
    fi
    if [ "$(id -u)" -eq 0 ]; then
      install "${need[@]}"
    elif command -v sudo >/dev/null 2>&1 && sudo -n true >/dev/null 2>&1; then
      sudo -n "$0" install
    else
      echo "The tests need system packages that are missing (${need[*]})." \
        "Install them once with: sudo scripts/system_packages.sh install" >&2
      exit 1
    fi
    left="$(missing no)"
    if [ -n "$left" ]; then
      echo "Still missing after installing: $left" >&2
      exit 1
    fi
    ;;
  *)
    echo "usage: $0 missing|install|ensure [--all]" >&2
    exit 2
    ;;
esac
