/* cluster_module.h: the MPI module's table of functions, what src/cluster.c (built alone as pmview-cluster.so, opened only under an MPI launcher) gives the rest of pmview (src/cluster_link.c).
 *
 * pmview itself never links Open MPI: loading libmpi and the libraries it brings cost every start
 * of a single process, which never calls it. Under mpirun, pm_cluster_join opens the module found
 * next to the executable and calls its one exported function for this table; every pm_cluster_*
 * call with a cluster then goes through it. The module takes pmview's own functions (the film, the
 * session, the memory accounting) from the executable, which exports its pm_* symbols for it.
 */
#ifndef PM_CLUSTER_MODULE_H
#define PM_CLUSTER_MODULE_H

#include "cluster.h"

/* the module's file, in the executable's folder */
#define PM_CLUSTER_MODULE_FILE "pmview-cluster.so"
/* the name of its one exported function, which returns the table */
#define PM_CLUSTER_MODULE_ENTRY "pm_cluster_module_functions"

typedef struct {
    pm_cluster *(*join)(int *argc, char ***argv);
    void (*leave)(pm_cluster *c);
    int (*rank)(const pm_cluster *c);
    int (*size)(const pm_cluster *c);
    int (*agree)(pm_cluster *c, int code, uint64_t digest);
    bool (*prepare)(pm_cluster *c, const pm_film *film);
    void (*abort)(pm_cluster *c, const char *message);
    uint64_t (*seed)(const pm_cluster *c, uint64_t seed);
    uint32_t (*share)(const pm_cluster *c, uint32_t total);
    pm_cluster_totals (*get_totals)(const pm_cluster *c);
    void (*watch)(pm_cluster *c, volatile sig_atomic_t *interrupted);
    const pm_film *(*merge_now)(pm_cluster *c, pm_session *s);
    void (*serve)(pm_cluster *c, pm_session *s);
    void (*send_stop)(pm_cluster *c);
    const pm_film *(*end_run)(pm_cluster *c, pm_session *s, void (*tick)(void *context), void *context);
    void (*expect_end)(pm_cluster *c, double deadline, double patience);
    const char *(*error)(const pm_cluster *c);
    void (*send_restart)(pm_cluster *c, const pm_camera *camera, int indirect);
    void (*send_pause)(pm_cluster *c, bool paused);
    void (*send_resize)(pm_cluster *c, int width, int height, const pm_camera *camera);
    void (*send_quit)(pm_cluster *c);
    const pm_film *(*poll_merge)(pm_cluster *c, pm_session *s);
    int (*follow)(pm_cluster *c, pm_session *s);
} pm_cluster_module;

/* The module's table (defined in src/cluster.c, exported by the module alone). */
const pm_cluster_module *pm_cluster_module_functions(void);

#endif
