#!/bin/sh
# install-deps.sh: installs the Debian 12 packages pmview needs (with `fuzz` or `check`, also those targets' own), only those missing, quietly when all are present.
set -e
# python3-numpy writes the generated multi-million-triangle scenes of the window-loading test and the bench in seconds
# gnuplot-nox draws the plots of `make convergence`, whose short form is one of `make test`'s tests
PKGS="build-essential pkg-config libembree-dev libglfw3-dev libosmesa6-dev libopenexr-dev libtinygltf-dev nlohmann-json3-dev libdraco-dev libmeshoptimizer-dev libstb-dev openmpi-bin libopenmpi-dev xvfb xdotool xauth x11-apps python3 python3-numpy gnuplot-nox"
# `install-deps.sh fuzz` (make fuzz): clang and its runtime libraries hold libFuzzer; gcc has none
[ "$1" = fuzz ] && PKGS="$PKGS clang libclang-rt-14-dev"
# `install-deps.sh check` (make check): valgrind for the memcheck test
[ "$1" = check ] && PKGS="$PKGS valgrind"
missing=""
for p in $PKGS; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && exit 0
echo "install-deps: installing:$missing"
SUDO=""
[ "$(id -u)" = 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
