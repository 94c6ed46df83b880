#!/bin/sh
# install-deps.sh: installs the Debian 12 packages pmview needs, only those missing, quietly when all are present.
#   sh tools/install-deps.sh               to build, run and test
#   sh tools/install-deps.sh convergence   only what `make convergence` adds: gnuplot for its plots
set -e
PKGS="build-essential pkg-config libembree-dev libglfw3-dev libosmesa6-dev libopenexr-dev libtinygltf-dev nlohmann-json3-dev libstb-dev xvfb xdotool xauth x11-apps python3"
[ "$1" = convergence ] && PKGS="gnuplot-nox"
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
