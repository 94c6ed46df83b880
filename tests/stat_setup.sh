# stat_setup.sh: what the tests that read pmview's stat lines share, sourced from the project's root: the optimised binary, a scratch directory removed at exit, the check counters, and a stat line's value.
bin=./pmview
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0; checks=0
# value STAGE KEY FILE: the last `stat STAGE` line's KEY in FILE
value() { sed -n "s/^stat $1 .*[ ]$2=\([^ ]*\).*/\1/p" "$3" | tail -n 1; }
