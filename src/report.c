/* report.c: the `stat STAGE key=value ...` lines of --stats for each stage of a run (an interface: keys are only ever added). */
#include <stdio.h>
#include <sys/resource.h>

#include "defaults.h"
#include "kdtree.h"
#include "memory.h"
#include "photonmap.h"
#include "progressive.h"
#include "report.h"

static long peak_rss_bytes(void) {
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss * 1024L;
}

void pm_print_load_stats(const pm_load_report *report, const pm_scene *scene) {
    printf("stat load seconds=%.4f triangles=%u vertices=%u materials=%u lights=%u emissive_triangles=%u textures=%u cameras=%u skipped_degenerate=%u skipped_primitives=%u ignored_inputs=%u unit_scale=%.9g recentered=%d occlusion_textures_ignored=%u\n",
           report->seconds, scene->triangle_count, scene->vertex_count, scene->material_count, scene->light_count,
           scene->emitter_count, scene->texture_count, scene->camera_count, report->skipped_degenerate,
           report->skipped_primitives, report->ignored_inputs, report->unit_scale, report->recentered,
           report->occlusion_textures_ignored);
    /* instancing: stored (unique) triangles against those the placements put in the world */
    printf("stat scene placements=%u instanced_meshes=%u unique_triangles=%u placed_triangles=%u\n", scene->placement_count,
           scene->instanced_mesh_count, scene->triangle_count, pm_scene_triangle_ids(scene));
}

void pm_print_bvh_stats(const pm_accel *accel) {
    printf("stat bvh seconds=%.4f bytes=%zu alpha_tested_triangles=%u\n", pm_accel_build_seconds(accel),
           pm_accel_bytes(accel), pm_accel_alpha_tested_triangles(accel));
}

void pm_print_analysis_stats(const pm_scene *s) {
    const pm_scene_analysis *a = &s->analysis;
    printf("stat analysis diffuse=%d mirror=%d glass=%d textures=%d emissive_triangles=%d punctual_lights=%d sky=%d caustics_possible=%d interreflection_possible=%d photons_needed=%d glossy=%d components=",
           a->has_diffuse, a->has_mirror, a->has_glass, a->has_textures, a->has_emissive_triangles,
           a->has_punctual_lights, a->has_sky, a->caustics_possible, a->interreflection_possible,
           a->component_possible[PM_CAUSTIC] || a->component_possible[PM_INDIRECT], a->has_glossy);
    bool first = true;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (a->component_possible[c]) { printf("%s%s", first ? "" : ",", pm_component_names[c]); first = false; }
    printf("%s non_opaque=%d thin_glass=%d unlit=%d near_specular=%d light_diffuse=%d light_peak_over_mean=%.4g\n", first ? "none" : "",
           a->has_non_opaque, a->has_thin_glass, a->has_unlit, a->has_near_specular, a->light_diffuse, a->light_peak_over_mean);
}

void pm_print_film_stats(const pm_film *film) {
    printf("stat film width=%d height=%d bytes=%zu buffers=", film->width, film->height, pm_film_bytes(film));
    bool first = true;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (film->sum[c]) { printf("%s%s", first ? "" : ",", pm_component_names[c]); first = false; }
    printf("%s\n", first ? "none" : "");
}

void pm_print_final_stats(pm_session *session, const pm_accel *accel, int threads, double alpha, bool pathtrace) {
    const pm_film *film = pm_session_film(session);
    pm_eye_stats eye_stats;
    pm_progressive *progressive = pm_session_progressive(session);
    if (progressive) {
        const pm_progressive_stats *ps = pm_progressive_get_stats(progressive);
        eye_stats = ps->eye;
        const pm_photon_stats *ph = &ps->photons;
        /* kdtree_seconds is the grid build too: stat keys are an interface, and scripts written
         * before grid_seconds named it read the grid's time under that key */
        printf("stat photons emitted=%llu caustic=%llu global=%llu rays=%llu seconds=%.4f trace_seconds=%.4f kdtree_seconds=%.4f grid_seconds=%.4f photons_per_second=%.0f bytes_per_photon=%zu projection_fraction=%.4f dropped=%llu\n",
               (unsigned long long)ph->emitted, (unsigned long long)ph->stored_caustic,
               (unsigned long long)ph->stored_global, (unsigned long long)ph->rays, ph->seconds, ph->trace_seconds,
               ps->grid_seconds, ps->grid_seconds, ph->trace_seconds > 0 ? ph->emitted / ph->trace_seconds : 0.0, sizeof(pm_photon),
               pm_progressive_projection_fraction(progressive), (unsigned long long)ph->dropped);
        pm_radius_summary r = pm_progressive_radii(progressive, film);
        double useful = ps->photons_stored ? (double)ps->photons_read / (double)ps->photons_stored : 0.0;
        printf("stat progressive iterations=%u photons_per_iteration=%llu alpha=%.4f radius_initial=%.6g radius_mean=%.6g radius_min=%.6g radius_max=%.6g gather_radius=%.6g gather_seconds=%.4f photons_found=%llu caustic_splats=%llu photon_passes=%u eye_passes_next=%u useful_share=%.4f useful_photons_per_second=%.0f clip_rays=%llu gather_source=%s choice_relmse_photons=%.6g choice_relmse_path=%.6g choice_bias2=%.6g choice_cost_photons=%.0f choice_cost_path=%.0f choice_iterations=%u photons_examined=%llu disc_queries=%llu choice_caustic_share=%.4g path_only_samples=%u caustic_trial=%d caustic_trial_error_photons=%.6g caustic_trial_error_path=%.6g caustic_trial_cost_photons=%.0f caustic_trial_cost_path=%.0f light_vertices=%llu connect_trial=%d connect_trial_error_on=%.6g connect_trial_error_off=%.6g connect_trial_cost_on=%.0f connect_trial_cost_off=%.0f sky_arrival_cells=%u\n",
               film->samples, (unsigned long long)pm_progressive_photons_per_iteration(progressive), alpha,
               r.initial_mean, r.mean, r.min, r.max, r.gather, ps->gather_seconds,
               (unsigned long long)ps->photons_found, (unsigned long long)ps->splats, film->photon_passes,
               pm_progressive_eye_passes(progressive), useful,
               ph->seconds > 0 ? (double)ps->photons_read / ph->seconds : 0.0, (unsigned long long)ps->clip_rays,
               ps->gather_source == PM_GATHER_PHOTONS ? "photons" : (ps->gather_source == PM_GATHER_PATH ? "path" : (ps->gather_source == -2 ? "learning" : "none")),
               ps->choice_relmse[PM_GATHER_PHOTONS], ps->choice_relmse[PM_GATHER_PATH], ps->choice_bias2,
               ps->choice_cost[PM_GATHER_PHOTONS], ps->choice_cost[PM_GATHER_PATH], ps->choice_iterations,
               (unsigned long long)ps->photons_examined, (unsigned long long)ps->disc_queries, ps->choice_caustic_share,
               ps->path_only_samples, ps->caustic_trial, ps->caustic_trial_error[0], ps->caustic_trial_error[1],
               ps->caustic_trial_cost[0], ps->caustic_trial_cost[1], (unsigned long long)ps->light_vertices, ps->connect_trial, ps->connect_trial_error[0], ps->connect_trial_error[1], ps->connect_trial_cost[0], ps->connect_trial_cost[1], ps->sky_arrival_cells);
    } else {
        eye_stats = *pm_session_eye_stats(session);
        const pm_photon_maps *maps = pm_session_classic_maps(session);
        const pm_photon_stats *pst = pm_session_classic_photon_stats(session);
        if (maps && (maps->global.count || maps->caustic.count || pst->emitted)) {
            printf("stat photons emitted=%llu caustic=%llu global=%llu rays=%llu seconds=%.4f trace_seconds=%.4f photons_per_second=%.0f bytes_per_photon=%zu projection_fraction=%.4f dropped=%llu\n",
                   (unsigned long long)pst->emitted, (unsigned long long)pst->stored_caustic,
                   (unsigned long long)pst->stored_global, (unsigned long long)pst->rays, pst->seconds, pst->trace_seconds,
                   pst->trace_seconds > 0 ? pst->emitted / pst->trace_seconds : 0.0, sizeof(pm_photon), maps->projection_fraction,
                   (unsigned long long)pst->dropped);
            printf("stat kdtree seconds=%.4f caustic_photons=%zu caustic_bytes=%zu global_photons=%zu global_bytes=%zu\n", pst->kdtree_seconds,
                   maps->caustic.count, pm_kdtree_bytes(&maps->caustic), maps->global.count, pm_kdtree_bytes(&maps->global));
            printf("stat irradiance seconds=%.4f points=%zu bytes=%zu\n", pst->irradiance_seconds, maps->irradiance.count,
                   pm_kdtree_bytes(&maps->irradiance));
        }
    }
    const pm_shadow_stats *sh = pm_session_shadow_stats(session);
    printf("stat shadow_photons built=%d reason=%s lights=%u photons=%llu records=%llu rays=%llu cells=%zu bytes=%zu cell_size=%.6g spacing=%.6g seconds=%.4f probe_decided=%.3f probe_lookup_ns=%.1f probe_ray_ns=%.1f probe_needed=%.3f\n",
           sh->built, sh->built ? "none" : (sh->reason ? sh->reason : "not_reached"), sh->lights,
           (unsigned long long)sh->photons, (unsigned long long)sh->records, (unsigned long long)sh->rays, sh->cells,
           sh->bytes, sh->cell_size, sh->spacing, sh->seconds, sh->probe_decided, sh->probe_lookup_ns, sh->probe_ray_ns,
           PM_SHADOW_MIN_GAIN * PM_SHADOW_LOOKUP_OVER_RAY);
    if (pathtrace) {
        double paths = (double)film->samples * film->width * film->height;
        printf("stat pathtrace iterations=%u paths=%.0f rays=%llu seconds=%.4f rays_per_second=%.0f paths_per_second=%.0f mean_path_vertices=%.4f roulette_vertex=%d max_survival=%.2f\n",
               film->samples, paths, (unsigned long long)eye_stats.rays, eye_stats.seconds,
               eye_stats.seconds > 0 ? eye_stats.rays / eye_stats.seconds : 0.0, eye_stats.seconds > 0 ? paths / eye_stats.seconds : 0.0,
               paths > 0 ? eye_stats.path_vertices / paths : 0.0, PM_EYE_ROULETTE_VERTEX, PM_MAX_SURVIVAL);
    }
    printf("stat eye iterations=%u rays=%llu seconds=%.4f rays_per_second=%.0f threads=%d dropped_samples=%llu shadow_rays=%llu shadow_rays_saved=%llu pixels_ahead=%zu connections=%llu sky_arrival_samples=%llu\n",
           film->samples, (unsigned long long)eye_stats.rays, eye_stats.seconds,
           eye_stats.seconds > 0 ? eye_stats.rays / eye_stats.seconds : 0.0, threads,
           (unsigned long long)eye_stats.dropped_samples, (unsigned long long)eye_stats.shadow_rays,
           (unsigned long long)eye_stats.shadow_rays_saved, pm_film_pixels_ahead(film), (unsigned long long)eye_stats.connections,
           (unsigned long long)eye_stats.sky_arrival_samples);
    long peak = peak_rss_bytes();
    uint64_t estimate = pm_memory_forecast();
    printf("stat memory peak_rss_bytes=%ld film_bytes=%zu bvh_bytes=%zu limit_bytes=%llu checked_allocations=%llu "
           "estimate_bytes=%llu baseline_bytes=%llu peak_over_estimate=%.3f\n",
           peak, pm_film_bytes(film), pm_accel_bytes(accel), (unsigned long long)pm_memory_limit(),
           (unsigned long long)pm_memory_allocations(), (unsigned long long)estimate,
           (unsigned long long)pm_memory_forecast_baseline(), estimate ? (double)peak / (double)estimate : 0.0);
}

void pm_print_cluster_stats(const pm_cluster *cluster) {
    pm_cluster_totals t = pm_cluster_get_totals(cluster);
    int ranks = pm_cluster_size(cluster);
    /* every rank but 0 sends its form to each merge: what the job's merges moved in all */
    unsigned long long merged = (unsigned long long)t.merges * t.bytes_per_merge * (unsigned long long)(ranks - 1);
    printf("stat cluster ranks=%d merges=%llu bytes_per_merge=%llu bytes_sent=%llu bytes_merged=%llu bytes_per_second=%.0f "
           "photons_total=%llu\n",
           ranks, (unsigned long long)t.merges, (unsigned long long)t.bytes_per_merge, (unsigned long long)t.bytes_sent, merged,
           t.seconds_joined > 0 ? (double)(merged + t.bytes_sent) / t.seconds_joined : 0.0, (unsigned long long)t.photons);
}
