/* cluster.c: the MPI side of pmview: joining a job, agreeing on the set-up, merging the ranks' films by one reduction, and the window's commands to every rank; built alone as the module pmview-cluster.so (include/cluster_module.h). */
#include "cluster.h"
#include "cluster_module.h"

#include <fcntl.h>
#include <limits.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "clock.h"
#include "defaults.h"
#include "memory.h"

enum { TAG_COMMAND = 11, TAG_DONE = 12, TAG_TEXT = 13, TAG_READY = 14, TAG_AGREE = 15, TAG_VERDICT = 16, TAG_BYE = 17 };
enum { CMD_MERGE = 1, CMD_FINAL, CMD_RESTART, CMD_PAUSE, CMD_RESIZE, CMD_QUIT, CMD_STOP };
/* ahead of the film's additive form in a merge: the photons each rank emitted */
enum { TOTALS_FIELDS = 1 };

/* What rank 0 asks of the others; sent as bytes: every rank is the same binary. */
typedef struct {
    int type;
    int width, height;     /* CMD_RESIZE */
    int indirect;          /* CMD_RESTART: -1 keeps the setting */
    int has_camera;
    int paused;            /* CMD_PAUSE */
    uint64_t count;        /* CMD_MERGE, CMD_FINAL: the doubles each rank adds, to check every rank agrees */
    pm_camera camera;
} command;

struct pm_cluster {
    int rank, size;
    int real_stderr;       /* ranks other than 0: the terminal's stderr, kept for a failure's line */
    FILE *kept_stderr;     /* ... while their stderr goes here */
    pm_film merged;        /* rank 0: the sum of every rank's film */
    bool merged_made;
    double *send, *receive;
    size_t capacity;       /* doubles send (and receive) hold */
    uint64_t buffers_admitted; /* their bytes, admitted against --max-memory */
    pm_cluster_totals totals;
    /* the window's merge under way (rank 0): asked, waiting for every rank's word that it is ready */
    bool in_flight;
    int ready;
    bool *answered;        /* rank 0: which ranks have given the word awaited (ready, or their run done) */
    volatile sig_atomic_t *interrupted; /* a signal reached this rank (mpirun passes one on to every rank) */
    uint64_t epoch, flight_epoch;
    size_t flight_count;
    double last_merge_start;
    double joined_at;      /* when MPI started (pm_now_seconds): the set-up's time is measured from it */
    double agreed_at;      /* when the set-up was agreed (pm_now_seconds) */
    double deadline;       /* the run's --time deadline (pm_now_seconds), when end_patience is set */
    double end_patience;   /* rank 0: seconds it waits past the deadline for another rank's word, 0: no bound */
    char error[1024];
};

static bool take_word(pm_cluster *c, int tag);

static void nap(void) {
    struct timespec t = {0, 500000}; /* half a millisecond: MPI's own waits spin a core the renderer needs */
    nanosleep(&t, NULL);
}

/* Rank 0: ends the job naming the ranks not marked answered ("rank 1, 3 " then `why`): each wait
 * for another rank is bounded, and a rank silent past its bound (stopped, hung or gone) cannot be
 * waited for or ended by itself (MPI_Abort ends it). */
static void end_naming_silent(pm_cluster *c, const char *why) {
    int n = snprintf(c->error, sizeof c->error, "rank");
    int listed = 0;
    for (int k = 1; k < c->size && n < (int)sizeof c->error - 512; k++)
        if (!c->answered[k]) n += snprintf(c->error + n, sizeof c->error - (size_t)n, "%s %d", listed++ ? "," : "", k);
    snprintf(c->error + n, sizeof c->error - (size_t)n, " %s", why);
    pm_cluster_abort(c, c->error);
}


pm_cluster *pm_cluster_join(int *argc, char ***argv) {
    if (!getenv("OMPI_COMM_WORLD_SIZE") && !getenv("PMI_SIZE") && !getenv("PMIX_RANK")) return NULL;
    int provided = 0;
    if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        fprintf(stderr, "pmview: error: MPI could not start (started by mpirun, pmview joins its job)\n");
        exit(1);
    }
    uint64_t mark = pm_memory_failure_mark();
    pm_cluster *c = pm_calloc(1, sizeof *c, "the cluster's state");
    if (!c) {
        fprintf(stderr, "pmview: error: out of memory joining the MPI job (%s)\n", pm_memory_failure_since(mark));
        MPI_Abort(MPI_COMM_WORLD, 1);
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &c->rank);
    MPI_Comm_size(MPI_COMM_WORLD, &c->size);
    c->joined_at = pm_now_seconds();
    c->real_stderr = -1;
    c->answered = pm_calloc((size_t)c->size, sizeof *c->answered, "the cluster's table of ranks");
    if (!c->answered) {
        fprintf(stderr, "pmview: error: out of memory joining the MPI job (%s)\n", pm_memory_failure_since(mark));
        MPI_Abort(MPI_COMM_WORLD, 1);
    }
    if (c->rank > 0) {
        /* one voice: rank 0's; another rank's lines are read back when it is the one that failed */
        fflush(stdout);
        fflush(stderr);
        int null = open("/dev/null", O_WRONLY);
        if (null >= 0) { dup2(null, 1); close(null); }
        c->kept_stderr = tmpfile();
        if (c->kept_stderr) {
            c->real_stderr = dup(2);
            dup2(fileno(c->kept_stderr), 2);
        }
    }
    return c;
}

/* Before MPI_Finalize, which waits for every rank: each rank's word that it is leaving, rank 0
 * waiting PM_CLUSTER_QUIT_SECONDS at most for them. A rank stopped (SIGSTOP) after the last merge
 * held the job for ever in MPI_Finalize; it ends the job with a line naming it instead (rank 0's
 * files are written by then). */
static void say_goodbye(pm_cluster *c) {
    int bye = 1;
    if (c->rank != 0) {
        MPI_Send(&bye, 1, MPI_INT, 0, TAG_BYE, MPI_COMM_WORLD);
        return;
    }
    memset(c->answered, 0, (size_t)c->size * sizeof *c->answered);
    double start = pm_now_seconds();
    for (int heard = 0; heard < c->size - 1;) {
        if (take_word(c, TAG_BYE)) { heard++; continue; }
        if (pm_now_seconds() - start > PM_CLUSTER_QUIT_SECONDS) {
            char why[160];
            snprintf(why, sizeof why, "gave no word that it is leaving within %.3g s (stopped or hung): the job ends",
                     PM_CLUSTER_QUIT_SECONDS);
            end_naming_silent(c, why);
        }
        nap();
    }
}

void pm_cluster_leave(pm_cluster *c) {
    if (!c) return;
    say_goodbye(c);
    if (c->merged_made) pm_film_free(&c->merged);
    free(c->send);
    free(c->receive);
    pm_memory_release(c->buffers_admitted);
    free(c->answered);
    if (c->kept_stderr) fclose(c->kept_stderr);
    if (c->real_stderr >= 0) close(c->real_stderr);
    free(c);
    MPI_Finalize();
}

int pm_cluster_rank(const pm_cluster *c) { return c ? c->rank : 0; }
int pm_cluster_size(const pm_cluster *c) { return c ? c->size : 1; }
pm_cluster_totals pm_cluster_get_totals(const pm_cluster *c) {
    pm_cluster_totals none = {0};
    if (!c) return none;
    pm_cluster_totals t = c->totals;
    t.seconds_joined = c->agreed_at > 0 ? pm_now_seconds() - c->agreed_at : 0.0;
    return t;
}
const char *pm_cluster_error(const pm_cluster *c) { return c ? c->error : ""; }

uint64_t pm_cluster_seed(const pm_cluster *c, uint64_t seed) {
    if (!c || c->rank == 0) return seed;
    /* splitmix64 of the rank: streams no other rank's seed comes near */
    uint64_t z = seed + 0x9e3779b97f4a7c15ull * (uint64_t)c->rank;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return (z ^ (z >> 31)) & 0x7fffffffull;
}

uint32_t pm_cluster_share(const pm_cluster *c, uint32_t total) {
    if (!c) return total;
    uint32_t each = total / (uint32_t)c->size, rest = total % (uint32_t)c->size;
    return each + ((uint32_t)c->rank < rest ? 1u : 0u);
}

/* The last line this rank wrote to its kept stderr that starts "pmview:" (a failure's message:
 * a bad option's line comes before the usage text, which must not stand for it), else its last
 * line, or "". */
static void last_kept_line(pm_cluster *c, char *line, size_t size) {
    line[0] = 0;
    fflush(stderr);
    if (!c->kept_stderr) return;
    struct stat st;
    if (fstat(fileno(c->kept_stderr), &st) != 0 || st.st_size <= 0) return;
    static char tail[16384];
    off_t from = st.st_size > (off_t)sizeof tail - 1 ? st.st_size - (off_t)sizeof tail + 1 : 0;
    ssize_t n = pread(fileno(c->kept_stderr), tail, sizeof tail - 1, from);
    if (n <= 0) return;
    tail[n] = 0;
    while (n > 0 && (tail[n - 1] == '\n' || tail[n - 1] == '\r')) tail[--n] = 0;
    const char *start = strrchr(tail, '\n');
    start = start ? start + 1 : tail;
    for (const char *at = tail; at; at = strchr(at, '\n')) {
        if (*at == '\n') at++;
        if (strncmp(at, "pmview:", 7) == 0) start = at;
    }
    const char *end = strchr(start, '\n');
    size_t length = end ? (size_t)(end - start) : strlen(start);
    if (length > size - 1) length = size - 1;
    memcpy(line, start, length);
    line[length] = 0;
}

/* "pmview: X" as rank K's: "pmview: rank K: X". */
static void print_as_rank(FILE *f, int rank, const char *line) {
    const char *rest = strncmp(line, "pmview: ", 8) == 0 ? line + 8 : line;
    fprintf(f, "pmview: rank %d: %s\n", rank, rest);
}

/* A rank's word at the agreement, and rank 0's verdict on them all. */
typedef struct {
    int64_t code; /* < 0: ready; else the exit code of its failure */
    uint64_t digest;
} agree_word;
typedef struct {
    int64_t agreed;  /* the first failing rank's code, or -1 */
    int32_t first;   /* the lowest rank that failed, or size */
    int32_t differs; /* the lowest rank whose digest is not rank 0's, or 0 */
} agree_verdict;

/* Waits for a message of `tag` from `source` (MPI_ANY_SOURCE: any), napping, for at most `patience`
 * seconds; false when none came. Point-to-point with a bound rather than a collective: a rank that
 * is stopped (SIGSTOP) or hung would hold a collective, and so the whole job, for ever. */
static bool wait_for_message(int source, int tag, double patience, MPI_Status *status) {
    double start = pm_now_seconds();
    for (;;) {
        int waiting = 0;
        MPI_Iprobe(source, tag, MPI_COMM_WORLD, &waiting, status);
        if (waiting) return true;
        if (pm_now_seconds() - start > patience) return false;
        nap();
    }
}

int pm_cluster_agree(pm_cluster *c, int code, uint64_t digest) {
    if (!c) return code;
    /* every rank loads the same scene, so their set-ups take about as long: a rank silent for many
     * times rank 0's own set-up is stopped or hung, not slow (the others' bound is wider: rank 0
     * also opens the window; and so is rank 0's when it failed early, before the scene's load) */
    double setup = pm_now_seconds() - c->joined_at;
    double patience = c->rank == 0 && code < 0 ? PM_CLUSTER_AGREE_SECONDS + PM_CLUSTER_AGREE_FACTOR * setup
                                               : 3 * PM_CLUSTER_AGREE_SECONDS + 3 * PM_CLUSTER_AGREE_FACTOR * setup;
    agree_verdict verdict = {-1, c->size, 0};
    if (c->rank != 0) {
        agree_word word = {code, digest};
        MPI_Send(&word, sizeof word, MPI_BYTE, 0, TAG_AGREE, MPI_COMM_WORLD);
        if (!wait_for_message(0, TAG_VERDICT, patience, MPI_STATUS_IGNORE)) {
            char message[256];
            snprintf(message, sizeof message, "rank 0 gave no word at the set-up's agreement in %.3g s (stopped or hung): the job ends",
                     patience);
            pm_cluster_abort(c, message);
        }
        MPI_Recv(&verdict, sizeof verdict, MPI_BYTE, 0, TAG_VERDICT, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    } else {
        memset(c->answered, 0, (size_t)c->size * sizeof *c->answered);
        if (code >= 0) { verdict.first = 0; verdict.agreed = code; }
        for (int heard = 0; heard < c->size - 1; heard++) {
            MPI_Status status;
            if (!wait_for_message(MPI_ANY_SOURCE, TAG_AGREE, patience, &status)) {
                char why[160];
                snprintf(why, sizeof why, "gave no word at the set-up's agreement %.3g s after rank 0's set-up (stopped or hung): the job ends",
                         patience);
                end_naming_silent(c, why);
            }
            agree_word word;
            MPI_Recv(&word, sizeof word, MPI_BYTE, status.MPI_SOURCE, TAG_AGREE, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            int k = status.MPI_SOURCE;
            c->answered[k] = true;
            if (word.code >= 0 && k < verdict.first) { verdict.first = k; verdict.agreed = word.code; }
            /* each must hold rank 0's scene and options, or their images would be summed into one
             * (a different file per rank, a stale copy at the same path elsewhere) */
            if (word.code < 0 && code < 0 && word.digest != digest && (verdict.differs == 0 || k < verdict.differs))
                verdict.differs = k;
        }
        for (int k = 1; k < c->size; k++) MPI_Send(&verdict, sizeof verdict, MPI_BYTE, k, TAG_VERDICT, MPI_COMM_WORLD);
    }
    c->agreed_at = pm_now_seconds();
    if (verdict.first == c->size) {
        if (!verdict.differs) return -1;
        if (c->rank == 0)
            fprintf(stderr, "pmview: error: rank %d holds another scene or other options than rank 0 (their digests "
                            "differ): every rank must load the same file with the same options\n", verdict.differs);
        return 1;
    }
    if (verdict.first != 0) {
        char line[1024];
        if (c->rank == verdict.first) {
            last_kept_line(c, line, sizeof line);
            MPI_Send(line, (int)strlen(line) + 1, MPI_CHAR, 0, TAG_TEXT, MPI_COMM_WORLD);
        } else if (c->rank == 0) {
            MPI_Recv(line, sizeof line, MPI_CHAR, verdict.first, TAG_TEXT, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            line[sizeof line - 1] = 0;
            print_as_rank(stderr, verdict.first, line[0] ? line : "failed during set-up");
        }
    }
    return (int)verdict.agreed;
}

void pm_cluster_abort(pm_cluster *c, const char *message) {
    if (c->rank == 0) fprintf(stderr, "pmview: error: %s\n", message);
    else {
        char line[1200];
        snprintf(line, sizeof line, "pmview: rank %d: error: %s\n", c->rank, message);
        if (c->real_stderr >= 0 && write(c->real_stderr, line, strlen(line)) < 0) { /* nothing left to tell */ }
    }
    MPI_Abort(MPI_COMM_WORLD, 1);
}

/* ---- merging ---- */

/* The failure the merging call met since its mark, never an older one. */
static bool out_of_memory(pm_cluster *c, uint64_t mark) {
    snprintf(c->error, sizeof c->error, "out of memory (%s) merging the ranks' images",
             pm_memory_failure_since_or(mark, "merge buffers"));
    return false;
}

/* Room for a merge of `count` doubles (rank 0 also receives). */
static bool prepare_buffers(pm_cluster *c, size_t count) {
    if (count <= c->capacity) return true;
    uint64_t mark = pm_memory_failure_mark();
    free(c->send);
    free(c->receive);
    c->send = c->receive = NULL;
    c->capacity = 0;
    pm_memory_release(c->buffers_admitted);
    c->buffers_admitted = 0;
    uint64_t bytes = (uint64_t)count * sizeof(double) * (c->rank == 0 ? 2u : 1u);
    if (!pm_memory_admit(bytes, "the cluster's merge buffers")) return out_of_memory(c, mark);
    c->buffers_admitted = bytes;
    c->send = pm_malloc(count * sizeof(double), "the cluster's merge buffers");
    if (!c->send) return out_of_memory(c, mark);
    if (c->rank == 0) {
        c->receive = pm_malloc(count * sizeof(double), "the cluster's merge buffers");
        if (!c->receive) return out_of_memory(c, mark);
    }
    c->capacity = count;
    return true;
}

/* Rank 0's merged film, made with the size and layout of the forms it will unpack. */
static bool prepare_merged(pm_cluster *c, int width, int height, const bool components[PM_COMPONENT_COUNT],
                           const bool slots[PM_SLOT_COUNT]) {
    bool same = c->merged_made && c->merged.width == width && c->merged.height == height;
    for (int k = 0; k < PM_COMPONENT_COUNT && same; k++) same = (c->merged.sum[k] != NULL) == components[k];
    for (int k = 0; k < PM_SLOT_COUNT && same; k++) same = (c->merged.ppm[k] != NULL) == slots[k];
    if (same) return true;
    uint64_t mark = pm_memory_failure_mark();
    if (c->merged_made) pm_film_free(&c->merged);
    c->merged_made = false;
    if (!pm_film_init(&c->merged, width, height, components)) return out_of_memory(c, mark);
    c->merged_made = true;
    if (!pm_film_enable_ppm(&c->merged, slots)) return out_of_memory(c, mark);
    return true;
}

static bool prepare_merged_like(pm_cluster *c, const pm_film *film) {
    bool components[PM_COMPONENT_COUNT], slots[PM_SLOT_COUNT];
    for (int k = 0; k < PM_COMPONENT_COUNT; k++) components[k] = film->sum[k] != NULL;
    for (int k = 0; k < PM_SLOT_COUNT; k++) slots[k] = film->ppm[k] != NULL;
    return prepare_merged(c, film->width, film->height, components, slots);
}

/* This rank's share of a merge of `count` doubles into c->send, from the form the session's worker
 * published (the window): zeros where it has none of the merge's layout since the last restart. */
static void send_published(pm_cluster *c, const pm_session_packed *packed) {
    memcpy(c->send + TOTALS_FIELDS, packed->values, packed->count * sizeof(double));
    c->send[0] = (double)packed->photons;
}

static void pack_published(pm_cluster *c, pm_session *s, size_t count) {
    pm_session_packed packed;
    memset(c->send, 0, count * sizeof(double));
    if (!pm_session_lock_packed(s, &packed)) return;
    if (packed.count + TOTALS_FIELDS == count) send_published(c, &packed);
    pm_session_unlock_latest(s);
}

/* ... or from its film between two iterations (snapshots: this thread runs them). */
static void pack_film(pm_cluster *c, pm_session *s) {
    pm_film_pack(pm_session_film(s), c->send + TOTALS_FIELDS);
    c->send[0] = (double)pm_session_photons(s);
}

static void count_sent(pm_cluster *c, size_t count) {
    c->totals.merges++;
    c->totals.bytes_per_merge = count * sizeof(double);
    if (c->rank != 0) c->totals.bytes_sent += count * sizeof(double);
}

static const pm_film *unpack_merged(pm_cluster *c) {
    c->totals.photons = (uint64_t)c->receive[0];
    pm_film_unpack(&c->merged, c->receive + TOTALS_FIELDS);
    return &c->merged;
}

static void send_all(pm_cluster *c, const command *cmd) {
    for (int k = 1; k < c->size; k++) {
        MPI_Send(cmd, sizeof *cmd, MPI_BYTE, k, TAG_COMMAND, MPI_COMM_WORLD);
        c->totals.bytes_sent += sizeof *cmd;
    }
}

/* A rank's part of the merge rank 0 asked for with cmd: its form packed, a word that it is ready,
 * then the reduction. Rank 0 waits for every word before it joins, so no rank spins in MPI while
 * another finishes an iteration, and the reduction itself runs at the speed of the network. */
static void answer_merge(pm_cluster *c, pm_session *s, const command *cmd, bool published) {
    size_t count = (size_t)cmd->count;
    if (!published && TOTALS_FIELDS + pm_film_packed_count(pm_session_film(s)) != count) {
        char message[256];
        snprintf(message, sizeof message, "its image holds %zu values where rank 0's holds %zu (not the same scene or options?)",
                 TOTALS_FIELDS + pm_film_packed_count(pm_session_film(s)), count);
        pm_cluster_abort(c, message);
    }
    if (!prepare_buffers(c, count)) pm_cluster_abort(c, c->error);
    if (published) pack_published(c, s, count);
    else pack_film(c, s);
    int ready = 1;
    MPI_Send(&ready, 1, MPI_INT, 0, TAG_READY, MPI_COMM_WORLD);
    MPI_Reduce(c->send, NULL, (int)count, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
    count_sent(c, count);
}

void pm_cluster_watch(pm_cluster *c, volatile sig_atomic_t *interrupted) {
    if (c) c->interrupted = interrupted;
}

/* Rank 0 waiting for a word from every rank: once a signal has come (mpirun sends one to every rank
 * when one dies, and a live rank answers within its running task), a rank silent for
 * PM_CLUSTER_SILENCE_SECONDS after it is taken for gone, and the job ends naming it. */
static void check_silence(pm_cluster *c, double *since, const char *awaited) {
    if (!c->interrupted || !*c->interrupted) return;
    if (*since == 0.0) { *since = pm_now_seconds(); return; }
    if (pm_now_seconds() - *since <= PM_CLUSTER_SILENCE_SECONDS) return;
    char why[160];
    snprintf(why, sizeof why, "gave no %s after the signal: taken for gone, the job ends", awaited);
    end_naming_silent(c, why);
}

/* Rank 0 waiting since `since` (pm_now_seconds) for a word from every rank: with a deadline
 * (pm_cluster_expect_end), every rank's iterations end by it (a first iteration may run past it,
 * on every rank alike), so a rank silent `end_patience` past the later of the deadline and the
 * wait's start is stopped or hung, and the job ends naming it. A wait begun before the deadline
 * lasts until then: a rank may take that long over an iteration. */
static void check_deadline(pm_cluster *c, double since, const char *awaited) {
    if (c->end_patience <= 0.0) return;
    double from = since > c->deadline ? since : c->deadline;
    if (pm_now_seconds() - from <= c->end_patience) return;
    char why[160];
    snprintf(why, sizeof why, "gave no %s %.3g s past --time: taken for stopped, the job ends", awaited, c->end_patience);
    end_naming_silent(c, why);
}

/* Rank 0: one word of `tag` from any rank if one has come, its sender marked as answered. Each rank
 * sends one word of a kind per merge or run, so words can be counted. */
static bool take_word(pm_cluster *c, int tag) {
    int waiting = 0, word;
    MPI_Status status;
    MPI_Iprobe(MPI_ANY_SOURCE, tag, MPI_COMM_WORLD, &waiting, &status);
    if (!waiting) return false;
    MPI_Recv(&word, 1, MPI_INT, status.MPI_SOURCE, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    c->answered[status.MPI_SOURCE] = true;
    return true;
}

/* Rank 0: takes the ready words that have come (all of them when block), true once every rank's is in. */
static bool take_ready(pm_cluster *c, bool block) {
    double since = 0.0, start = pm_now_seconds();
    if (c->ready == 0) memset(c->answered, 0, (size_t)c->size * sizeof *c->answered);
    while (c->ready < c->size - 1) {
        if (take_word(c, TAG_READY)) {
            c->ready++;
            continue;
        }
        if (!block) return false;
        check_silence(c, &since, "image for the merge");
        check_deadline(c, start, "image for the merge");
        nap();
    }
    return true;
}

/* Rank 0's side of a merge once every rank is ready: the reduction, then the sum unpacked. */
static const pm_film *reduce_at_root(pm_cluster *c, size_t count, bool unpack) {
    MPI_Reduce(c->send, c->receive, (int)count, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
    c->in_flight = false;
    count_sent(c, count);
    return unpack ? unpack_merged(c) : NULL;
}

static const pm_film *merge_from_root(pm_cluster *c, pm_session *s, int type) {
    const pm_film *film = pm_session_film(s);
    size_t count = TOTALS_FIELDS + pm_film_packed_count(film);
    if (count > INT_MAX) {
        snprintf(c->error, sizeof c->error, "the image is too large for one MPI reduction (%zu values)", count);
        return NULL;
    }
    bool ready = prepare_buffers(c, count) && prepare_merged_like(c, film);
    command cmd = {.type = type, .count = count, .indirect = -1};
    send_all(c, &cmd);
    if (!ready) pm_cluster_abort(c, c->error); /* the others are on their way into the reduction: end the job */
    pack_film(c, s);
    c->ready = 0;
    take_ready(c, true);
    return reduce_at_root(c, count, true);
}

const pm_film *pm_cluster_merge_now(pm_cluster *c, pm_session *s) { return merge_from_root(c, s, CMD_MERGE); }

void pm_cluster_expect_end(pm_cluster *c, double deadline, double patience) {
    if (!c) return;
    c->deadline = deadline;
    c->end_patience = patience > 0.0 ? patience : 0.0;
}

bool pm_cluster_prepare(pm_cluster *c, const pm_film *film) {
    if (!c) return true;
    size_t count = TOTALS_FIELDS + pm_film_packed_count(film);
    if (count > INT_MAX) {
        snprintf(c->error, sizeof c->error, "the image is too large for one MPI reduction (%zu values)", count);
        return false;
    }
    return prepare_buffers(c, count) && (c->rank != 0 || prepare_merged_like(c, film));
}

/* A command from rank 0 if one is waiting (block: wait for it, napping). */
static bool next_command(command *cmd, bool block) {
    for (;;) {
        int waiting = 0;
        MPI_Iprobe(0, TAG_COMMAND, MPI_COMM_WORLD, &waiting, MPI_STATUS_IGNORE);
        if (waiting) {
            MPI_Recv(cmd, sizeof *cmd, MPI_BYTE, 0, TAG_COMMAND, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            return true;
        }
        if (!block) return false;
        nap();
    }
}

void pm_cluster_serve(pm_cluster *c, pm_session *s) {
    if (!c || c->rank == 0) return;
    command cmd;
    while (next_command(&cmd, false)) {
        if (cmd.type == CMD_MERGE) answer_merge(c, s, &cmd, false);
        if (cmd.type == CMD_STOP) pm_session_cancel(s); /* rank 0 was signalled alone: end the run as a signal would */
    }
}

void pm_cluster_send_stop(pm_cluster *c) {
    if (!c || c->rank != 0) return;
    command cmd = {.type = CMD_STOP, .indirect = -1};
    send_all(c, &cmd);
}

const pm_film *pm_cluster_end_run(pm_cluster *c, pm_session *s, void (*tick)(void *context), void *context) {
    if (c->rank != 0) {
        int done = 1;
        MPI_Send(&done, 1, MPI_INT, 0, TAG_DONE, MPI_COMM_WORLD);
        command cmd;
        for (;;) {
            next_command(&cmd, true);
            if (cmd.type == CMD_MERGE || cmd.type == CMD_FINAL) answer_merge(c, s, &cmd, false);
            if (cmd.type == CMD_FINAL) return NULL;
        }
    }
    /* rank 0: every other rank's word that its run is over, then the last merge */
    memset(c->answered, 0, (size_t)c->size * sizeof *c->answered);
    int heard = 0;
    double since = 0.0, ended = pm_now_seconds();
    while (heard < c->size - 1) {
        if (take_word(c, TAG_DONE)) {
            heard++;
            continue;
        }
        if (tick) tick(context);
        check_silence(c, &since, "word that its run is over");
        check_deadline(c, ended, "word that its run is over");
        nap();
    }
    return merge_from_root(c, s, CMD_FINAL);
}

/* ---- the window ---- */

void pm_cluster_send_restart(pm_cluster *c, const pm_camera *camera, int indirect) {
    if (!c) return;
    command cmd = {.type = CMD_RESTART, .indirect = indirect, .has_camera = camera != NULL};
    if (camera) cmd.camera = *camera;
    c->epoch++;
    send_all(c, &cmd);
}

void pm_cluster_send_pause(pm_cluster *c, bool paused) {
    if (!c) return;
    command cmd = {.type = CMD_PAUSE, .paused = paused, .indirect = -1};
    send_all(c, &cmd);
}

/* Rank 0 in the window: the ranks not yet marked answered gave no word within
 * PM_CLUSTER_QUIT_SECONDS of `event` (the quit, a resize), where a live rank answers at once from
 * its command loop (pm_cluster_follow): stopped (SIGSTOP) or hung, as silent as a dead rank. */
static void silent_in_window(pm_cluster *c, const char *awaited, const char *event) {
    char why[160];
    snprintf(why, sizeof why, "gave no %s within %.3g s of the %s (stopped or hung): the job ends", awaited,
             PM_CLUSTER_QUIT_SECONDS, event);
    end_naming_silent(c, why);
}

/* Rank 0 in the window, from `start` (pm_now_seconds) of `event`: the merge under way, if any,
 * ends (its sum dropped), as every other rank is in it. */
static void end_merge_in_flight(pm_cluster *c, double start, const char *event) {
    if (!c->in_flight) return;
    while (!take_ready(c, false)) {
        if (pm_now_seconds() - start > PM_CLUSTER_QUIT_SECONDS) silent_in_window(c, "image for the merge under way", event);
        nap();
    }
    reduce_at_root(c, c->flight_count, false);
}

void pm_cluster_send_resize(pm_cluster *c, int width, int height, const pm_camera *camera) {
    if (!c) return;
    /* the merge under way is of the old size */
    end_merge_in_flight(c, pm_now_seconds(), "resize");
    command cmd = {.type = CMD_RESIZE, .width = width, .height = height, .indirect = -1, .has_camera = camera != NULL};
    if (camera) cmd.camera = *camera;
    c->epoch++;
    send_all(c, &cmd);
}

void pm_cluster_send_quit(pm_cluster *c) {
    if (!c) return;
    double start = pm_now_seconds();
    end_merge_in_flight(c, start, "quit");
    command cmd = {.type = CMD_QUIT, .indirect = -1};
    send_all(c, &cmd);
    /* every rank's word that it has stopped its session, so none is left waiting in MPI_Finalize */
    memset(c->answered, 0, (size_t)c->size * sizeof *c->answered);
    for (int heard = 0; heard < c->size - 1;) {
        if (take_word(c, TAG_DONE)) { heard++; continue; }
        if (pm_now_seconds() - start > PM_CLUSTER_QUIT_SECONDS) silent_in_window(c, "word that it has quit", "quit");
        nap();
    }
}

const pm_film *pm_cluster_poll_merge(pm_cluster *c, pm_session *s) {
    if (!c) return NULL;
    if (c->in_flight) {
        if (!take_ready(c, false)) return NULL;
        return reduce_at_root(c, c->flight_count, c->flight_epoch == c->epoch);
    }
    double now = pm_now_seconds();
    if (now - c->last_merge_start < PM_CLUSTER_MERGE_SECONDS) return NULL;
    /* the layout is that of rank 0's own newest form: none since the last restart, no merge yet */
    pm_session_packed packed;
    if (!pm_session_lock_packed(s, &packed)) return NULL;
    size_t count = TOTALS_FIELDS + packed.count;
    bool ready = count <= INT_MAX && prepare_buffers(c, count) &&
                 prepare_merged(c, packed.width, packed.height, packed.components, packed.slots);
    if (ready) send_published(c, &packed);
    pm_session_unlock_latest(s);
    if (!ready) return NULL;
    command cmd = {.type = CMD_MERGE, .count = count, .indirect = -1};
    send_all(c, &cmd);
    c->in_flight = true;
    c->ready = 0;
    c->flight_epoch = c->epoch;
    c->flight_count = count;
    c->last_merge_start = now;
    return NULL;
}

int pm_cluster_follow(pm_cluster *c, pm_session *s) {
    char err[1024];
    if (!pm_session_keep_packed(s, true) || !pm_session_start(s, err, sizeof err)) pm_cluster_abort(c, pm_session_error(s));
    command cmd;
    for (;;) {
        next_command(&cmd, true);
        switch (cmd.type) {
        case CMD_RESTART: pm_session_request_restart(s, cmd.has_camera ? &cmd.camera : NULL, cmd.indirect); break;
        case CMD_PAUSE: pm_session_pause(s, cmd.paused != 0); break;
        case CMD_RESIZE:
            if (!pm_session_resize(s, cmd.width, cmd.height, cmd.has_camera ? &cmd.camera : NULL))
                pm_cluster_abort(c, pm_session_error(s));
            break;
        case CMD_MERGE: answer_merge(c, s, &cmd, true); break;
        case CMD_QUIT: {
            pm_session_stop(s);
            int done = 1;
            MPI_Send(&done, 1, MPI_INT, 0, TAG_DONE, MPI_COMM_WORLD);
            return 0;
        }
        default: break;
        }
    }
}

/* ---- the module's one exported function (the rest is hidden: -fvisibility=hidden) ---- */

__attribute__((visibility("default"))) const pm_cluster_module *pm_cluster_module_functions(void) {
    static const pm_cluster_module functions = {
        .join = pm_cluster_join, .leave = pm_cluster_leave, .rank = pm_cluster_rank, .size = pm_cluster_size,
        .agree = pm_cluster_agree, .prepare = pm_cluster_prepare, .abort = pm_cluster_abort, .seed = pm_cluster_seed,
        .share = pm_cluster_share, .get_totals = pm_cluster_get_totals, .watch = pm_cluster_watch,
        .merge_now = pm_cluster_merge_now, .serve = pm_cluster_serve, .send_stop = pm_cluster_send_stop,
        .end_run = pm_cluster_end_run, .expect_end = pm_cluster_expect_end, .error = pm_cluster_error,
        .send_restart = pm_cluster_send_restart, .send_pause = pm_cluster_send_pause, .send_resize = pm_cluster_send_resize,
        .send_quit = pm_cluster_send_quit, .poll_merge = pm_cluster_poll_merge, .follow = pm_cluster_follow};
    return &functions;
}
