# cli_setup.sh: what the command-line test scripts share, sourced from the project's root: the binary under test (the ASan build when there is one), leak checks on, a scratch directory removed at exit.
bin=build/asan/pmview
[ -x "$bin" ] || bin=./pmview
export ASAN_OPTIONS=detect_leaks=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
