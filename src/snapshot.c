/* snapshot.c: the offscreen driver: a session run to --iterations or --time with its observer (progress bar, --log, --reference curve), then the file written; and the PNG of what the display shows. */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "clock.h"
#include "defaults.h"
#include "drivers.h"
#include "image_io.h"
#include "memory.h"

static volatile sig_atomic_t interrupted_by;
static pm_session *volatile signalled_session; /* its passes stop at the signal, not at the end of the iteration */

static void on_signal(int sig) {
    interrupted_by = sig;
    if (signalled_session) pm_session_cancel(signalled_session);
}

void pm_snapshot_catch_signals(pm_session *session) {
    signalled_session = session;
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
}

/* Where no render loop is left to notice a flag (a snapshot being written, the window, which a
 * signal ends outright): the file under way goes with the process (an EXR's hidden temporary
 * file stayed behind), and the exit status is an interrupted run's. */
static void on_signal_while_writing(int sig) {
    pm_remove_partial_output();
    _exit(sig == SIGINT ? 130 : 143);
}

void pm_exit_on_signals(void) {
    signalled_session = NULL;
    signal(SIGINT, on_signal_while_writing);
    signal(SIGTERM, on_signal_while_writing);
}

/* The offscreen view's share of a PNG: its RGBA8 target, OSMesa's buffer, four RGB float
 * component textures (16 bytes a texel: a driver may pad them to RGBA) and the RGBA8 copy read
 * back. */
static uint64_t png_view_bytes(int width, int height) { return (4 + 4 + 4 * 16 + 4) * (uint64_t)width * height; }

uint64_t pm_snapshot_output_bytes(const char *path, const pm_film *film) {
    if (!pm_has_extension(path, ".png")) return pm_exr_write_bytes(film->width, film->height);
    /* a PNG also resolves each component the film has into a layer of its own */
    uint64_t layers = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (film->sum[c]) layers += 3 * sizeof(float) * (uint64_t)film->width * film->height;
    return layers + png_view_bytes(film->width, film->height) + pm_png_write_bytes(film->width, film->height);
}

void pm_display_from_options(const pm_options *o, pm_display *display) {
    memset(display, 0, sizeof *display);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) display->enabled[c] = o->components_given ? o->components[c] : true;
    display->exposure_ev = (float)o->exposure_ev;
}

bool pm_write_png_view(const float *const layers[PM_COMPONENT_COUNT], int width, int height, const pm_display *display,
                       const char *path, char *err, size_t err_size) {
    uint64_t mark = pm_memory_failure_mark(); /* what fails in this call, never an older failure */
    uint64_t view_bytes = png_view_bytes(width, height);
    if (!pm_memory_admit(view_bytes, "PNG offscreen view")) {
        snprintf(err, err_size, "%s: out of memory (%s)", path, pm_memory_failure_since(mark));
        return false;
    }
    pm_view *view = pm_view_create_offscreen(width, height, err, err_size);
    bool ok = false;
    if (view) {
        pm_view_upload_layers(view, width, height, layers);
        pm_view_draw(view, display);
        uint8_t *rgba = pm_malloc(4 * (size_t)width * height, "PNG offscreen view");
        if (!rgba) snprintf(err, err_size, "%s: out of memory (%s)", path, pm_memory_failure_since(mark));
        else {
            pm_view_read_rgba8(view, rgba);
            ok = pm_write_png(path, width, height, rgba, err, err_size);
        }
        free(rgba);
        pm_view_destroy(view);
    }
    pm_memory_release(view_bytes);
    return ok;
}

/* The PNG snapshot: the film's layers resolved, drawn as the display shows them. */
static bool write_png_snapshot(const pm_options *o, const pm_film *film, char *err, size_t err_size) {
    uint64_t mark = pm_memory_failure_mark(); /* what fails in this call, never an older failure */
    pm_display display;
    pm_display_from_options(o, &display);
    size_t n = (size_t)film->width * film->height;
    float *layers[PM_COMPONENT_COUNT] = {NULL, NULL, NULL, NULL};
    uint64_t layer_bytes = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) layer_bytes += film->sum[c] ? sizeof(float) * 3 * n : 0;
    const bool admitted = pm_memory_admit(layer_bytes, "PNG output layers");
    bool ok = admitted;
    if (!ok) snprintf(err, err_size, "%s: out of memory (%s)", o->snapshot, pm_memory_failure_since(mark));
    for (int c = 0; c < PM_COMPONENT_COUNT && ok; c++) {
        if (!film->sum[c]) continue;
        layers[c] = pm_malloc(sizeof(float) * 3 * n, "PNG output layers");
        if (!layers[c]) { snprintf(err, err_size, "%s: out of memory (%s)", o->snapshot, pm_memory_failure_since(mark)); ok = false; break; }
        pm_film_resolve(film, (pm_component)c, layers[c]);
    }
    if (ok) ok = pm_write_png_view((const float *const *)layers, film->width, film->height, &display, o->snapshot, err, err_size);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) free(layers[c]);
    if (admitted) pm_memory_release(layer_bytes);
    return ok;
}

/* A checkpoint or the end: the film (the session's, or the cluster's merged one) to o->snapshot,
 * replacing it atomically (image_io.c writes beside it and renames). */
static bool write_snapshot(const pm_options *o, const pm_film *film, char *err, size_t err_size) {
    if (pm_has_extension(o->snapshot, ".png")) return write_png_snapshot(o, film, err, err_size);
    return pm_write_exr(o->snapshot, film, err, err_size);
}

/* The run's observer: after every iteration a --log row, a --reference point of the error curve
 * (with --stats), a --checkpoint and the progress bar; under mpirun, rank 0 reads them from the
 * merged film and the other ranks answer its merges. */
typedef struct {
    const pm_options *o;
    pm_cluster *cluster;
    const pm_reference_image *reference;
    float *scratch;           /* 3 floats a pixel for the reference's measures, or NULL */
    FILE *log;
    uint32_t logged;          /* the samples of the last log row */
    uint64_t next_progress;   /* the next error-curve point */
    bool tty;
    double start, last_checkpoint, last_merge;
    uint64_t *reserved;       /* the writers' room, lent to each checkpoint */
    pm_session *session;
    uint32_t logged_whole;    /* the image's samples in the last log row: under mpirun the merged
                               * film's, which other ranks' iterations raise after rank 0's last */
    double logged_rendered;   /* the rendering seconds of the last log row */
    long last_row_at;         /* where the last log row starts in the file */
} observer;

/* The snapshot's progress: a bar redrawn on a terminal, nothing otherwise (one summary at the end). */
static void show_progress(bool tty, uint32_t done, long target, double elapsed, double budget, uint64_t photons) {
    if (!tty) return;
    double fraction = budget > 0 ? elapsed / budget : (target > 0 ? (double)done / target : 0);
    if (fraction > 1) fraction = 1;
    char bar[31];
    int filled = (int)(fraction * 30);
    for (int i = 0; i < 30; i++) bar[i] = i < filled ? '#' : '.';
    bar[30] = 0;
    double left = fraction > 0 ? elapsed / fraction - elapsed : 0;
    fprintf(stderr, "\r[%s] %u it  %.2f Mphotons/s  %.1f s  %.1f s left ", bar, done,
            elapsed > 0 ? photons / elapsed * 1e-6 : 0.0, elapsed, left);
    fflush(stderr);
}

/* The whole image now: the session's film, or every rank's merged. */
static const pm_film *whole_image(observer *ob) {
    if (!ob->cluster) return pm_session_film(ob->session);
    const pm_film *merged = pm_cluster_merge_now(ob->cluster, ob->session);
    ob->last_merge = pm_now_seconds();
    if (!merged) pm_cluster_abort(ob->cluster, pm_cluster_error(ob->cluster));
    return merged;
}

static uint64_t whole_photons(const observer *ob, uint64_t own) {
    return ob->cluster ? pm_cluster_get_totals(ob->cluster).photons : own;
}

static void checkpoint(observer *ob, const pm_film *film) {
    char err[1024];
    ob->last_checkpoint = pm_now_seconds();
    /* the writers admit what they take: the room kept for the last write is theirs meanwhile */
    pm_memory_release(*ob->reserved);
    bool ok = write_snapshot(ob->o, film, err, sizeof err);
    if (!pm_memory_admit(*ob->reserved, "output buffers")) *ob->reserved = 0;
    if (!ok) fprintf(stderr, "%spmview: error: checkpoint: %s\n", ob->tty ? "\n" : "", err);
    pm_memory_clear_failure();
}

static bool checkpoint_due(const observer *ob) {
    return ob->o->checkpoint > 0 && pm_now_seconds() - ob->last_checkpoint >= ob->o->checkpoint;
}

/* While rank 0 waits for the others to finish: the checkpoints go on. */
static void tick(void *context) {
    observer *ob = context;
    if (checkpoint_due(ob)) checkpoint(ob, whole_image(ob));
}

static void observe(void *context, pm_session *session, const pm_session_run_state *state) {
    observer *ob = context;
    if (pm_cluster_rank(ob->cluster) != 0) {
        pm_cluster_serve(ob->cluster, session);
        return;
    }
    /* under mpirun a row is a merge, which waits for every rank's running iteration: at most one
     * every PM_CLUSTER_MERGE_SECONDS, or rank 0 would spend its time waiting */
    bool merge_allowed = !ob->cluster || pm_now_seconds() - ob->last_merge >= PM_CLUSTER_MERGE_SECONDS;
    bool log_row = ob->log && pm_log_wanted(ob->logged, state->samples) && merge_allowed;
    bool progress = ob->scratch && ob->o->stats && state->samples >= ob->next_progress && merge_allowed;
    bool save = checkpoint_due(ob);
    const pm_film *film = log_row || progress || save ? whole_image(ob) : NULL;
    if (log_row) {
        /* standard output, even redirected to a file, may hold other lines after a row: never rewritten */
        ob->last_row_at = ob->log == stdout ? -1 : ftell(ob->log);
        pm_log_row(ob->log, session, film, whole_photons(ob, state->photons), ob->reference, ob->scratch, state->rendered);
        ob->logged = state->samples;
        ob->logged_whole = film->samples;
        ob->logged_rendered = state->rendered;
    }
    if (progress) {
        /* at 1, 2, 4, 8, ... samples, or the first count past each when an iteration adds several */
        double ratio[3], e = pm_reference_relmse(film, ob->reference, ob->scratch, ratio);
        printf("stat progress iterations=%u seconds=%.4f relmse=%.6f\n", film->samples, pm_now_seconds() - ob->start, e);
        while (ob->next_progress <= state->samples) ob->next_progress *= 2;
    }
    if (save) checkpoint(ob, film);
    show_progress(ob->tty, state->samples * (uint32_t)pm_cluster_size(ob->cluster), ob->o->iterations,
                  pm_now_seconds() - ob->start, ob->o->time_limit, state->photons * (uint64_t)pm_cluster_size(ob->cluster));
}

int pm_snapshot_run(const pm_options *o, pm_cluster *cluster, pm_session *session, const pm_reference_image *reference,
                    uint64_t *reserved) {
    uint64_t mark = pm_memory_failure_mark(); /* what fails in this call, never an older failure */
    char err[1024];
    pm_snapshot_catch_signals(session);
    pm_cluster_watch(cluster, &interrupted_by);
    pm_output_watch(&interrupted_by);
    bool root = pm_cluster_rank(cluster) == 0;
    const pm_film *film = pm_session_film(session);
    observer ob = {.o = o, .cluster = cluster, .reference = reference, .next_progress = 1,
                   .tty = root && isatty(2) && !o->quiet, .reserved = reserved, .session = session};
    if (reference->rgb[0]) {
        ob.scratch = pm_malloc(sizeof(float) * 3 * (size_t)film->width * film->height, "reference comparison");
        if (!ob.scratch) { fprintf(stderr, "pmview: error: out of memory (%s)\n", pm_memory_failure_since(mark)); return 1; }
    }
    if (o->log && root) {
        ob.log = pm_log_to_stdout(o->log) ? stdout : fopen(o->log, "w");
        if (!ob.log) {
            snprintf(err, sizeof err, "%s: cannot write the log (%s)", o->log, strerror(errno));
            if (cluster) pm_cluster_abort(cluster, err); /* every rank ends, not rank 0 alone */
            fprintf(stderr, "pmview: error: %s\n", err);
            free(ob.scratch);
            return 1;
        }
        pm_log_header(ob.log);
    }
    /* --iterations is the whole image's: each rank renders its share */
    uint32_t total = (uint32_t)(o->iterations ? o->iterations : (o->time_limit > 0 ? 1000000000L : PM_DEFAULT_SNAPSHOT_ITERATIONS));
    pm_session_goal goal = {pm_cluster_share(cluster, total), o->time_limit};
    pm_session_run_state state = {0, 0, 0.0, 0.0, 0.0};
    ob.start = ob.last_checkpoint = pm_now_seconds();
    /* every rank's run ends at --time: one silent well past it is stopped (SIGSTOP), not slow */
    if (o->time_limit > 0) pm_cluster_expect_end(cluster, ob.start + o->time_limit, PM_CLUSTER_END_SECONDS + PM_CLUSTER_END_SHARE * o->time_limit);
    pm_session_run_result result = goal.samples ? pm_session_run(session, &goal, observe, &ob, &state) : PM_RUN_DONE;
    if (result == PM_RUN_FAILED) {
        if (cluster) {
            snprintf(err, sizeof err, "%s: %s", o->scene_path, pm_session_error(session));
            pm_cluster_abort(cluster, err);
        }
        fprintf(stderr, "%spmview: error: %s: %s\n", ob.tty ? "\n" : "", o->scene_path, pm_session_error(session));
        free(ob.scratch);
        if (ob.log && ob.log != stdout) fclose(ob.log);
        return 1;
    }
    if (cluster) {
        if (root && interrupted_by) pm_cluster_send_stop(cluster);
        film = pm_cluster_end_run(cluster, session, root ? tick : NULL, &ob);
        if (!root) {
            free(ob.scratch);
            return interrupted_by ? (interrupted_by == SIGINT ? 130 : 143) : 0;
        }
        if (!film) pm_cluster_abort(cluster, pm_cluster_error(cluster));
    }
    double seconds = pm_now_seconds() - ob.start;
    if (ob.log && (ob.logged != state.samples || (cluster && ob.logged_whole != film->samples)) && film->samples)
        pm_log_row(ob.log, session, film, whole_photons(&ob, state.photons), reference, ob.scratch, state.rendered);
    else if (ob.log && film->samples && state.rendered != ob.logged_rendered && ob.last_row_at > 0) {
        /* a pass cut by --time after the last row added samples to some pixels but no whole
         * iteration: the last row is written again for the image that is saved (iterations stay
         * distinct) */
        int fd = fileno(ob.log);
        if (fflush(ob.log) == 0 && fseek(ob.log, ob.last_row_at, SEEK_SET) == 0) {
            pm_log_row(ob.log, session, film, whole_photons(&ob, state.photons), reference, ob.scratch, state.rendered);
            long end = fflush(ob.log) == 0 ? ftell(ob.log) : -1;
            /* a pipe or device never gets here (no fseek); a file is cut after the new row */
            if (end > 0 && ftruncate(fd, end) != 0) fprintf(stderr, "pmview: warning: %s: the log's last row could not be rewritten\n", o->log);
        }
    }
    if (ob.log) {
        /* the flush reports why the buffered rows cannot be written (a full disk, EFBIG) */
        errno = 0;
        bool written = fflush(ob.log) == 0 && !ferror(ob.log);
        int why = errno;
        if (ob.log != stdout && fclose(ob.log) != 0 && written) { written = false; why = errno; }
        if (!written) {
            fprintf(stderr, "%spmview: error: %s: cannot write the log (%s)\n", ob.tty ? "\n" : "", o->log,
                    why ? strerror(why) : "write error");
            free(ob.scratch);
            return 1;
        }
    }
    if (ob.tty) fputc('\n', stderr);
    if (o->time_limit > 0 && state.first_iteration > o->time_limit && !interrupted_by && !o->quiet)
        fprintf(stderr, "pmview: note: --time %g s is shorter than the first iteration (%.2f s): a first pass over every pixel is always finished\n",
                o->time_limit, state.first_iteration);
    pm_exit_on_signals();
    /* the writers admit what they take themselves: the room kept for them since before the render is theirs now */
    pm_memory_release(*reserved);
    *reserved = 0;
    if (!write_snapshot(o, film, err, sizeof err)) { fprintf(stderr, "pmview: error: %s\n", err); free(ob.scratch); return 1; }
    if (!o->quiet) printf("pmview: wrote %s (%dx%d, %u iterations, %.2f s)%s\n", o->snapshot, film->width, film->height,
                          film->samples, seconds, interrupted_by ? ", interrupted: the image so far" : "");
    if (ob.scratch) {
        double ratio[3], e = pm_reference_relmse(film, reference, ob.scratch, ratio);
        printf("stat error iterations=%u seconds=%.4f relmse=%.6f mean_ratio_r=%.4f mean_ratio_g=%.4f mean_ratio_b=%.4f\n",
               film->samples, seconds, e, ratio[0], ratio[1], ratio[2]);
    }
    free(ob.scratch);
    if (interrupted_by) return interrupted_by == SIGINT ? 130 : 143;
    return 0;
}
