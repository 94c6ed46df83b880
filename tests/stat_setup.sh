# stat_setup.sh: what the tests that read pmview's stat lines share, sourced from the project's root: the optimised binary, a scratch directory removed at exit, the check counters, a stat line's value, a check of named numbers and a run's channel means.
bin=./pmview
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0; checks=0
# value STAGE KEY FILE: the last `stat STAGE` line's KEY in FILE
value() { sed -n "s/^stat $1 .*[ ]$2=\([^ ]*\).*/\1/p" "$3" | tail -n 1; }
check() { # description, python condition over the named numbers that follow (name=value ...)
    desc=$1; cond=$2; shift 2
    checks=$((checks + 1))
    if python3 -c 'import sys
v = {k: float(x or "nan") for k, x in (a.split("=", 1) for a in sys.argv[2:])}
sys.exit(0 if eval(sys.argv[1], {}, v) else 1)' "$cond" "$@"; then
        echo "ok: $desc ($*)"
    else fails=$((fails + 1)); echo "FAIL: $desc ($*)"; fi
}
means_of() { # the run's channel means over its reference's: r= g= b=
    echo "r=$(value error mean_ratio_r "$tmp/$1") g=$(value error mean_ratio_g "$tmp/$1") b=$(value error mean_ratio_b "$tmp/$1")"
}
