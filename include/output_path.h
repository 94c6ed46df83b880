/* output_path.h: the output rules the writers share (output_path.c): a file written beside its target and renamed over it, the partial file a signal removes, the hurry flag. */
#ifndef PM_OUTPUT_PATH_H
#define PM_OUTPUT_PATH_H

#include <stdbool.h>
#include <stddef.h>

#define PM_OUTPUT_PATH_MAX 4096

/* An output under way. Its bytes go to an unnamed file in the target's folder (O_TMPFILE), which
 * a kill at any moment (mpirun's SIGKILL) takes with it; it is named only once whole, by a link
 * to a hidden name renamed at once over the target. Where the folder's file system has no unnamed
 * files, a hidden named file from the start (a signal handler removes it; SIGKILL cannot). */
typedef struct {
    int fd;
    bool named;   /* temp names the file on disk */
    bool claimed; /* temp is partial_path, which the signal handler removes */
    char *temp;
    char own[PM_OUTPUT_PATH_MAX];
} pm_pending_output;

/* Starts an output for path (err says why not). */
bool pm_output_open(const char *path, pm_pending_output *o, char *err, size_t err_size);
/* The whole file becomes path (ok), or goes; either way the output ends. */
bool pm_output_finish(const char *path, pm_pending_output *o, bool ok, char *err, size_t err_size);
/* An in-place write's file registered for the signal handler; false: not registered. */
bool pm_output_claim_in_place(const char *path);
/* Gives back a claim (pm_output_claim_in_place's true, or an output's): the handler removes nothing now. */
void pm_output_release(bool claimed);
/* Whether the signal's flag (pm_output_watch) is set: write uncompressed. */
bool pm_output_hurried(void);
/* Whether an existing file opens for writing (nothing is truncated); else err says why. */
bool pm_file_takes_writing(const char *path, char *err, size_t err_size);
/* The same for a file that may not exist (true when it does not). */
bool pm_file_takes_writing_if_present(const char *path, char *err, size_t err_size);
/* err = "PATH: what", on one line whatever the library said. */
void pm_io_error(char *err, size_t err_size, const char *path, const char *what);

#endif
