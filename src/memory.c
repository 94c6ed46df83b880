/* memory.c: checked allocation with failure recording, the memory limit on the sum of admitted structures, and allocation-failure injection for tests. */
#include "memory.h"

#include <ctype.h>
#include <inttypes.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "defaults.h"

static _Atomic uint64_t limit_bytes;
static _Atomic uint64_t committed_bytes;
static _Atomic uint64_t allocations;
static _Atomic uint64_t fail_at;       /* 0: no injection */
static atomic_bool fail_after;
static pthread_once_t env_once = PTHREAD_ONCE_INIT;
static pthread_mutex_t failure_lock = PTHREAD_MUTEX_INITIALIZER;
/* Every failure gets the next number (failures counts them, never reset) and its owner: the
 * thread that met it, or the thread whose parallel-for ran it (pm_memory_adopt_owner). The last
 * RECENT are kept with their numbers, so an operation that took a mark before it began can ask for
 * the first failure of its own after it, whatever failed before it, on another thread, or was
 * handled and forgiven (pm_memory_forgive_last). The first unforgiven failure since the last clear
 * is kept apart, at a fixed address, for pm_memory_failure. */
enum { RECENT = 16, TEXT = 320 };
typedef struct { uint64_t number, owner; bool forgiven; char text[TEXT]; } failure_record;
static uint64_t failures;
static failure_record recent[RECENT];
static char failure[TEXT];
static bool failed;
static uint64_t failed_number;  /* the number of the failure in `failure` */
static uint64_t cleared_after;  /* the failures counted at the last clear */
static _Atomic uint64_t owners; /* owners handed out so far */
static _Thread_local uint64_t thread_owner;       /* 0 until the thread's first failure or mark */
static _Thread_local uint64_t thread_last_failure; /* the number of the calling thread's last failure */
static _Thread_local char since_text[TEXT]; /* pm_memory_failure_since's answer, the calling thread's own */

uint64_t pm_memory_owner(void) {
    if (!thread_owner) thread_owner = atomic_fetch_add(&owners, 1) + 1;
    return thread_owner;
}

void pm_memory_adopt_owner(uint64_t owner) { thread_owner = owner; }

static void read_env(void) {
    const char *v = getenv("PMVIEW_FAIL_ALLOC");
    if (!v || !*v) return;
    char *end;
    unsigned long long n = strtoull(v, &end, 10);
    if (end != v) {
        atomic_store(&fail_at, (uint64_t)n);
        atomic_store(&fail_after, *end == '+');
    }
}

void pm_memory_fail_at(uint64_t n, bool and_after) {
    pthread_once(&env_once, read_env);
    atomic_store(&allocations, 0);
    atomic_store(&fail_at, n);
    atomic_store(&fail_after, and_after);
}

uint64_t pm_memory_allocations(void) { return atomic_load(&allocations); }

static void record(const char *text) {
    uint64_t owner = pm_memory_owner();
    pthread_mutex_lock(&failure_lock);
    failures++;
    failure_record *r = &recent[failures % RECENT];
    *r = (failure_record){.number = failures, .owner = owner, .forgiven = false};
    snprintf(r->text, TEXT, "%s", text);
    if (!failed) {
        snprintf(failure, sizeof failure, "%s", text);
        failed = true;
        failed_number = failures;
    }
    thread_last_failure = failures;
    pthread_mutex_unlock(&failure_lock);
}

uint64_t pm_memory_failure_mark(void) {
    pm_memory_owner();
    pthread_mutex_lock(&failure_lock);
    uint64_t n = failures;
    pthread_mutex_unlock(&failure_lock);
    return n;
}

const char *pm_memory_failure_since(uint64_t mark) {
    const char *answer = NULL;
    uint64_t owner = pm_memory_owner();
    pthread_mutex_lock(&failure_lock);
    /* the caller's first unforgiven failure after the mark, among those still kept (when more than
     * RECENT came after it, the oldest kept of its own: a failure of the operation all the same) */
    uint64_t first = failures - mark > RECENT ? failures - RECENT + 1 : mark + 1;
    for (uint64_t n = first; n <= failures && !answer; n++) {
        const failure_record *r = &recent[n % RECENT];
        if (r->owner != owner || r->forgiven) continue;
        snprintf(since_text, sizeof since_text, "%s", r->text);
        answer = since_text;
    }
    pthread_mutex_unlock(&failure_lock);
    return answer;
}

const char *pm_memory_failure_since_or(uint64_t mark, const char *otherwise) {
    const char *since = pm_memory_failure_since(mark);
    return since ? since : otherwise;
}

void pm_memory_forgive_last(void) {
    pthread_mutex_lock(&failure_lock);
    uint64_t n = thread_last_failure;
    if (n && failures - n < RECENT && recent[n % RECENT].number == n) recent[n % RECENT].forgiven = true;
    if (n && failed && failed_number == n) {
        /* the record since the last clear passes to the next unforgiven failure still kept */
        failed = false;
        failure[0] = 0;
        for (uint64_t k = n + 1; k <= failures && !failed; k++) {
            const failure_record *r = &recent[k % RECENT];
            if (r->number != k || r->forgiven || k <= cleared_after) continue;
            snprintf(failure, sizeof failure, "%s", r->text);
            failed = true;
            failed_number = k;
        }
    }
    thread_last_failure = 0;
    pthread_mutex_unlock(&failure_lock);
}

void pm_memory_fail(uint64_t bytes, const char *what) {
    char text[192];
    snprintf(text, sizeof text, "%s, %" PRIu64 " bytes", what, bytes);
    record(text);
}

/* Whether this allocation is the injected failure. */
static bool injected(void) {
    pthread_once(&env_once, read_env);
    uint64_t n = atomic_fetch_add(&allocations, 1) + 1, at = atomic_load(&fail_at);
    return at && (n == at || (n > at && atomic_load(&fail_after)));
}

void *pm_malloc(size_t bytes, const char *what) {
    void *p = injected() ? NULL : malloc(bytes ? bytes : 1);
    if (!p) pm_memory_fail(bytes, what);
    return p;
}

void *pm_calloc(size_t count, size_t size, const char *what) {
    void *p = NULL;
    bool overflow = size && count > SIZE_MAX / size;
    if (!injected() && !overflow) p = calloc(count ? count : 1, size ? size : 1);
    if (!p) pm_memory_fail(overflow ? UINT64_MAX : (uint64_t)count * size, what);
    return p;
}

void *pm_realloc(void *old, size_t bytes, const char *what) {
    void *p = injected() ? NULL : realloc(old, bytes ? bytes : 1);
    if (!p) pm_memory_fail(bytes, what); /* old stays allocated, as with realloc */
    return p;
}

uint64_t pm_memory_default_limit(void) {
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    if (pages <= 0 || page <= 0) return (uint64_t)4 << 30;
    return (uint64_t)((double)pages * (double)page * PM_DEFAULT_MEMORY_SHARE);
}

void pm_memory_set_limit(uint64_t bytes) { atomic_store(&limit_bytes, bytes); }

uint64_t pm_memory_limit(void) {
    uint64_t l = atomic_load(&limit_bytes);
    if (!l) {
        l = pm_memory_default_limit();
        atomic_store(&limit_bytes, l);
    }
    return l;
}

static void refuse(uint64_t bytes, uint64_t committed, const char *what) {
    char text[320];
    snprintf(text, sizeof text,
             "%s, %" PRIu64 " bytes, with %" PRIu64 " bytes already committed, over the limit of %" PRIu64
             " bytes; see --max-memory",
             what, bytes, committed, pm_memory_limit());
    record(text);
}

bool pm_memory_admit(uint64_t bytes, const char *what) {
    uint64_t limit = pm_memory_limit();
    uint64_t committed = atomic_load(&committed_bytes);
    /* a compare-and-swap loop: two threads admitting at once must not both take the last room */
    do {
        if (bytes > limit || committed > limit - bytes) {
            refuse(bytes, committed, what);
            return false;
        }
    } while (!atomic_compare_exchange_weak(&committed_bytes, &committed, committed + bytes));
    return true;
}

void pm_memory_release(uint64_t bytes) {
    uint64_t committed = atomic_load(&committed_bytes);
    /* never below zero: a release without its admission is a bug, and wrapping round would refuse all after it */
    while (!atomic_compare_exchange_weak(&committed_bytes, &committed, committed > bytes ? committed - bytes : 0)) {
    }
}

uint64_t pm_memory_committed(void) { return atomic_load(&committed_bytes); }

uint64_t pm_memory_available(void) {
    uint64_t limit = pm_memory_limit(), committed = atomic_load(&committed_bytes);
    return committed < limit ? limit - committed : 0;
}

void pm_memory_refuse(uint64_t bytes, const char *what) { refuse(bytes, atomic_load(&committed_bytes), what); }

const char *pm_memory_failure(void) {
    pthread_mutex_lock(&failure_lock);
    bool f = failed;
    pthread_mutex_unlock(&failure_lock);
    return f ? failure : NULL;
}

void pm_memory_clear_failure(void) {
    pthread_mutex_lock(&failure_lock);
    failed = false;
    failure[0] = 0;
    cleared_after = failures;
    pthread_mutex_unlock(&failure_lock);
}

/* ---- the forecast of the peak ---- */

static _Atomic uint64_t forecast_baseline, forecast_peak;
static _Atomic int64_t forecast_held;

uint64_t pm_memory_resident_bytes(void) {
    FILE *f = fopen("/proc/self/statm", "r");
    if (!f) return 0;
    unsigned long long pages_total = 0, pages_resident = 0;
    int read = fscanf(f, "%llu %llu", &pages_total, &pages_resident);
    fclose(f);
    long page = sysconf(_SC_PAGESIZE);
    return read == 2 && page > 0 ? (uint64_t)pages_resident * (uint64_t)page : 0;
}

void pm_memory_forecast_start(void) {
    atomic_store(&forecast_baseline, pm_memory_resident_bytes());
    atomic_store(&forecast_held, 0);
    atomic_store(&forecast_peak, 0);
}

void pm_memory_forecast_phase(uint64_t transient_bytes) {
    int64_t held = atomic_load(&forecast_held);
    uint64_t total = (held > 0 ? (uint64_t)held : 0) + transient_bytes;
    uint64_t peak = atomic_load(&forecast_peak);
    while (total > peak && !atomic_compare_exchange_weak(&forecast_peak, &peak, total)) {
    }
}

void pm_memory_forecast_hold(int64_t bytes) {
    atomic_fetch_add(&forecast_held, bytes);
    pm_memory_forecast_phase(0);
}

uint64_t pm_memory_forecast(void) { return atomic_load(&forecast_baseline) + atomic_load(&forecast_peak); }
uint64_t pm_memory_forecast_baseline(void) { return atomic_load(&forecast_baseline); }

bool pm_memory_parse_size(const char *text, uint64_t *bytes) {
    char *end;
    double v = strtod(text, &end);
    if (end == text || !(v > 0)) return false;
    double scale = 1;
    switch (toupper((unsigned char)*end)) {
    case 'K': scale = 1024.0; end++; break;
    case 'M': scale = 1024.0 * 1024; end++; break;
    case 'G': scale = 1024.0 * 1024 * 1024; end++; break;
    case 'T': scale = 1024.0 * 1024 * 1024 * 1024; end++; break;
    default: break;
    }
    if (toupper((unsigned char)*end) == 'B') end++;
    if (*end || v * scale >= 1.8e19 || v * scale < 1) return false;
    *bytes = (uint64_t)(v * scale);
    return true;
}
