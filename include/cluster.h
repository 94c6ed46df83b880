/* cluster.h: one render over many processes (MPI, the only module that calls it): every rank renders iterations of its own, seeded apart, and the films' additive forms are summed on rank 0.
 *
 * The split (docs/design.md, "One render over many processes"): a rank is a whole pmview, scene,
 * BVH and session, rendering its own iterations with its own seed; nothing passes between ranks
 * while they render. When rank 0 needs the whole image (a --log row, a checkpoint, the window's
 * next frame, the end) it asks for a merge: each rank answers between two of its iterations with
 * its film's additive form (pm_film_pack), summed onto rank 0 by one MPI reduction, and rank 0
 * unpacks the sum into a film of its own that everything downstream reads as it reads a session's
 * film. A merge waits for at most one iteration of each rank; the bytes it moves depend on the
 * image, not on how many iterations were rendered.
 *
 * Without an MPI launcher (pm_cluster_join returns NULL) nothing here touches MPI, and every
 * function taking a NULL cluster is a single process's no-op.
 */
#ifndef PM_CLUSTER_H
#define PM_CLUSTER_H

#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include "camera.h"
#include "film.h"
#include "session.h"

typedef struct pm_cluster pm_cluster;

/* Joins the job when an MPI launcher started pmview (Open MPI's mpirun sets OMPI_COMM_WORLD_SIZE;
 * PMI and PMIx launchers PMI_SIZE or PMIX_RANK): NULL otherwise. On ranks other than 0, stdout is
 * dropped and stderr kept aside: rank 0 alone speaks (pm_cluster_agree, pm_cluster_end_run). */
pm_cluster *pm_cluster_join(int *argc, char ***argv);
/* Ends MPI and frees the cluster (NULL: nothing). */
void pm_cluster_leave(pm_cluster *c);
int pm_cluster_rank(const pm_cluster *c); /* 0 without a cluster */
int pm_cluster_size(const pm_cluster *c); /* 1 without a cluster */

/* Every rank at the same point with its own outcome (-1: going on, else its exit code): -1 when
 * every rank goes on, else the first failing rank's code on every rank, and rank 0 prints that
 * rank's error line once ("rank K: " in it when K is not 0). When every rank goes on, their
 * digests (the scene's and the options', pm_scene_digest) must be rank 0's, else 1 on every rank
 * and one line naming the first rank that differs. Also a barrier: time budgets count from here. */
int pm_cluster_agree(pm_cluster *c, int code, uint64_t digest);
/* In the set-up, once the session's film exists: the merge's buffers (every rank's send buffer,
 * rank 0's receive buffer and merged film) admitted against --max-memory and made, so a job that
 * could not merge fails before it renders. False with pm_cluster_error set; true without a cluster. */
bool pm_cluster_prepare(pm_cluster *c, const pm_film *film);
/* A failure after the set-up (out of memory, a command rank 0's image does not fit): one line,
 * rank 0's or "pmview: rank K: error: ...", then every rank ends (MPI_Abort). */
void pm_cluster_abort(pm_cluster *c, const char *message);
/* The seed a rank renders with: `seed` itself on rank 0 (one process's image), mixed apart on the others. */
uint64_t pm_cluster_seed(const pm_cluster *c, uint64_t seed);
/* This rank's share of `total` samples (--iterations): split evenly, the first ranks one more. */
uint32_t pm_cluster_share(const pm_cluster *c, uint32_t total);

/* The job's totals at the last merge (rank 0). */
typedef struct {
    uint64_t photons;          /* emitted by every rank since the last restart */
    uint64_t merges;
    uint64_t bytes_sent;       /* what this rank sent to merges and commands */
    uint64_t bytes_per_merge;  /* what each rank sends to one merge */
    double seconds_joined;     /* wall seconds since the job's set-up was agreed */
} pm_cluster_totals;
pm_cluster_totals pm_cluster_get_totals(const pm_cluster *c);

/* ---- snapshots: every rank runs its share (pm_session_run) on its own ---- */
/* The flag a signal handler sets: once it is set, rank 0 waits for a silent rank at most
 * PM_CLUSTER_SILENCE_SECONDS, then ends the job with a line naming it (a rank that died). */
void pm_cluster_watch(pm_cluster *c, volatile sig_atomic_t *interrupted);
/* Rank 0, between its iterations: every rank's film summed into rank 0's merged film, returned
 * (NULL when out of memory, with pm_cluster_error set). Waits for each rank's running iteration; a
 * rank silent after a signal (pm_cluster_watch) or past --time (pm_cluster_expect_end) ends the job. */
const pm_film *pm_cluster_merge_now(pm_cluster *c, pm_session *s);
/* Ranks other than 0, between their iterations: answers rank 0's merges, never waiting, and ends
 * the run (pm_session_cancel) when rank 0 asks it to (pm_cluster_send_stop). */
void pm_cluster_serve(pm_cluster *c, pm_session *s);
/* Rank 0, its run ended by a signal: asks every rank to end its run too, so that a signal to rank 0
 * alone (kill on its pid, not mpirun's to every rank) still merges and writes the image so far. */
void pm_cluster_send_stop(pm_cluster *c);
/* After a rank's run that did not fail (a failure ends the job: pm_cluster_abort). Ranks other
 * than 0 tell rank 0, answer its merges until the last one, and return NULL. Rank 0 waits for
 * every rank, calling tick(context) every few milliseconds meanwhile (checkpoints), then merges a
 * last time and returns the film. A rank silent after a signal (pm_cluster_watch) or past --time
 * (pm_cluster_expect_end) ends the job. */
const pm_film *pm_cluster_end_run(pm_cluster *c, pm_session *s, void (*tick)(void *context), void *context);
/* Before a run with --time, whose iterations end by `deadline` (pm_now_seconds) on every rank:
 * rank 0 waits for another rank's word (a merge's image, the run's end) until the later of the
 * deadline and the wait's start plus `patience`, then ends the job naming the silent ones (a
 * stopped rank, which no signal reveals). Patience 0, the default: as long as they take
 * (--iterations, whose shares differ in speed). */
void pm_cluster_expect_end(pm_cluster *c, double deadline, double patience);
/* Why the last call above failed, naming the rank. */
const char *pm_cluster_error(const pm_cluster *c);

/* ---- the window: rank 0 draws, every rank renders in its session's worker ---- */
/* Rank 0 asks every other rank for what it asks of its own session. A resize and the quit first
 * end the merge under way (pm_cluster_poll_merge), the quit then waits for every rank's word: a
 * rank silent there for PM_CLUSTER_QUIT_SECONDS ends the job with a line naming it. */
void pm_cluster_send_restart(pm_cluster *c, const pm_camera *camera, int indirect);
void pm_cluster_send_pause(pm_cluster *c, bool paused);
void pm_cluster_send_resize(pm_cluster *c, int width, int height, const pm_camera *camera);
void pm_cluster_send_quit(pm_cluster *c);
/* Rank 0, every frame: starts a merge of the sessions' published forms when none is under way, the
 * last started PM_CLUSTER_MERGE_SECONDS ago and rank 0's own session has published one since the
 * last restart (its size and layout are the merge's; a rank without one of them adds zeros);
 * returns the merged film when one has completed since the last call and no restart came after it
 * began, else NULL. Never waits for a rank. */
const pm_film *pm_cluster_poll_merge(pm_cluster *c, pm_session *s);
/* Ranks other than 0: applies rank 0's commands to the session (whose worker renders) and answers
 * its merges until it quits; returns the exit code. */
int pm_cluster_follow(pm_cluster *c, pm_session *s);

#endif
