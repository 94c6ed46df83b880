#!/bin/sh
# test_signal_writes.sh: signals while a large checkpoint is written: SIGTERM then SIGKILL (within the write alone) during the first checkpoint leaves a whole image and no temporary file, alone and under mpirun; SIGKILL during a later EXR or PNG checkpoint leaves the previous image byte for byte and nothing else.
#
# The image of cases 1-3 is 1400 px square (118 MB of EXR planes, about 50 MB compressed), so a
# compressed write takes over a second on this machine (the first case's control adapts the
# signals' timing to it); the release binary is used, as the point is what a real run writes
# within the second between a SIGTERM and a SIGKILL. A write under way is seen as the pmview
# process holding an unnamed file of the image's folder ("/folder/#NNN (deleted)" in /proc/PID/fd);
# a write to a hidden named file would leave it behind after a SIGKILL.
cd "$(dirname "$0")/.." || exit 1
[ -x ./pmview ] || { echo "test_signal_writes: FAILED: ./pmview is not built"; exit 1; }
bin=./pmview
tmp=$(mktemp -d) || exit 1
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export PMVIEW_TEST_JOB="test_signal_writes.$$"
pid=""
cleanup() {
    [ -n "$pid" ] && kill -KILL "$pid" 2>/dev/null
    for p in $(job_processes any); do kill -KILL "$p" 2>/dev/null; done
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP

fails=0; checks=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; }
check() { # description of the failure, then a shell condition (eval'd)
    checks=$((checks + 1))
    desc=$1; shift
    eval "$@" || fail "$desc"
}
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", b - a }'; }
. tests/job_processes.sh
# writing PID DIR: PID holds an unnamed file of DIR open (a write under way)
writing() { ls -l "/proc/$1/fd" 2>/dev/null | grep -q -- "-> $2/#[0-9]* (deleted)"; }
# wait_writing PID DIR [N]: until PID starts its N-th write into DIR (1 by default), at most 120 s; false if it never does
wait_writing() {
    n=0; want=${3:-1}; i=0; was=false
    while [ "$i" -lt 12000 ]; do
        kill -0 "$1" 2>/dev/null || return 1
        if writing "$1" "$2"; then
            $was || n=$((n + 1)); was=true
            [ "$n" -ge "$want" ] && return 0
        else
            was=false
        fi
        i=$((i + 1)); sleep 0.01
    done
    return 1
}
# whole_exr FILE: pmview reads every line of FILE (as a sky map): a truncated EXR is refused
whole_exr() {
    $bin scenes/cornell-box.gltf --width 8 --iterations 1 --quiet --sky "$1" --snapshot "$tmp/reader.exr" >"$tmp/reader.out" 2>&1 ||
        { sed 's/^/    /' "$tmp/reader.out" | head -3; return 1; }
}
# leftovers DIR KEEP: the names in DIR (hidden ones too) other than KEEP
leftovers() { ls -A "$1" | grep -vx "$2" | tr '\n' ' '; }
big="scenes/cornell-box.gltf --width 1400 --threads 2 --mode pathtrace"
# --checkpoint 0.2: the first checkpoint comes at the first iteration's end (an iteration of $big
# takes about 0.9 s on two idle cores), so each run starts writing one iteration sooner than at 1 s.
# (Not under mpirun, where rank 0 is looked for in /proc first: a search that took longer than its
# first iteration would miss the first checkpoint.)

# --- 1. SIGKILL alone during the second EXR checkpoint: the first stays, byte for byte. The first
# checkpoint's compressed write is the control, timed from its unnamed file's opening to the
# image's appearance: over 1 s, or the cases below could not fail
mkdir "$tmp/second"
$bin $big --time 120 --checkpoint 0.2 --quiet --snapshot "$tmp/second/img.exr" >"$tmp/second.out" 2>&1 &
pid=$!
seen=false; write_seconds=0
if wait_writing $pid "$tmp/second" 1; then
    start=$(now)
    while [ ! -e "$tmp/second/img.exr" ] && kill -0 $pid 2>/dev/null; do sleep 0.01; done
    write_seconds=$(elapsed "$start" "$(now)")
    while writing $pid "$tmp/second"; do sleep 0.01; done
    cp "$tmp/second/img.exr" "$tmp/first-copy.exr" 2>/dev/null
    wait_writing $pid "$tmp/second" 1 && seen=true
fi
kill -KILL $pid 2>/dev/null; wait $pid 2>/dev/null; pid=""
echo "control: the first compressed checkpoint took $write_seconds s to write"
check "second EXR checkpoint, SIGKILL: no second write was seen" $seen
check "second EXR checkpoint, SIGKILL: the first checkpoint was changed or lost" cmp -s "'$tmp/first-copy.exr'" "'$tmp/second/img.exr'"
left=$(leftovers "$tmp/second" img.exr)
check "second EXR checkpoint, SIGKILL: files left beside the image: $left" [ -z "'$left'" ]
# The SIGKILL of the single-process case comes min(1 s, half that write) after the SIGTERM, so it
# always lands while the compressed write would still be under way, on a fast machine too (a
# compressed write that ended first would leave a whole image whatever pmview did with the signal).
kill_delay=$(awk -v w="$write_seconds" 'BEGIN { d = w / 2; if (d > 1) d = 1; printf "%.2f", d }')
check "control: no compressed write was timed ($write_seconds s)" \
    awk "'BEGIN { exit !($write_seconds > 0.05) }'"

# --- 2. one process, its first checkpoint: SIGTERM while it is written, SIGKILL min(1 s, half the
# control's write) later
mkdir "$tmp/first"
$bin $big --time 120 --checkpoint 0.2 --quiet --snapshot "$tmp/first/img.exr" >"$tmp/first.out" 2>&1 &
pid=$!
seen=false; wait_writing $pid "$tmp/first" && seen=true
kill -TERM $pid 2>/dev/null; sleep "$kill_delay"; kill -KILL $pid 2>/dev/null
wait $pid 2>/dev/null; pid=""
check "first checkpoint, SIGTERM + SIGKILL $kill_delay s later: no write was seen" $seen
check "first checkpoint, SIGTERM + SIGKILL $kill_delay s later: no image after it" [ -e "'$tmp/first/img.exr'" ]
check "first checkpoint, SIGTERM + SIGKILL $kill_delay s later: the image is not whole" whole_exr "'$tmp/first/img.exr'"
left=$(leftovers "$tmp/first" img.exr)
check "first checkpoint, SIGTERM + SIGKILL $kill_delay s later: files left beside the image: $left" [ -z "'$left'" ]

# --- 3. the same for a PNG (written in place before: a kill truncated the previous image)
mkdir "$tmp/png"
$bin $big --time 120 --checkpoint 0.2 --quiet --snapshot "$tmp/png/img.png" >"$tmp/png.out" 2>&1 &
pid=$!
seen=false
if wait_writing $pid "$tmp/png" 1; then
    while writing $pid "$tmp/png"; do sleep 0.01; done
    cp "$tmp/png/img.png" "$tmp/first-copy.png" 2>/dev/null
    wait_writing $pid "$tmp/png" 1 && seen=true
fi
kill -KILL $pid 2>/dev/null; wait $pid 2>/dev/null; pid=""
check "second PNG checkpoint, SIGKILL: no second write was seen" $seen
check "second PNG checkpoint, SIGKILL: the first checkpoint was changed or lost" cmp -s "'$tmp/first-copy.png'" "'$tmp/png/img.png'"
left=$(leftovers "$tmp/png" img.png)
check "second PNG checkpoint, SIGKILL: files left beside the image: $left" [ -z "'$left'" ]

# --- 4. under mpirun: SIGTERM to mpirun while rank 0 writes its first checkpoint. mpirun sends
# the ranks SIGCONT at once, SIGTERM 1 s later and SIGKILL 1 s after that (odls_base_sigkill_timeout),
# so a compressed write that takes under 2 s ends before the kill with or without the hurry (case 2
# shows the hurry), and an image large enough to need it would make this case a race against the
# machine's write speed. It is 1000 px square (60 MB of planes, its uncompressed write 0.1 s here):
# what it shows is mpirun's own sequence, a rank 0 interrupted in its first checkpoint's write,
# leaving a whole image, no temporary file and no rank behind.
if command -v mpirun >/dev/null 2>&1; then
    mkdir "$tmp/mpi"
    mpirun --oversubscribe -np 2 $bin scenes/cornell-box.gltf --width 1000 --threads 1 --mode pathtrace --time 120 \
        --checkpoint 1 --quiet --snapshot "$tmp/mpi/img.exr" </dev/null >"$tmp/mpi.out" 2>&1 &
    pid=$!
    rank0=""; i=0
    while [ -z "$rank0" ] && [ "$i" -lt 300 ]; do sleep 0.1; i=$((i + 1)); rank0=$(job_processes 0); done
    seen=false; [ -n "$rank0" ] && wait_writing "$rank0" "$tmp/mpi" && seen=true
    term_at=$(now); image_after="never"
    kill -TERM $pid 2>/dev/null
    # until mpirun has ended (at most 20 s), noting when the image appeared for the report
    i=0
    while kill -0 $pid 2>/dev/null && [ "$i" -lt 2000 ]; do
        [ "$image_after" = never ] && [ -e "$tmp/mpi/img.exr" ] && image_after="$(elapsed "$term_at" "$(now)") s"
        sleep 0.01; i=$((i + 1))
    done
    gone_after=$(elapsed "$term_at" "$(now)")
    kill -KILL $pid 2>/dev/null; wait $pid 2>/dev/null; pid=""
    echo "mpirun: the image appeared $image_after after its SIGTERM, mpirun ended after $gone_after s"
    [ -e "$tmp/mpi/img.exr" ] || sed 's/^/    mpirun: /' "$tmp/mpi.out" | head -8
    check "mpirun, first checkpoint, SIGTERM: no write was seen" $seen
    check "mpirun, first checkpoint, SIGTERM: no image after it" [ -e "'$tmp/mpi/img.exr'" ]
    check "mpirun, first checkpoint, SIGTERM: the image is not whole" whole_exr "'$tmp/mpi/img.exr'"
    left=$(leftovers "$tmp/mpi" img.exr)
    check "mpirun, first checkpoint, SIGTERM: files left beside the image: $left" [ -z "'$left'" ]
    check "mpirun: a pmview rank is left running" [ -z "'$(job_processes any)'" ]
else
    echo "mpirun missing: the mpirun case is skipped"
fi

echo "test_signal_writes: $checks checks, $fails failed"
[ "$fails" -eq 0 ]
