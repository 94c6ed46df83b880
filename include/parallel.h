/* parallel.h: a minimal parallel-for over task indices on a fixed number of pthreads.
 *
 * Work is handed out by an atomic counter, so load balances itself; determinism comes from
 * seeding each task's random stream by its index (rng.h), never from the thread that runs it.
 */
#ifndef PM_PARALLEL_H
#define PM_PARALLEL_H

#ifdef __cplusplus
/* the loader (C++) decodes its images in parallel; C11's atomic_bool is std::atomic_bool there */
#include <atomic>
#include <cstddef>
typedef std::atomic_bool atomic_bool;
extern "C" {
#else
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#endif

/* Calls fn(ctx, task, thread) for task in [0, count), on `threads` threads (the caller's one
 * included); thread is in [0, threads). Returns when all tasks are done. */
void pm_parallel_for(int threads, size_t count, void (*fn)(void *ctx, size_t task, int thread), void *ctx);
/* Every parallel-for started later on the calling thread stops handing out tasks once *flag is
 * true (NULL: never). A render session's worker sets it, so a restart or a quit is answered within
 * one task however long the pass; the caller then takes back what the tasks that ran wrote (a
 * cancelled iteration leaves nothing, see eye.h). */
void pm_parallel_set_cancel(const atomic_bool *flag);
/* The calling thread's flag (NULL: none), for work that also looks at it inside a long task (a
 * photon chunk of long paths) or must tell a pass cut short from a finished one. */
const atomic_bool *pm_parallel_get_cancel(void);
/* For tests: every parallel-for started later on the calling thread calls observer(ctx, task,
 * count) before each task it hands out (count: the loop's tasks), on the thread that runs the
 * task (NULL: none). A test that sets its cancel flag there knows the cancel landed in the middle
 * of a pass. */
void pm_parallel_set_task_observer(void (*observer)(void *ctx, size_t task, size_t count), void *ctx);
/* Whether the calling thread's flag is set. */
bool pm_parallel_cancelled(void);
/* A requested thread count made usable: at least 1, at most PM_MAX_THREADS (defaults.h). */
int pm_thread_count(int requested);
/* Number of online cores. */
int pm_cpu_count(void);

#ifdef __cplusplus
}
#endif

#endif
