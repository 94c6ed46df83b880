# job_processes.sh: sourced by the tests that start pmview under mpirun: finds this test's own ranks by the PMVIEW_TEST_JOB each carries.
#
# job_processes RANK|any: the pids of this test's pmview processes still running (RANK: that MPI
# rank only), so finding rank 1, and the check that none is left, never touch another pmview.
job_processes() {
    for d in /proc/[0-9]*; do
        [ "$(cat "$d/comm" 2>/dev/null)" = pmview ] || continue
        vars=$( (tr '\0' '\n' <"$d/environ") 2>/dev/null)
        echo "$vars" | grep -qx "PMVIEW_TEST_JOB=$PMVIEW_TEST_JOB" || continue
        [ "$1" = any ] || echo "$vars" | grep -qx "OMPI_COMM_WORLD_RANK=$1" || continue
        echo "${d#/proc/}"
    done
}
