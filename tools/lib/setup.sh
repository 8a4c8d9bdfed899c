# tools/lib/setup.sh — shared by tools/run-demo and tools/run-tests: install
# the Debian 12 packages manyrods needs (only the missing ones), configure
# CMake (Release, Ninja when present) and build. Sourced, not executed.

MANYRODS_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
MANYRODS_BUILD=${MANYRODS_BUILD:-$MANYRODS_ROOT/build}

# Debian packages and why (README: Dependencies).
MANYRODS_PACKAGES=(
  g++               # C++20 compiler with OpenMP (libgomp)
  cmake             # build system
  ninja-build       # fast builds (make works too)
  libeigen3-dev     # host-side linear algebra: statics, stable_dt, tests
  libgtest-dev      # GoogleTest
  libbenchmark-dev  # Google Benchmark (bench/)
  libtomlplusplus-dev  # toml++: scene files (host/scene/setup/scene.cpp), with file:line of every key
  libtinyobjloader-dev # tinyobjloader: OBJ meshes for mesh colliders (host/scene/io/mesh_grid.cpp)
  libcli11-dev      # CLI11: options and subcommands of build/bin/manyrods
  libhdf5-dev       # HDF5 C library: trajectories, energies and checkpoints (host/scene/io/h5io.cpp)
  gnuplot-nox       # PNG plots: manyrods plot (pngcairo) and the speed-vs-error study (tools/run-accuracy)
  python3-h5py      # tests/test_h5io: checks that h5py reads the output layout
  python3-dev       # Python headers: the Python module (python/src/module.cpp)
  python3-venv      # the project's virtual environment (.venv) for the Python side
  openmpi-bin       # mpirun: sweeps sharded over MPI ranks (manyrods sweep --chunk under mpirun; ctest mpi_sweep)
  libopenmpi-dev    # MPI headers and library for the command-line tool (optional: MANYRODS_MPI)
)

manyrods_install_deps() {
  local missing=() p
  for p in "${MANYRODS_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then
    echo "manyrods: all required Debian packages are installed"
    return 0
  fi
  echo "manyrods: installing missing Debian packages: ${missing[*]}"
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
      sudo="sudo"
    else
      echo "manyrods: not root and no sudo; install as root: apt-get install ${missing[*]}" >&2
      return 1
    fi
  fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# The Python side (nanobind, scikit-build-core, numpy, pytest, matplotlib,
# usd-core; python/requirements.txt, pinned, from PyPI) in a virtual
# environment of Debian's Python, never the system's site-packages:
# $MANYRODS_VENV (default .venv in the checkout), made or updated when the
# requirements changed. MANYRODS_PYTHON=0 skips it (no Python module, no
# Python tests).
MANYRODS_VENV=${MANYRODS_VENV:-$MANYRODS_ROOT/.venv}

manyrods_python_env() {
  [ "${MANYRODS_PYTHON:-1}" != 0 ] || return 0
  local req="$MANYRODS_ROOT/python/requirements.txt" stamp="$MANYRODS_VENV/.manyrods-requirements"
  if [ -x "$MANYRODS_VENV/bin/python" ] && cmp -s "$req" "$stamp"; then
    echo "manyrods: Python environment $MANYRODS_VENV is up to date"
    return 0
  fi
  echo "manyrods: making the Python environment $MANYRODS_VENV (python/requirements.txt, from PyPI)"
  /usr/bin/python3 -m venv "$MANYRODS_VENV"
  "$MANYRODS_VENV/bin/python" -m pip install -q --disable-pip-version-check -r "$req"
  cp "$req" "$stamp"
}

manyrods_configure() {
  local gen=() py=()
  if command -v ninja >/dev/null 2>&1; then gen=(-G Ninja); fi
  if [ "${MANYRODS_PYTHON:-1}" != 0 ] && [ -x "$MANYRODS_VENV/bin/python" ]; then
    py=(-DPython_EXECUTABLE="$MANYRODS_VENV/bin/python")
  fi
  if [ -f "$MANYRODS_BUILD/CMakeCache.txt" ]; then
    cmake -S "$MANYRODS_ROOT" -B "$MANYRODS_BUILD" -DCMAKE_BUILD_TYPE=Release "${py[@]}" "$@" >/dev/null
  else
    cmake -S "$MANYRODS_ROOT" -B "$MANYRODS_BUILD" "${gen[@]}" -DCMAKE_BUILD_TYPE=Release "${py[@]}" "$@"
  fi
}

manyrods_build() {
  cmake --build "$MANYRODS_BUILD" -j "$(nproc)" "$@"
}
