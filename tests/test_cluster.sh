#!/bin/sh
# test_cluster.sh: 2-rank MPI jobs (mpirun --oversubscribe -np 2): the same image twice for one seed in every mode, a furnace's mean equal to its analytic answer and to one process's, --time, --log, SIGINT, a killed rank, a bad scene, --watch refused, pmview without libmpi (its module has it), a --log that cannot be written, ranks holding different scenes or options, --max-memory counting the merge's buffers, a stopped rank under --time (at its run's end, and in a merge on 3 ranks), SIGTERM to rank 0 alone, a rank stopped in its set-up, the cluster stat line.
#
# Every job is small (64 px or less, --threads 1) so the whole runs in well under a minute on two
# busy cores. The ASan build's leak check is off inside mpirun jobs only: Open MPI keeps its own
# allocations (some in components it has unloaded, which no suppression can name) to the end.
cd "$(dirname "$0")/.." || exit 1

have_tools() { for t in mpirun python3; do command -v $t >/dev/null 2>&1 || return 1; done; }
if ! have_tools; then
    # only when installing cannot stop at a password prompt
    if [ "$(id -u)" = 0 ] || sudo -n true 2>/dev/null; then sh tools/install-deps.sh </dev/null >/dev/null 2>&1; fi
    if ! have_tools; then
        echo "SKIP: mpirun or python3 missing and tools/install-deps.sh could not install them"
        exit 0
    fi
fi
. tests/cli_setup.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# marks this script's ranks, so that finding rank 1 (and the check that none is left) never
# touches another pmview running on the machine
export PMVIEW_TEST_JOB="test_cluster.$$"
job=""
cleanup() {
    [ -n "$job" ] && kill -KILL "$job" 2>/dev/null
    for p in $(job_processes any); do kill -KILL "$p" 2>/dev/null; done
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP

fails=0; checks=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; }
check() { # description, then a shell condition (eval'd)
    checks=$((checks + 1))
    desc=$1; shift
    eval "$@" || fail "$desc"
}
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", b - a }'; }
# at_most X Y: X <= Y as numbers
at_most() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a <= b) }'; }
# mpi ARGS...: a 2-rank job of the binary under test, stdin closed (mpirun forwards it to rank 0)
mpi() { ASAN_OPTIONS=detect_leaks=0 mpirun --oversubscribe -np 2 $bin "$@" </dev/null; }
. tests/job_processes.sh
# exec_with_sigint ARGS...: becomes ARGS (same pid) with SIGINT's default action: a job a script
# starts in the background inherits SIGINT ignored, and mpirun keeps it so, as Ctrl-C never does
exec_with_sigint() {
    if env --default-signal=INT true 2>/dev/null; then
        exec env --default-signal=INT "$@"
    fi
    exec python3 -c 'import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); os.execvp(sys.argv[1], sys.argv[1:])' "$@"
}
# mpi_job ARGS...: the same in the background, started as `mpi_job ... &`: its $! is mpirun's pid
mpi_job() { export ASAN_OPTIONS=detect_leaks=0; exec_with_sigint mpirun --oversubscribe -np 2 $bin "$@" </dev/null; }
# mpi_job3 ARGS...: the same with 3 ranks
mpi_job3() { export ASAN_OPTIONS=detect_leaks=0; exec_with_sigint mpirun --oversubscribe -np 3 $bin "$@" </dev/null; }
# rendering FILE: waits (at most 60 s: an ASan set-up on a machine loaded 10 times over took 15)
# until FILE, the output of a job started with --stats and a --reference, holds rank 0's first
# 'stat progress' line: an iteration is done, so every rank has given its word
# at the set-up's agreement and catches signals. (A fixed wait instead was too short on a loaded
# machine, where the set-up took longer, and too long on an idle one.) The space after the stage
# matters: 'stat progressive_setup' is printed during the set-up, before the agreement, and a rank
# stopped then fails the agreement instead of the case under test.
rendering() {
    i=0; while ! grep -qs "^stat progress " "$1" && [ "$i" -lt 1200 ]; do sleep 0.05; i=$((i + 1)); done
}
# stat_value FILE STAGE KEY: KEY's value on FILE's last 'stat STAGE' line
stat_value() { grep "^stat $2 " "$1" | tail -n 1 | tr ' ' '\n' | sed -n "s/^$3=//p"; }
# is_exr FILE: OpenEXR's magic number (76 2f 31 01)
is_exr() { [ "$(od -An -tx1 -N4 "$1" 2>/dev/null | tr -d ' \n')" = 762f3101 ]; }
# readable_render FILE: pmview reads FILE as a --reference of a 2-iteration render of the Cornell
# box at 64 px, and the means agree within 20 % (FILE is an image of that scene, not only a header)
readable_render() {
    $bin scenes/cornell-box.gltf --width 64 --threads 1 --iterations 2 --reference "$1" --stats --quiet \
        --snapshot "$tmp/reader.exr" >"$tmp/reader.out" 2>&1 || { sed 's/^/    /' "$tmp/reader.out" | head -3; return 1; }
    r=$(stat_value "$tmp/reader.out" error mean_ratio_g)
    [ -n "$r" ] && awk -v r="$r" 'BEGIN { exit !(r > 0.8 && r < 1.25) }' || { echo "    mean ratio against $1: '$r'"; return 1; }
}
cornell="scenes/cornell-box.gltf --threads 1"
# rank_of JOB RANK: the pid of mpirun JOB's child that is that MPI rank (its children, not all of
# /proc: found within milliseconds where job_processes, on a loaded machine, takes seconds)
rank_of() {
    for p in $(ps -o pid= --ppid "$1"); do
        tr '\0' '\n' <"/proc/$p/environ" 2>/dev/null | grep -qx "OMPI_COMM_WORLD_RANK=$2" && echo "$p"
    done
}
# the options that make rank 0 print 'stat progress' lines from its first iteration on (see
# rendering), at 64 and 32 px (a reference of the image's size; any values serve)
rendered64="--width 64 --stats --reference tests/ref/cornell_path_64.exr"
python3 tests/sky_files.py exr "$tmp/ref32.exr" 32 32 1 || fail "sky_files.py failed"
rendered32="--width 32 --stats --reference $tmp/ref32.exr"

# --- 1. one seed, one image: two 2-rank runs byte for byte, in each mode; another seed differs
for mode in progressive classic pathtrace; do
    for run in a b; do
        # shellcheck disable=SC2046 # the classic mode's photon count, fewer than its default
        mpi $cornell --width 48 --iterations 6 --seed 5 --mode $mode $([ $mode = classic ] && echo --photons 5000) --snapshot "$tmp/$mode-$run.exr" >"$tmp/$mode-$run.out" 2>&1 ||
            { sed 's/^/    /' "$tmp/$mode-$run.out" | head -5; }
    done
    check "$mode: two 2-rank runs of seed 5 are not byte-identical" cmp -s "$tmp/$mode-a.exr" "$tmp/$mode-b.exr"
    check "$mode: the 2-rank job did not render the 6 iterations asked for" grep -q "'(48x48, 6 iterations'" "$tmp/$mode-a.out"
done
mpi $cornell --width 48 --iterations 6 --seed 6 --mode progressive --snapshot "$tmp/seed6.exr" >"$tmp/seed6.out" 2>&1
check "the 2-rank image of seed 6 is missing" is_exr "$tmp/seed6.exr"
check "the 2-rank images of seeds 5 and 6 are identical (the determinism check could not fail)" ! cmp -s "$tmp/progressive-a.exr" "$tmp/seed6.exr"

# --- 2. the expected image is one process's: a white furnace, walls of albedo 0.5 emitting 1,
# radiance 1 / (1 - 0.5) = 2 everywhere. 16 iterations at 64x64, seeds 1 to 3, one process and
# 2 ranks, progressive and path-traced, each against a constant reference of 2.
# Measured (ASan build): progressive (--gather photons) 1-process mean ratios 1.0005 0.9988 1.0012,
# 2 ranks 1.0002 0.9995 1.0002, relMSE 0.00129 (8 iterations: 0.0025); path tracing 1.0001 1.0004 0.9999
# and 1.0000 1.0002 0.9995, relMSE 0.0007. The noise of an image's mean is taken as the larger of
# the seed-to-seed spread measured here (sample standard deviation of the 1-process means) and
# sqrt(relMSE / pixels) (the pixels' own noise, averaged: 0.00056 progressive, 0.00041 path
# traced, what the spread above shows too); every mean must lie within 4 of those of the answer,
# the two means of three within 4 of each other. A merge that dropped or doubled a rank's film
# misses by 10 % or more; one that lost a rank's iterations doubles the relMSE, checked too.
python3 tests/furnace_scene.py "$tmp/furnace.gltf" 0.5 1 || fail "furnace_scene.py failed"
answer=$(python3 tests/furnace_scene.py answer 0.5 1)
python3 tests/sky_files.py exr "$tmp/furnace-ref.exr" 64 64 "$answer" || fail "sky_files.py failed"
furnace="$tmp/furnace.gltf --width 64 --threads 1 --iterations 16 --reference $tmp/furnace-ref.exr --stats"
# The progressive runs read the photons at the gather rays' ends (--gather photons): the default's
# gather choice path-traces a furnace from the visible point on, which would make them the path
# tracer's runs again and leave the photon pass over MPI untested.
for mode in progressive pathtrace; do
    : >"$tmp/furnace-$mode.txt"
    how="--mode $mode"; [ $mode = progressive ] && how="$how --gather photons"
    for seed in 1 2 3; do
        $bin $furnace $how --seed $seed --snapshot "$tmp/f1.exr" >"$tmp/f1-$mode-$seed.out" 2>&1 ||
            fail "furnace $mode seed $seed, one process: exit $?"
        mpi $furnace $how --seed $seed --snapshot "$tmp/f2.exr" >"$tmp/f2-$mode-$seed.out" 2>&1 ||
            fail "furnace $mode seed $seed, 2 ranks: exit $?"
        for n in 1 2; do
            o="$tmp/f$n-$mode-$seed.out"
            echo "$n $(stat_value "$o" error iterations) $(stat_value "$o" error mean_ratio_r) $(stat_value "$o" error relmse)" >>"$tmp/furnace-$mode.txt"
        done
    done
    checks=$((checks + 1))
    python3 - "$tmp/furnace-$mode.txt" "$mode" <<'EOF' || fail "furnace, $mode: the means are not the analytic answer's within the noise"
import math, statistics, sys
rows = [line.split() for line in open(sys.argv[1])]
ok = len(rows) == 6 and all(len(r) == 4 for r in rows)
if not ok:
    print("furnace %s: missing stat error lines: %s" % (sys.argv[2], rows))
    sys.exit(1)
ratio = {1: [float(r[2]) for r in rows if r[0] == "1"], 2: [float(r[2]) for r in rows if r[0] == "2"]}
relmse = {1: [float(r[3]) for r in rows if r[0] == "1"], 2: [float(r[3]) for r in rows if r[0] == "2"]}
iterations = [int(r[1]) for r in rows]
spread = statistics.stdev(ratio[1])
noise = max(spread, math.sqrt(statistics.mean(relmse[1]) / (64 * 64)))
tolerance = 4 * noise + 0.0001  # the ratios are printed to 4 decimals
mean = {n: statistics.mean(ratio[n]) for n in (1, 2)}
print("furnace %s: mean ratios, one process %s, 2 ranks %s; seed-to-seed spread %.5f, noise %.5f, tolerance %.5f; "
      "relMSE one process %.5f, 2 ranks %.5f" % (sys.argv[2], ratio[1], ratio[2], spread, noise, tolerance,
                                                 statistics.mean(relmse[1]), statistics.mean(relmse[2])))
bad = []
if iterations != [16] * 6:
    bad.append("iterations %s, want 16 each (--iterations is the whole job's)" % iterations)
for n in (1, 2):
    for r in ratio[n]:
        if abs(r - 1) > tolerance:
            bad.append("%s mean ratio %.4f beyond %.5f of 1" % ("one process's" if n == 1 else "2 ranks'", r, tolerance))
if abs(mean[2] - mean[1]) > tolerance:
    bad.append("2 ranks' mean of means %.5f vs one process's %.5f" % (mean[2], mean[1]))
if statistics.mean(relmse[2]) > 1.4 * statistics.mean(relmse[1]):
    bad.append("2 ranks' relMSE %.5f above 1.4 x one process's %.5f: a rank's iterations are missing"
               % (statistics.mean(relmse[2]), statistics.mean(relmse[1])))
for b in bad:
    print("furnace %s: %s" % (sys.argv[2], b))
sys.exit(1 if bad else 0)
EOF
done

# --- 7, 8. the cluster stat line: 2 ranks merged at least once, an image's worth of bytes a merge;
# one process says ranks=1 and merges nothing
o="$tmp/f2-progressive-1.out"
check "2 ranks: no 'stat cluster ranks=2' line" grep -q "'^stat cluster ranks=2 '" "$o"
merges=$(stat_value "$o" cluster merges); per_merge=$(stat_value "$o" cluster bytes_per_merge)
# a merge carries at least the RGB floats of every pixel (64 x 64 x 12 bytes)
check "2 ranks: merges=$merges, want >= 1" [ "${merges:-0}" -ge 1 ]
check "2 ranks: bytes_per_merge=$per_merge, want >= 64 x 64 x 12" [ "${per_merge:-0}" -ge 49152 ]
o="$tmp/f1-progressive-1.out"
check "one process: no 'stat cluster ranks=1 merges=0' line" grep -q "'^stat cluster ranks=1 merges=0 '" "$o"

# --- 3. --time 2 and --log on a 2-rank job: ends in about 2 s, the log's iterations grow and
# its last row is the image's count
start=$(now)
mpi $cornell --width 64 --time 2 --snapshot "$tmp/time.exr" --log "$tmp/time.csv" >"$tmp/time.out" 2>&1
rc=$?; wall=$(elapsed "$start" "$(now)")
echo "--time 2 on 2 ranks: the job took $wall s wall, exit $rc"
check "--time 2: exit $rc" [ "$rc" -eq 0 ]
check "--time 2: the job took $wall s wall, want 2 to 4.5 (2 s + start-up and write)" "at_most 1.95 $wall && at_most $wall 4.5"
check "--time 2: no image written" is_exr "$tmp/time.exr"
wrote=$(sed -n 's/^pmview: wrote .* (64x[0-9]*, \([0-9]*\) iterations, \([0-9.]*\) s).*/\1 \2/p' "$tmp/time.out")
check "--time 2: no 'pmview: wrote' line" [ -n "'$wrote'" ]
checks=$((checks + 1))
python3 - "$tmp/time.csv" $wrote <<'EOF' || fail "--log on 2 ranks: the log is not what the run did"
import csv, sys
rows = list(csv.reader(open(sys.argv[1])))
header, rows = rows[0], rows[1:]
written, seconds = int(sys.argv[2]), float(sys.argv[3])
its = [int(r[header.index("iterations")]) for r in rows]
print("--time 2 on 2 ranks: %d iterations in %.2f s; log rows' iterations %s" % (written, seconds, its))
bad = []
if header[:4] != ["seconds", "iterations", "photons", "mean_radius"]:
    bad.append("header %s" % header[:4])
if not 1.95 <= seconds <= 2.5:
    bad.append("the render took %.2f s, want 2" % seconds)
if len(its) < 2:
    bad.append("%d rows, want >= 2" % len(its))
if any(b <= a for a, b in zip(its, its[1:])):
    bad.append("the iterations do not grow")
if its and its[-1] != written:
    bad.append("the last row has %d iterations, the image %d" % (its[-1], written))
for b in bad:
    print("--log: " + b)
sys.exit(1 if bad else 0)
EOF

# job_ends WHAT: waits up to 15 s for the background job $job to end; wall: seconds since $sent
job_ends() {
    i=0
    while kill -0 "$job" 2>/dev/null && [ "$i" -lt 150 ]; do sleep 0.1; i=$((i + 1)); done
    wall=$(elapsed "$sent" "$(now)")
    if kill -0 "$job" 2>/dev/null; then fail "$1: mpirun still running 15 s after it"; kill -KILL "$job"; fi
}

# Stops rank process $1 (SIGSTOP; nothing when empty), waits for the job as job_ends does (its
# exit in rc, the seconds from the stop in wall), then lets the rank go on.
stopped_rank_ends() {
    sent=$(now)
    [ -n "$1" ] && kill -STOP "$1"
    job_ends "$2"
    wait "$job"; rc=$?; job=""
    [ -n "$1" ] && kill -CONT "$1" 2>/dev/null
}

# --- 4. SIGINT to mpirun: the image so far, written and readable, within 5 s of the signal
mpi_job $cornell $rendered64 --time 60 --snapshot "$tmp/int.exr" >"$tmp/int.out" 2>&1 &
job=$!
rendering "$tmp/int.out"
sent=$(now)
kill -INT "$job"
job_ends "SIGINT"
wait "$job"; rc=$?; job=""
echo "SIGINT: mpirun ended $wall s after the signal, exit $rc"
check "SIGINT: the job ended $wall s after the signal, want <= 5" at_most "$wall" 5
check "SIGINT: no 'interrupted: the image so far' on stdout" grep -q "'^pmview: wrote .*interrupted: the image so far'" "$tmp/int.out"
check "SIGINT: the image is not an EXR" is_exr "$tmp/int.exr"
check "SIGINT: pmview cannot read the image as a reference" readable_render "$tmp/int.exr"
check "SIGINT: a pmview rank is left running" [ -z "'$(job_processes any)'" ]

# --- 5. a killed rank: the job ends naming it, non-zero, with the last checkpoint valid
wall=""
mpi_job $cornell --width 64 --time 60 --checkpoint 0.5 --snapshot "$tmp/ck.exr" >"$tmp/ck.out" 2>&1 &
job=$!
i=0
while ! is_exr "$tmp/ck.exr" && [ "$i" -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
sleep 1.5
rank1=$(job_processes 1)
if [ -z "$rank1" ] || ! is_exr "$tmp/ck.exr"; then
    fail "killed rank: no rank 1 ('$rank1') or no checkpoint after 10 s"
    sed 's/^/    /' "$tmp/ck.out" | head -5
    kill -KILL "$job"
else
    sent=$(now)
    kill -KILL $rank1
    job_ends "killed rank"
fi
wait "$job"; rc=$?; job=""
echo "killed rank: mpirun ended ${wall:-?} s after rank 1 was killed, exit $rc"
check "killed rank: the job ended ${wall:-?} s after the kill, want <= 5" at_most "${wall:-99}" 5
check "killed rank: exit 0" [ "$rc" -ne 0 ]
check "killed rank: the output does not name rank 1" grep -q "'rank 1'" "$tmp/ck.out"
check "killed rank: pmview's own line does not name rank 1" grep -q "'^pmview: .*rank 1'" "$tmp/ck.out"
check "killed rank: the checkpoint is not an EXR" is_exr "$tmp/ck.exr"
check "killed rank: pmview cannot read the checkpoint as a reference" readable_render "$tmp/ck.exr"
check "killed rank: a pmview rank is left running" [ -z "'$(job_processes any)'" ]
[ "$fails" -gt 0 ] && sed 's/^/    | /' "$tmp/ck.out"

# --- 6. a bad scene is refused once: one 'pmview:' line (mpirun's own banner never starts so),
# non-zero, nothing on stdout
head -c 300 scenes/cornell-box.gltf >"$tmp/corrupt.gltf"
for scene in "$tmp/no-such-scene.gltf" "$tmp/corrupt.gltf"; do
    name=$(basename "$scene")
    mpi "$scene" --width 16 --threads 1 --iterations 1 --snapshot "$tmp/bad.exr" >"$tmp/bad.out" 2>"$tmp/bad.err"
    rc=$?
    lines=$(grep -c "^pmview:" "$tmp/bad.err")
    check "$name: exit 0" [ "$rc" -ne 0 ]
    check "$name: $lines 'pmview:' lines on stderr, want 1" [ "$lines" -eq 1 ]
    check "$name: the line does not name the scene" grep -q "'^pmview: error: $scene'" "$tmp/bad.err"
    check "$name: pmview wrote to stdout" [ ! -s "'$tmp/bad.out'" ]
    check "$name: an image was written" [ ! -e "'$tmp/bad.exr'" ]
    grep "^pmview:" "$tmp/bad.err"
done

# --- 6b. --watch under mpirun (a reload is one process's set-up): refused at the start, one
# 'pmview:' line naming --watch and mpirun, exit 2, nothing rendered
mpi $cornell --width 16 --threads 1 --iterations 1 --watch --snapshot "$tmp/watch.exr" >"$tmp/watch.out" 2>"$tmp/watch.err"
rc=$?
lines=$(grep -c "^pmview:" "$tmp/watch.err")
check "--watch under mpirun: exit $rc, want 2" [ "$rc" -eq 2 ]
check "--watch under mpirun: $lines 'pmview:' lines on stderr, want 1" [ "$lines" -eq 1 ]
check "--watch under mpirun: the line does not name --watch and mpirun" grep -q "'^pmview: --watch .*mpirun'" "$tmp/watch.err"
check "--watch under mpirun: an image was written" [ ! -e "'$tmp/watch.exr'" ]
grep "^pmview:" "$tmp/watch.err"

# --- 6c. pmview itself does not link Open MPI: its module, beside it, does
check "pmview links libmpi (only pmview-cluster.so should)" "! readelf -d $bin | grep -q 'NEEDED.*libmpi'"
check "pmview-cluster.so beside $bin does not link libmpi" "readelf -d $(dirname "$bin")/pmview-cluster.so | grep -q 'NEEDED.*libmpi'"

# --- 7. --log into a missing folder or onto a directory: refused in the set-up, so every rank
# ends: one 'pmview:' line naming the path, non-zero, no rank left. Before, rank 0 printed its
# error and ended while rank 1 waited for a merge for ever.
for log in "$tmp/no-such-folder/run.csv" "$tmp"; do
    ASAN_OPTIONS=detect_leaks=0 timeout 60 mpirun --oversubscribe -np 2 $bin $cornell --width 16 --threads 1 --iterations 1 \
        --snapshot "$tmp/log.exr" --log "$log" </dev/null >"$tmp/log.out" 2>"$tmp/log.err"
    rc=$?
    lines=$(grep -c "^pmview:" "$tmp/log.err")
    echo "--log $log: exit $rc, $(grep "^pmview:" "$tmp/log.err" | head -n 1)"
    check "--log $log: the job did not end within 60 s" [ "$rc" -ne 124 ]
    check "--log $log: exit 0" [ "$rc" -ne 0 ]
    check "--log $log: $lines 'pmview:' lines on stderr, want 1" [ "$lines" -eq 1 ]
    check "--log $log: the line does not name the log" grep -q "'^pmview: error: $log: cannot write the log'" "$tmp/log.err"
    check "--log $log: a pmview rank is left running" [ -z "'$(job_processes any)'" ]
    for p in $(job_processes any); do kill -KILL "$p" 2>/dev/null; done
done

# --- 8. ranks that disagree: a different file per rank, a stale copy at the same path in each
# rank's working directory, a bad option on rank 1 alone. Each job ends with one 'pmview:' line
# naming the cause, non-zero, nothing written. Before, the first two summed both scenes into one
# image without a word, and the third printed the usage text's last line as the error.
mkdir -p "$tmp/wd0" "$tmp/wd1"
cp scenes/cornell-box.gltf "$tmp/wd0/s.gltf"
cp scenes/point-room.gltf "$tmp/wd1/s.gltf"
disagree() { # description, want (text in the line), then mpirun's app contexts
    desc=$1; want=$2; shift 2
    rm -f "$tmp/mpmd.exr"
    ASAN_OPTIONS=detect_leaks=0 timeout 60 mpirun --oversubscribe "$@" </dev/null >"$tmp/mpmd.out" 2>"$tmp/mpmd.err"
    rc=$?
    lines=$(grep -c "^pmview:" "$tmp/mpmd.err")
    echo "$desc: exit $rc, $(grep "^pmview:" "$tmp/mpmd.err" | head -n 1)"
    check "$desc: exit $rc, want non-zero and not a timeout" [ "$rc" -ne 0 ] \&\& [ "$rc" -ne 124 ]
    check "$desc: $lines 'pmview:' lines on stderr, want 1" [ "$lines" -eq 1 ]
    check "$desc: the line does not say '$want'" grep -q "'^pmview: .*$want'" "$tmp/mpmd.err"
    check "$desc: an image was written" [ ! -e "'$tmp/mpmd.exr'" ]
    for p in $(job_processes any); do kill -KILL "$p" 2>/dev/null; done
}
opts="--width 16 --threads 1 --iterations 2 --snapshot $tmp/mpmd.exr"
disagree "a different scene per rank" "rank 1 holds another scene or other options than rank 0" \
    -np 1 $bin scenes/cornell-box.gltf $opts : -np 1 $bin scenes/point-room.gltf $opts
disagree "a stale copy in rank 1's folder" "rank 1 holds another scene or other options than rank 0" \
    -np 1 --wdir "$tmp/wd0" "$PWD/$bin" s.gltf $opts : -np 1 --wdir "$tmp/wd1" "$PWD/$bin" s.gltf $opts
disagree "other options on rank 1" "rank 1 holds another scene or other options than rank 0" \
    -np 1 $bin scenes/cornell-box.gltf $opts : -np 1 $bin scenes/cornell-box.gltf $opts --photons 5000
disagree "a bad option on rank 1" "rank 1: unknown option .--bogus." \
    -np 1 $bin scenes/cornell-box.gltf $opts : -np 1 $bin scenes/cornell-box.gltf $opts --bogus

# --- 9. --max-memory counts the merge's buffers: at 512x512 a limit of 90 MB fits one process
# (film, photon statistics, EXR buffers: about 91 MB committed at its peak) but not rank 0 of two,
# which also holds a send and a receive buffer of the packed film (84 MB) and the merged film. The
# 2-rank job is refused in the set-up, one line naming the buffers, no image. Before, it rendered
# to the end and failed at the merge, and rank 0 peaked past the limit.
$bin scenes/cornell-box.gltf --width 512 --iterations 1 --threads 1 --max-memory 90M --quiet --snapshot "$tmp/one.exr" 2>"$tmp/one.err"
rc=$?
check "--max-memory 90M: one process does not fit (exit $rc): $(head -n 1 "$tmp/one.err")" [ "$rc" -eq 0 ]
rm -f "$tmp/two.exr"
mpi scenes/cornell-box.gltf --width 512 --iterations 2 --threads 1 --max-memory 90M --snapshot "$tmp/two.exr" >"$tmp/two.out" 2>"$tmp/two.err"
rc=$?
echo "--max-memory 90M on 2 ranks: exit $rc, $(grep "^pmview:" "$tmp/two.err" | head -n 1)"
check "--max-memory 90M on 2 ranks: exit 0" [ "$rc" -ne 0 ]
check "--max-memory 90M on 2 ranks: not one line naming the merge buffers" [ "$(grep -c "^pmview: error: .*the cluster's merge buffers" "$tmp/two.err")" -eq 1 ]
check "--max-memory 90M on 2 ranks: an image was written" [ ! -e "'$tmp/two.exr'" ]
check "--max-memory 90M on 2 ranks: rendering reported" ! grep -q "'^stat eye\|wrote'" "$tmp/two.out"

# --- 10. a rank stopped (SIGSTOP) in the render of a --time 4 run: it never says its run is over,
# and no signal reveals it; rank 0 waits 5 s + 10% of --time past its own end, then ends the job
# naming it: at most 4 + 5.4 s after the stop. The stop comes 1 s after rank 0's set-up ended
# ('stat film'), when rank 1's has too: not at the first 'stat progress' (see rendering), as rank 0
# would then ask the stopped rank for merges (case 10b).
mpi_job $cornell --width 32 --stats --time 4 --snapshot "$tmp/stop.exr" >"$tmp/stop.out" 2>&1 &
job=$!
i=0; while ! grep -qs "^stat film" "$tmp/stop.out" && [ "$i" -lt 1200 ]; do sleep 0.05; i=$((i + 1)); done
sleep 1  # past the set-up's agreement: the render is under way
rank1=$(rank_of "$job" 1)
stopped_rank_ends "$rank1" "stopped rank"
echo "stopped rank: mpirun ended $wall s after the stop, exit $rc, $(grep "^pmview:" "$tmp/stop.out" | head -n 1)"
check "stopped rank: no rank 1 to stop" [ -n "'$rank1'" ]
check "stopped rank: the job ended $wall s after the stop, want <= 12 (at most --time 4, then 5.4 s)" at_most "$wall" 12
check "stopped rank: exit 0" [ "$rc" -ne 0 ]
check "stopped rank: pmview's line does not name rank 1 as stopped" grep -q "'^pmview: error: rank 1 gave no word that its run is over .* past --time'" "$tmp/stop.out"
for p in $(job_processes any); do kill -KILL "$p" 2>/dev/null; done

# --- 10b. a rank stopped (SIGSTOP) at rank 0's first 'stat progress' of a 3-rank --time 1 run:
# rank 0's next progress row is a merge, begun before the deadline, that waits for the stopped
# rank's image. It waits until 1 s + 5.1 s of patience (5 s + 10% of --time) past the run's start,
# then ends the job with one line naming rank 2 alone (rank 1 answered): at most 6.1 s after the
# stop, and the job never ends before --time + patience from mpirun's start. Of the 3 s of margin,
# MPI_Abort's teardown takes about 1 (mpirun's SIGKILL reaches the stopped rank 1 s after its
# SIGTERM; the ASan build ended 7.1 s after the stop), the rest is room for a loaded machine.
started=$(now)
mpi_job3 $cornell $rendered32 --time 1 --snapshot "$tmp/stop3.exr" >"$tmp/stop3.out" 2>&1 &
job=$!
rendering "$tmp/stop3.out"
rank2=$(rank_of "$job" 2)
stopped_rank_ends "$rank2" "stopped rank in a merge"
total=$(elapsed "$started" "$(now)")
echo "stopped rank in a merge: mpirun ended $wall s after the stop ($total s after its start), exit $rc, $(grep "^pmview:" "$tmp/stop3.out" | head -n 1)"
check "stopped rank in a merge: no rank 2 to stop" [ -n "'$rank2'" ]
check "stopped rank in a merge: the job ended $wall s after the stop, want <= 9.1 (at most --time 1, then 5.1 s, and 3 s)" at_most "$wall" 9.1
check "stopped rank in a merge: the job ended $total s after its start, before --time 1 and 5.1 s of patience" at_most 6.1 "$total"
check "stopped rank in a merge: exit $rc, want non-zero" [ "$rc" -ne 0 ]
named=$(grep -c "^pmview: error: rank 2 gave no image for the merge 5.1 s past --time: taken for stopped, the job ends" "$tmp/stop3.out")
check "stopped rank in a merge: $named lines naming rank 2 alone as stopped in a merge, want 1" [ "$named" -eq 1 ]
for p in $(job_processes any); do kill -KILL "$p" 2>/dev/null; done

# --- 11. SIGTERM to rank 0 alone (kill on its pid, not mpirun's to every rank): rank 0 asks the
# others to end their runs, merges and writes the image so far, exit 143, within 5 s. Before,
# the healthy rank 1 was taken for gone after 0.5 s and no image was written.
rm -f "$tmp/term0.exr"
mpi_job $cornell $rendered32 --time 60 --snapshot "$tmp/term0.exr" >"$tmp/term0.out" 2>&1 &
job=$!
rendering "$tmp/term0.out"  # past the set-up: the render is under way
rank0=$(rank_of "$job" 0)
sent=$(now)
[ -n "$rank0" ] && kill -TERM $rank0
job_ends "SIGTERM to rank 0"
wait "$job"; rc=$?; job=""
echo "SIGTERM to rank 0 alone: mpirun ended $wall s after it, exit $rc, $(grep "^pmview:" "$tmp/term0.out" | head -n 1)"
check "SIGTERM to rank 0 alone: no rank 0 found" [ -n "'$rank0'" ]
check "SIGTERM to rank 0 alone: the job ended $wall s after the signal, want <= 5" at_most "$wall" 5
check "SIGTERM to rank 0 alone: no 'interrupted: the image so far'" grep -q "'^pmview: wrote .*interrupted: the image so far'" "$tmp/term0.out"
check "SIGTERM to rank 0 alone: the image is not an EXR" is_exr "$tmp/term0.exr"
check "SIGTERM to rank 0 alone: a pmview rank is left running" [ -z "'$(job_processes any)'" ]
for p in $(job_processes any); do kill -KILL "$p" 2>/dev/null; done

# --- 12. a rank stopped (SIGSTOP) during its set-up, before its word at the agreement: rank 0
# waits 10 s + 4 times its own set-up for every rank's word, then ends the job naming it (16 s
# after the stop on a loaded machine with a 500,000-triangle scene). Before,
# the agreement was a collective, which a stopped rank held for ever. The scene is a generated
# 180,000-triangle emitting grid, so that a rank's set-up lasts long enough to be stopped in it
# (0.8-1.7 s under ASan on a loaded machine), yet rank 0's patience of 4 set-ups stays short;
# a rank is past MPI's start once its stderr is the file it keeps (a deleted temporary file).
python3 - "$tmp/grid.gltf" 300 <<'EOF'
import json, struct, sys
out, n = sys.argv[1], int(sys.argv[2])
pos = b''.join(struct.pack('<3f', i / n - 0.5, j / n - 0.5, 0.0) for j in range(n + 1) for i in range(n + 1))
idx = b''.join(struct.pack('<6I', a, a + 1, a + n + 2, a, a + n + 2, a + n + 1)
               for a in (j * (n + 1) + i for j in range(n) for i in range(n)))
open(out + '.bin', 'wb').write(pos + idx)
json.dump({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
           "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 2]}],
           "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
           "materials": [{"emissiveFactor": [1, 1, 1], "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
           "buffers": [{"uri": out.split('/')[-1] + '.bin', "byteLength": len(pos) + len(idx)}],
           "bufferViews": [{"buffer": 0, "byteLength": len(pos)},
                           {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": (n + 1) ** 2, "type": "VEC3",
                          "min": [-0.5, -0.5, 0], "max": [0.5, 0.5, 0]},
                         {"bufferView": 1, "componentType": 5125, "count": 6 * n * n, "type": "SCALAR"}]},
          open(out, 'w'))
EOF
mpi_job "$tmp/grid.gltf" --threads 1 --width 32 --iterations 4 --snapshot "$tmp/setup-stop.exr" >"$tmp/setup-stop.out" 2>&1 &
job=$!
i=0; rank1=""
# mpirun's children, not all of /proc: found within milliseconds of their start
while [ -z "$rank1" ] && [ "$i" -lt 3000 ] && kill -0 "$job" 2>/dev/null; do
    for p in $(ps -o pid= --ppid "$job"); do
        tr '\0' '\n' <"/proc/$p/environ" 2>/dev/null | grep -qx OMPI_COMM_WORLD_RANK=1 && rank1=$p
    done
    i=$((i + 1)); [ -z "$rank1" ] && sleep 0.01
done
i=0; stopped=false
while [ -n "$rank1" ] && [ "$i" -lt 3000 ] && kill -0 "$rank1" 2>/dev/null; do
    if readlink "/proc/$rank1/fd/2" 2>/dev/null | grep -q '(deleted)'; then kill -STOP $rank1; stopped=true; break; fi
    sleep 0.01; i=$((i + 1))
done
sent=$(now)
i=0
while kill -0 "$job" 2>/dev/null && [ "$i" -lt 900 ]; do sleep 0.1; i=$((i + 1)); done
wall=$(elapsed "$sent" "$(now)")
if kill -0 "$job" 2>/dev/null; then fail "stopped in the set-up: mpirun still running 90 s after the stop"; kill -KILL "$job"; fi
wait "$job"; rc=$?; job=""
[ -n "$rank1" ] && kill -CONT $rank1 2>/dev/null
echo "stopped in the set-up: mpirun ended $wall s after the stop, exit $rc, $(grep "^pmview:" "$tmp/setup-stop.out" | head -n 1)"
check "stopped in the set-up: no rank 1 past MPI's start to stop" $stopped
check "stopped in the set-up: exit 0" [ "$rc" -ne 0 ]
named=$(grep -c "^pmview: error: rank 1 gave no word at the set-up.s agreement .* (stopped or hung): the job ends" "$tmp/setup-stop.out")
check "stopped in the set-up: $named lines naming rank 1 as silent at the agreement, want 1" [ "$named" -eq 1 ]
check "stopped in the set-up: rendering was reported" ! grep -q "'^pmview: wrote'" "$tmp/setup-stop.out"
for p in $(job_processes any); do kill -KILL "$p" 2>/dev/null; done

echo "test_cluster: $checks checks, $fails failed"
[ "$fails" -eq 0 ]
