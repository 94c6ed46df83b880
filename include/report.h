/* report.h: the `stat STAGE key=value ...` lines of --stats for each stage of a run (an interface: keys are only ever added). */
#ifndef PM_REPORT_H
#define PM_REPORT_H

#include <stdbool.h>
#include "accel.h"
#include "cluster.h"
#include "film.h"
#include "loader.h"
#include "scene.h"
#include "session.h"

void pm_print_load_stats(const pm_load_report *report, const pm_scene *scene);
void pm_print_bvh_stats(const pm_accel *accel);
void pm_print_analysis_stats(const pm_scene *s);
void pm_print_film_stats(const pm_film *film);
/* After the run: photons, progressive or classic maps, shadow photons, path tracing, eye pass and
 * memory. threads and alpha as the run was configured; pathtrace: --mode pathtrace. */
void pm_print_final_stats(pm_session *session, const pm_accel *accel, int threads, double alpha, bool pathtrace);
/* Under mpirun (rank 0): the rank count, the merges, the bytes each sent, the job's photons; a single process prints ranks=1. */
void pm_print_cluster_stats(const pm_cluster *cluster);

#endif
