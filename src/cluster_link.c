/* cluster_link.c: pmview's side of the MPI module: pm_cluster_join opens pmview-cluster.so (src/cluster.c) only when an MPI launcher started the process, and every pm_cluster_* call with a cluster goes to it; without one they are a single process's no-ops. */
#include "cluster_module.h"

#include <dlfcn.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* set once, by pm_cluster_join on the main thread before any other thread exists */
static const pm_cluster_module *module;

/* The module from the executable's folder: NULL with why set when it cannot be opened. */
static const pm_cluster_module *open_module(char *why, size_t why_size) {
    char path[PATH_MAX + sizeof PM_CLUSTER_MODULE_FILE];
    ssize_t n = readlink("/proc/self/exe", path, PATH_MAX);
    if (n <= 0 || n >= PATH_MAX) {
        snprintf(why, why_size, "the executable's folder is unknown (/proc/self/exe)");
        return NULL;
    }
    path[n] = '\0';
    char *slash = strrchr(path, '/');
    snprintf(slash ? slash + 1 : path, sizeof path - (size_t)(slash ? slash + 1 - path : 0), "%s", PM_CLUSTER_MODULE_FILE);
    /* global: Open MPI's own components, which it opens in turn, take libmpi's symbols from there */
    void *lib = dlopen(path, RTLD_NOW | RTLD_GLOBAL);
    if (!lib) {
        const char *error = dlerror();
        snprintf(why, why_size, "%.900s", error ? error : path);
        return NULL;
    }
    const pm_cluster_module *(*entry)(void);
    void *found = dlsym(lib, PM_CLUSTER_MODULE_ENTRY);
    if (!found) {
        snprintf(why, why_size, "%.900s has no %s", path, PM_CLUSTER_MODULE_ENTRY);
        return NULL;
    }
    memcpy(&entry, &found, sizeof entry); /* (a data pointer to a function pointer: dlsym's documented use) */
    return entry();
}

pm_cluster *pm_cluster_join(int *argc, char ***argv) {
    /* the launchers' marks (Open MPI's mpirun sets OMPI_COMM_WORLD_SIZE; PMI and PMIx launchers
     * PMI_SIZE or PMIX_RANK); cluster.c's join checks the same */
    if (!getenv("OMPI_COMM_WORLD_SIZE") && !getenv("PMI_SIZE") && !getenv("PMIX_RANK")) return NULL;
    char why[1024];
    module = open_module(why, sizeof why);
    if (!module) {
        fprintf(stderr, "pmview: error: started by an MPI launcher, but the MPI module cannot be loaded: %s\n", why);
        exit(1);
    }
    return module->join(argc, argv);
}

void pm_cluster_leave(pm_cluster *c) { if (c) module->leave(c); }
int pm_cluster_rank(const pm_cluster *c) { return c ? module->rank(c) : 0; }
int pm_cluster_size(const pm_cluster *c) { return c ? module->size(c) : 1; }
int pm_cluster_agree(pm_cluster *c, int code, uint64_t digest) { return c ? module->agree(c, code, digest) : code; }
bool pm_cluster_prepare(pm_cluster *c, const pm_film *film) { return c ? module->prepare(c, film) : true; }
void pm_cluster_abort(pm_cluster *c, const char *message) { module->abort(c, message); }
uint64_t pm_cluster_seed(const pm_cluster *c, uint64_t seed) { return c ? module->seed(c, seed) : seed; }
uint32_t pm_cluster_share(const pm_cluster *c, uint32_t total) { return c ? module->share(c, total) : total; }
pm_cluster_totals pm_cluster_get_totals(const pm_cluster *c) {
    pm_cluster_totals none = {0};
    return c ? module->get_totals(c) : none;
}
void pm_cluster_watch(pm_cluster *c, volatile sig_atomic_t *interrupted) { if (c) module->watch(c, interrupted); }
const pm_film *pm_cluster_merge_now(pm_cluster *c, pm_session *s) { return module->merge_now(c, s); }
void pm_cluster_serve(pm_cluster *c, pm_session *s) { if (c) module->serve(c, s); }
void pm_cluster_send_stop(pm_cluster *c) { if (c) module->send_stop(c); }
const pm_film *pm_cluster_end_run(pm_cluster *c, pm_session *s, void (*tick)(void *context), void *context) {
    return module->end_run(c, s, tick, context);
}
void pm_cluster_expect_end(pm_cluster *c, double deadline, double patience) { if (c) module->expect_end(c, deadline, patience); }
const char *pm_cluster_error(const pm_cluster *c) { return c ? module->error(c) : ""; }
void pm_cluster_send_restart(pm_cluster *c, const pm_camera *camera, int indirect) { if (c) module->send_restart(c, camera, indirect); }
void pm_cluster_send_pause(pm_cluster *c, bool paused) { if (c) module->send_pause(c, paused); }
void pm_cluster_send_resize(pm_cluster *c, int width, int height, const pm_camera *camera) {
    if (c) module->send_resize(c, width, height, camera);
}
void pm_cluster_send_quit(pm_cluster *c) { if (c) module->send_quit(c); }
const pm_film *pm_cluster_poll_merge(pm_cluster *c, pm_session *s) { return c ? module->poll_merge(c, s) : NULL; }
int pm_cluster_follow(pm_cluster *c, pm_session *s) { return module->follow(c, s); }
