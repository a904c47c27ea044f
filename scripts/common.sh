# Shared by scripts/run and scripts/test: set-up when needed, then configure and build.
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${CARIESIM_BUILD_DIR:-$root/build}"
jobs="${CARIESIM_JOBS:-$(nproc)}"

cariesim_setup_and_build() {
  "$root/scripts/setup"
  if [ ! -f "$build/build.ninja" ]; then
    cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE="${CARIESIM_BUILD_TYPE:-RelWithDebInfo}" \
      ${CARIESIM_CMAKE_ARGS:-}
  fi
  cmake --build "$build" -j "$jobs" "$@"
}
