/* output_path.c: where outputs go: paths checked before a render, a file written beside its target and renamed over it, the partial file a signal removes, the hurry flag, same-file and extension tests. */
/* realpath is XSI and O_TMPFILE and linkat Linux's, beyond the POSIX level the build asks for */
#define _GNU_SOURCE
#include "image_io.h"
#include "output_path.h"

#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* Messages go to a terminal or a log line: keep them to one line whatever the library said. */
static void one_line(char *err) {
    for (char *p = err; *p; p++)
        if (*p == '\n' || *p == '\r') *p = ' ';
}

void pm_io_error(char *err, size_t err_size, const char *path, const char *what) {
    if (!err || err_size == 0) return;
    snprintf(err, err_size, "%s: %s", path ? path : "(null)", what);
    one_line(err);
}

/* The file being written, for pm_remove_partial_output() from a signal handler: one writer at a
 * time holds the claim (another writes unregistered). The name lives here, and mkstemp fills it in
 * place after it is armed, so the file never exists under a name the handler cannot see. */
static char partial_path[PM_OUTPUT_PATH_MAX];
static volatile sig_atomic_t partial_armed;
static atomic_flag partial_claimed = ATOMIC_FLAG_INIT;

void pm_remove_partial_output(void) {
    if (partial_armed) unlink(partial_path); /* async-signal-safe: a flag read and unlink */
}

void pm_output_release(bool claimed) {
    if (!claimed) return;
    partial_armed = 0;
    atomic_flag_clear(&partial_claimed);
}

/* An in-place write's own file as the partial output a signal removes: false when another writer
 * holds the claim or the name does not fit (the file is then written unregistered). */
bool pm_output_claim_in_place(const char *path) {
    if (strlen(path) >= sizeof partial_path || atomic_flag_test_and_set(&partial_claimed)) return false;
    memcpy(partial_path, path, strlen(path) + 1);
    atomic_thread_fence(memory_order_seq_cst);
    partial_armed = 1;
    return true;
}

/* The folder part of path ("." for a bare name) into out. */
static void folder_of(const char *path, char *out, size_t size) {
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(out, size, ".");
    else if (slash == path) snprintf(out, size, "/");
    else snprintf(out, size, "%.*s", (int)(slash - path), path);
}

/* Creates an empty, uniquely named hidden file in path's folder: ".NAME.XXXXXX"; *armed (when
 * given) is set once temp holds the whole template, before the file can exist. */
static bool temporary_beside(const char *path, char *temp, size_t size, volatile sig_atomic_t *armed, char *err,
                             size_t err_size) {
    char folder[4096];
    folder_of(path, folder, sizeof folder);
    const char *slash = strrchr(path, '/');
    int n = snprintf(temp, size, "%s/.%s.XXXXXX", folder, slash ? slash + 1 : path);
    if (n < 0 || (size_t)n >= size) {
        temp[0] = '\0';
        pm_io_error(err, err_size, path, "the file name is too long");
        return false;
    }
    atomic_thread_fence(memory_order_seq_cst); /* the whole name is in place before the flag says so */
    if (armed) *armed = 1;
    int fd = mkstemp(temp);
    if (fd < 0) {
        char what[4200];
        snprintf(what, sizeof what, "cannot create a file in the folder %s (%s)", folder, strerror(errno));
        if (armed) *armed = 0;
        temp[0] = '\0';
        pm_io_error(err, err_size, path, what);
        return false;
    }
    /* mkstemp makes it private (0600); the file it becomes gets the usual permissions */
    mode_t mask = umask(0);
    umask(mask);
    fchmod(fd, 0666 & ~mask);
    close(fd);
    return true;
}

/* A signal's flag (pm_output_watch): once it is set, an EXR is written uncompressed, which takes a
 * fraction of the time (mpirun's SIGKILL follows its SIGTERM by 1 s), and a compressed write
 * under way when it comes starts again so. */
static volatile sig_atomic_t *hurry_flag;

void pm_output_watch(volatile sig_atomic_t *flag) { hurry_flag = flag; }

bool pm_output_hurried(void) { return hurry_flag && *hurry_flag; }

bool pm_output_open(const char *path, pm_pending_output *o, char *err, size_t err_size) {
    o->fd = -1;
    o->named = false;
    o->claimed = !atomic_flag_test_and_set(&partial_claimed);
    o->temp = o->claimed ? partial_path : o->own;
    o->temp[0] = '\0';
#ifdef O_TMPFILE
    char folder[4096];
    folder_of(path, folder, sizeof folder);
    o->fd = open(folder, O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666); /* the umask applies as for any new file */
    if (o->fd >= 0) return true;
#endif
    if (!temporary_beside(path, o->temp, sizeof partial_path, o->claimed ? &partial_armed : NULL, err, err_size)) {
        pm_output_release(o->claimed);
        return false;
    }
    o->named = true;
    o->fd = open(o->temp, O_WRONLY | O_CLOEXEC);
    if (o->fd < 0) {
        char what[320];
        snprintf(what, sizeof what, "cannot open the temporary file (%s)", strerror(errno));
        pm_io_error(err, err_size, path, what);
        unlink(o->temp);
        pm_output_release(o->claimed);
        return false;
    }
    return true;
}

/* Gives the unnamed file a hidden name beside path (".NAME.XXXXXX"), armed for the handler first. */
static bool pending_name(const char *path, pm_pending_output *o, char *err, size_t err_size) {
    char folder[4096], proc[64];
    folder_of(path, folder, sizeof folder);
    const char *slash = strrchr(path, '/');
    snprintf(proc, sizeof proc, "/proc/self/fd/%d", o->fd);
    static const char letters[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
    uint64_t seed = (uint64_t)getpid() * 0x9e3779b97f4a7c15ull ^ (uint64_t)(uintptr_t)o;
    struct timespec t;
    clock_gettime(CLOCK_REALTIME, &t);
    seed ^= (uint64_t)t.tv_nsec << 20 ^ (uint64_t)t.tv_sec;
    for (int attempt = 0; attempt < 64; attempt++) {
        char suffix[7];
        for (int k = 0; k < 6; k++) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            suffix[k] = letters[(seed >> 33) % (sizeof letters - 1)];
        }
        suffix[6] = '\0';
        int n = snprintf(o->temp, sizeof partial_path, "%s/.%s.%s", folder, slash ? slash + 1 : path, suffix);
        if (n < 0 || (size_t)n >= sizeof partial_path) {
            o->temp[0] = '\0';
            pm_io_error(err, err_size, path, "the file name is too long");
            return false;
        }
        atomic_thread_fence(memory_order_seq_cst); /* the whole name is in place before the flag says so */
        if (o->claimed) partial_armed = 1;
        if (linkat(AT_FDCWD, proc, AT_FDCWD, o->temp, AT_SYMLINK_FOLLOW) == 0) {
            o->named = true;
            return true;
        }
        int why = errno;
        if (o->claimed) partial_armed = 0;
        if (why != EEXIST) {
            char what[4400];
            snprintf(what, sizeof what, "cannot name the file written in the folder %s (%s)", folder, strerror(why));
            o->temp[0] = '\0';
            pm_io_error(err, err_size, path, what);
            return false;
        }
    }
    o->temp[0] = '\0';
    pm_io_error(err, err_size, path, "cannot find a free temporary name beside it");
    return false;
}

/* The whole file becomes path (ok), or goes; either way the output ends. */
bool pm_output_finish(const char *path, pm_pending_output *o, bool ok, char *err, size_t err_size) {
    if (ok && !o->named) ok = pending_name(path, o, err, err_size);
    if (ok && rename(o->temp, path) != 0) {
        char what[320];
        snprintf(what, sizeof what, "cannot replace the file (%s)", strerror(errno));
        pm_io_error(err, err_size, path, what);
        ok = false;
    }
    if (!ok && o->named) unlink(o->temp);
    if (o->fd >= 0) close(o->fd);
    o->fd = -1;
    pm_output_release(o->claimed);
    return ok;
}

/* Whether an existing file opens for writing (nothing is truncated); else err says why. */
bool pm_file_takes_writing(const char *path, char *err, size_t err_size) {
    int fd = open(path, O_WRONLY | O_NOCTTY | O_NONBLOCK);
    if (fd < 0) {
        char what[320];
        snprintf(what, sizeof what, "cannot write the file (%s)", strerror(errno));
        pm_io_error(err, err_size, path, what);
        return false;
    }
    close(fd);
    return true;
}

/* An existing file replaced by a rename must be one its owner lets us write. */
bool pm_file_takes_writing_if_present(const char *path, char *err, size_t err_size) {
    struct stat st;
    return !(stat(path, &st) == 0 && S_ISREG(st.st_mode)) || pm_file_takes_writing(path, err, err_size);
}

bool pm_check_output_path(const char *path, char *err, size_t err_size) {
    if (!path || !*path) { pm_io_error(err, err_size, path ? path : "", "no output file name given"); return false; }
    char what[4200];
    struct stat st;
    bool exists = stat(path, &st) == 0;
    if (!exists && errno != ENOENT) {
        snprintf(what, sizeof what, "cannot write there (%s)", strerror(errno));
        pm_io_error(err, err_size, path, what);
        return false;
    }
    if (exists && S_ISDIR(st.st_mode)) { pm_io_error(err, err_size, path, "is a directory, not a file name"); return false; }
    bool exr = pm_has_extension(path, ".exr");
    if (exists && exr && !S_ISREG(st.st_mode)) {
        pm_io_error(err, err_size, path, "is not a regular file (an EXR is written beside it and renamed over it)");
        return false;
    }
    /* A file is written beside a regular file and renamed over it, which the folder alone allows:
     * the same test keeps it from replacing a file its owner made read-only. A PNG onto anything
     * else (a device, a pipe) is written in place. */
    if (exists && !pm_file_takes_writing(path, err, err_size)) return false;
    if (exists && !exr && !S_ISREG(st.st_mode)) return true;
    /* a new file (or the one written beside it) must be creatable in the folder: try it */
    char temp[4096];
    if (!temporary_beside(path, temp, sizeof temp, NULL, err, err_size)) return false;
    unlink(temp);
    return true;
}

/* path with its folder resolved (the name kept: it need not exist yet) into out; false when the
 * folder cannot be resolved. */
static bool resolved(const char *path, char *out, size_t size) {
    char folder[4096], real[PATH_MAX];
    folder_of(path, folder, sizeof folder);
    if (!realpath(folder, real)) return false;
    const char *slash = strrchr(path, '/'), *name = slash ? slash + 1 : path;
    int n = snprintf(out, size, "%s/%s", strcmp(real, "/") ? real : "", name);
    return n >= 0 && (size_t)n < size;
}

bool pm_same_file(const char *a, const char *b) {
    if (!a || !b) return false;
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char ra[4200], rb[4200];
    if (resolved(a, ra, sizeof ra) && resolved(b, rb, sizeof rb)) return strcmp(ra, rb) == 0;
    return strcmp(a, b) == 0;
}

bool pm_has_extension(const char *path, const char *ext) {
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}
