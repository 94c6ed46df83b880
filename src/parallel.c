/* parallel.c: the parallel-for of parallel.h on plain pthreads with an atomic task counter. */
#include "parallel.h"

#include "defaults.h"
#include "memory.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

typedef struct {
    void (*fn)(void *, size_t, int);
    void *ctx;
    size_t count;
    atomic_size_t next;
    const atomic_bool *cancel;
    void (*observer)(void *, size_t, size_t);
    void *observer_ctx;
    uint64_t owner; /* the calling thread's owner of memory failures (memory.h): its workers' failures are its own */
} job;

/* Set by a render session's worker thread, read by every parallel-for it starts. */
static _Thread_local const atomic_bool *current_cancel;
static _Thread_local void (*current_observer)(void *, size_t, size_t);
static _Thread_local void *current_observer_ctx;

void pm_parallel_set_cancel(const atomic_bool *flag) { current_cancel = flag; }
const atomic_bool *pm_parallel_get_cancel(void) { return current_cancel; }
void pm_parallel_set_task_observer(void (*observer)(void *ctx, size_t task, size_t count), void *ctx) {
    current_observer = observer;
    current_observer_ctx = ctx;
}

bool pm_parallel_cancelled(void) { return current_cancel && atomic_load_explicit(current_cancel, memory_order_relaxed); }

typedef struct { job *j; int thread; } worker_arg;

static void run_worker(job *j, int thread) {
    for (;;) {
        if (j->cancel && atomic_load_explicit(j->cancel, memory_order_relaxed)) return;
        size_t task = atomic_fetch_add_explicit(&j->next, 1, memory_order_relaxed);
        if (task >= j->count) return;
        if (j->observer) j->observer(j->observer_ctx, task, j->count);
        j->fn(j->ctx, task, thread);
    }
}

static void *worker_main(void *p) {
    worker_arg *a = p;
    pm_memory_adopt_owner(a->j->owner);
    run_worker(a->j, a->thread);
    return NULL;
}

void pm_parallel_for(int threads, size_t count, void (*fn)(void *, size_t, int), void *ctx) {
    job j = {fn, ctx, count, 0, current_cancel, current_observer, current_observer_ctx, pm_memory_owner()};
    if (threads < 1) threads = 1;
    if ((size_t)threads > count) threads = count ? (int)count : 1;
    /* plain malloc: without these few bytes the calling thread runs every task, which is no failure
     * to report (pm_malloc would record one, and a later error could name it) */
    pthread_t *ids = threads > 1 ? malloc((threads - 1) * sizeof *ids) : NULL;
    worker_arg *args = threads > 1 ? malloc((threads - 1) * sizeof *args) : NULL;
    int started = 0;
    for (int t = 1; t < threads && ids && args; t++) { /* without them, this thread runs every task */
        args[t - 1] = (worker_arg){&j, t};
        if (pthread_create(&ids[t - 1], NULL, worker_main, &args[t - 1]) != 0) break;
        started++;
    }
    run_worker(&j, 0);
    for (int t = 0; t < started; t++) pthread_join(ids[t], NULL);
    free(ids);
    free(args);
}

int pm_thread_count(int requested) { return requested < 1 ? 1 : (requested > PM_MAX_THREADS ? PM_MAX_THREADS : requested); }

int pm_cpu_count(void) {
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}
