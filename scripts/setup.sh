#!/usr/bin/env bash
# Installs what hexsim needs from Debian 12's packages (only the missing ones) and builds it.
# Safe to run twice. Usage: scripts/setup.sh [BUILD_DIR [TARGET...]]   (default: build, every target;
# scripts/main.sh builds only the hexsim command and its libraries: `scripts/setup.sh build hexsim`)
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config git
  libeigen3-dev libode-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev libsqlite3-dev libpng-dev
  libosmesa6-dev libfreetype-dev fonts-dejavu-core
  ${HEXSIM_EXTRA_PACKAGES:-}
)

# A package whose command is already on PATH from elsewhere is not installed again: a machine with
# NodeSource's nodejs (which carries its own npm) cannot take Debian's npm ("held broken packages").
provided_by_command() {
  case "$1" in
    nodejs) command -v node >/dev/null 2>&1 ;;
    npm) command -v npm >/dev/null 2>&1 ;;
    chromium) command -v chromium >/dev/null 2>&1 ;;
    *) return 1 ;;
  esac
}
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" && continue
  provided_by_command "$p" && continue
  missing+=("$p")
done
if ((${#missing[@]})); then
  echo "hexsim setup: installing ${missing[*]}" >&2
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

BUILD_DIR=${1:-build}
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_COMPILER_LAUNCHER=ccache ${HEXSIM_CMAKE_ARGS:-} >/dev/null
targets=()
for t in "${@:2}"; do targets+=(--target "$t"); done
cmake --build "$BUILD_DIR" -j"$(nproc)" "${targets[@]}"
