/* memory.h: checked allocation: every large or per-pass allocation goes through here, so a failure is reported (what, how much), never a crash.
 *
 * pm_malloc/pm_calloc/pm_realloc behave as the C library's and, on failure, record the
 * failure's description (what, bytes). An error names the failure of the operation that failed,
 * never an older one that was handled: a top-level operation clears the record before it starts
 * (pm_memory_clear_failure, then pm_memory_failure), and an operation nested inside others takes
 * a mark first (pm_memory_failure_mark, then pm_memory_failure_since, which answers with the
 * caller's own failures only); a failure handled without an error is forgiven
 * (pm_memory_forgive_last). pm_memory_admit()
 * refuses a structure estimated in bytes before it is allocated when it does not fit the memory
 * limit (--max-memory; by default PM_DEFAULT_MEMORY_SHARE of physical memory) beside everything
 * admitted and not yet released: the limit bounds the sum of the structures alive at once, not
 * each one alone. Whoever frees an admitted structure gives its bytes back with
 * pm_memory_release(). For tests, the
 * environment variable PMVIEW_FAIL_ALLOC=N makes the N-th checked allocation fail (and every
 * one after it when N is followed by '+'), so each failure path can be driven without running
 * out of memory for real.
 */
#ifndef PM_MEMORY_H
#define PM_MEMORY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

void *pm_malloc(size_t bytes, const char *what);
void *pm_calloc(size_t count, size_t size, const char *what);
void *pm_realloc(void *p, size_t bytes, const char *what);

/* The limit in bytes for all admitted structures together (0 before any set: the default). */
void pm_memory_set_limit(uint64_t bytes);
uint64_t pm_memory_limit(void);
/* PM_DEFAULT_MEMORY_SHARE of physical memory (sysconf), or 4 GiB when it cannot be read. */
uint64_t pm_memory_default_limit(void);
/* True when `bytes` for `what` fit beside what is committed: they are then committed until
 * pm_memory_release(bytes). Else nothing is committed, and the refusal (what, bytes, what was
 * already committed, the limit, --max-memory) is recorded. Thread-safe. */
bool pm_memory_admit(uint64_t bytes, const char *what);
/* Gives back bytes admitted earlier, when their structure is freed. */
void pm_memory_release(uint64_t bytes);
/* Bytes admitted and not yet released, and what the limit leaves beside them (0 when none). */
uint64_t pm_memory_committed(void);
uint64_t pm_memory_available(void);
/* Records the refusal line of pm_memory_admit for `bytes` of `what`, without committing: for a
 * structure that bounds itself by pm_memory_available() as it grows. */
void pm_memory_refuse(uint64_t bytes, const char *what);
/* Records a failure found elsewhere (an allocation inside a library). */
void pm_memory_fail(uint64_t bytes, const char *what);

/* The first failure since the last pm_memory_clear_failure(), as "what, N bytes" (or with the
 * limit when an estimate was refused); NULL when none. The text stays until the next clear. */
const char *pm_memory_failure(void);
void pm_memory_clear_failure(void);
/* A mark (the failures recorded so far), and the first failure recorded after it (NULL when
 * none): what failed inside the operation that took the mark, whatever failed before it and was
 * handled, cleared or not. The text is the calling thread's, until its next call. */
uint64_t pm_memory_failure_mark(void);
const char *pm_memory_failure_since(uint64_t mark);
/* That failure, or `otherwise` (what the caller was allocating) when none was recorded. */
const char *pm_memory_failure_since_or(uint64_t mark, const char *otherwise);
/* Failures belong to an owner: the thread that met them, or the thread whose parallel-for ran the
 * task that met them (its workers adopt its owner), so pm_memory_failure_since never answers with
 * another thread's failure. */
uint64_t pm_memory_owner(void);
void pm_memory_adopt_owner(uint64_t owner);
/* Forgives the calling thread's last failure, which it handled (a cache it does without): no
 * error names it afterwards, neither pm_memory_failure nor pm_memory_failure_since. */
void pm_memory_forgive_last(void);

/* Allocation-failure injection (tests): the n-th checked allocation from now fails (0 = none);
 * with `and_after`, every one after it too. Also set from PMVIEW_FAIL_ALLOC at the first call. */
void pm_memory_fail_at(uint64_t n, bool and_after);
/* Checked allocations made so far (to size an injection loop). */
uint64_t pm_memory_allocations(void);

/* The forecast of the process's peak resident memory, made from the structures' sizes as the
 * set-up learns them, so --stats can set it beside the measured peak. The process's resident
 * memory when the forecast starts is its baseline (code, libraries, the window's context). Each
 * stage then declares what it keeps (hold: the scene's arrays, the BVH, the film, photon maps;
 * negative when it frees) and what it needs only while it runs (phase: the loader's document
 * and copies, Embree's build-time memory, the output's buffers): the forecast is the baseline
 * plus the largest held + transient sum met. Thread-safe. */
void pm_memory_forecast_start(void);
void pm_memory_forecast_hold(int64_t bytes);
void pm_memory_forecast_phase(uint64_t transient_bytes);
uint64_t pm_memory_forecast(void);          /* baseline + the largest phase */
uint64_t pm_memory_forecast_baseline(void);
/* Resident bytes now (/proc/self/statm; 0 where it cannot be read). */
uint64_t pm_memory_resident_bytes(void);

/* Parses a size: a number with an optional K, M, G or T suffix (powers of 1024) and optional B. */
bool pm_memory_parse_size(const char *text, uint64_t *bytes);

#endif
