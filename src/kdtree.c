/* kdtree.c: the photon kd-tree of kdtree.h: parallel deterministic median-split build, k-nearest and fixed-radius queries.
 *
 * Layout: implicit median split in place (the equivalent of Jensen's left-balanced heap, with
 * the same height). A subtree owns the contiguous range [lo, hi) of t->photons; its root is the
 * photon at mid = lo + (hi - lo) / 2, its left subtree is [lo, mid) and its right [mid + 1, hi).
 * Both children hold at most half of the range, so the height is floor(log2 n) + 1 whatever
 * the photon distribution, and a query is O(log n) plus the photons it must look at. Because
 * subtrees are contiguous, the last levels of a query stay in a few cache lines, and disjoint
 * subtrees can be built by different threads without sharing anything.
 *
 * Build: each node takes the axis of the largest extent of its photons' bounding box (ties go
 * to the lower axis) and puts the median on that axis at mid by quickselect (median-of-three
 * Hoare partitioning, heapsort fallback if a range refuses to shrink), so every level costs O(n)
 * and the build O(n log n). The top levels are split level by level, each level's nodes in
 * parallel; then the remaining subtrees are built as parallel tasks. Every node is produced by
 * the same function from the same input range, so the tree is byte-identical for any number of
 * threads. axis[i] is 3 for single-photon subtrees.
 *
 * Queries walk the tree iteratively with a fixed stack (one entry per level is enough), near
 * child first, skipping a far child whose splitting plane is beyond the current search radius.
 * Small subtrees are scanned linearly: cheaper than descending them node by node. The k-nearest
 * search keeps a max-heap of its candidates in the caller's arrays; once k are found the search
 * radius is the heap top, and only strictly closer photons can enter.
 */
#include "kdtree.h"
#include "memory.h"

#include <stdlib.h>
#include <string.h>

#include "parallel.h"

enum {
    LEAF_AXIS = 3,
    STACK_DEPTH = 64,          /* the height never exceeds the bit width of size_t */
    SCAN_RANGE = 6,            /* subtrees this small are scanned, not descended */
    SELECT_INSERTION_SIZE = 12,
    MAX_PARALLEL_SUBTREES = 256,
    MIN_PARALLEL_SUBTREE = 4096 /* below this, a task costs more to hand out than to run */
};

static inline float photon_key(const pm_photon *ph, int axis) { return ph->pos[axis]; }

static inline void swap_photons(pm_photon *a, pm_photon *b) {
    pm_photon tmp = *a;
    *a = *b;
    *b = tmp;
}

static int widest_axis(const pm_photon *ph, size_t n) {
    float lo[3], hi[3];
    for (int a = 0; a < 3; a++) lo[a] = hi[a] = ph[0].pos[a];
    for (size_t i = 1; i < n; i++) {
        for (int a = 0; a < 3; a++) {
            float v = ph[i].pos[a];
            lo[a] = v < lo[a] ? v : lo[a];
            hi[a] = v > hi[a] ? v : hi[a];
        }
    }
    float ex = hi[0] - lo[0], ey = hi[1] - lo[1], ez = hi[2] - lo[2];
    if (ex >= ey && ex >= ez) return 0;
    return ey >= ez ? 1 : 2;
}

static void insertion_sort(pm_photon *ph, size_t n, int axis) {
    for (size_t i = 1; i < n; i++) {
        pm_photon moving = ph[i];
        float key = photon_key(&moving, axis);
        size_t j = i;
        for (; j > 0 && photon_key(&ph[j - 1], axis) > key; j--) ph[j] = ph[j - 1];
        ph[j] = moving;
    }
}

static void heap_sift_down_photons(pm_photon *ph, size_t n, size_t pos, int axis) {
    for (;;) {
        size_t child = 2 * pos + 1;
        if (child >= n) return;
        if (child + 1 < n && photon_key(&ph[child + 1], axis) > photon_key(&ph[child], axis)) child++;
        if (photon_key(&ph[child], axis) <= photon_key(&ph[pos], axis)) return;
        swap_photons(&ph[child], &ph[pos]);
        pos = child;
    }
}

/* Guaranteed O(n log n) for the rare range on which median-of-three keeps picking bad pivots. */
static void heap_sort(pm_photon *ph, size_t n, int axis) {
    for (size_t i = n / 2; i-- > 0;) heap_sift_down_photons(ph, n, i, axis);
    for (size_t end = n; end-- > 1;) {
        swap_photons(&ph[0], &ph[end]);
        heap_sift_down_photons(ph, end, 0, axis);
    }
}

static void order_three(pm_photon *a, pm_photon *b, pm_photon *c, int axis) {
    if (photon_key(b, axis) < photon_key(a, axis)) swap_photons(a, b);
    if (photon_key(c, axis) < photon_key(b, axis)) {
        swap_photons(b, c);
        if (photon_key(b, axis) < photon_key(a, axis)) swap_photons(a, b);
    }
}

/* Reorders ph[0, n) so that ph[nth] is the element a sort would put there, with nothing greater
 * before it and nothing smaller after it. Hoare partitioning stops on keys equal to the pivot
 * from both sides, so runs of duplicates split in the middle instead of degrading. */
static void select_nth(pm_photon *ph, size_t n, size_t nth, int axis) {
    size_t lo = 0, hi = n - 1; /* inclusive */
    int rounds_left = 8;
    for (size_t m = n; m > 1; m >>= 1) rounds_left += 2;
    while (hi > lo) {
        size_t len = hi - lo + 1;
        if (len <= SELECT_INSERTION_SIZE) {
            insertion_sort(ph + lo, len, axis);
            return;
        }
        if (rounds_left-- == 0) {
            heap_sort(ph + lo, len, axis);
            return;
        }
        size_t mid = lo + (hi - lo) / 2;
        order_three(&ph[lo], &ph[mid], &ph[hi], axis);
        float pivot = photon_key(&ph[mid], axis);
        /* ph[lo] <= pivot <= ph[hi] stop both scans before they leave the range */
        size_t i = lo, j = hi;
        for (;;) {
            do i++; while (photon_key(&ph[i], axis) < pivot);
            do j--; while (photon_key(&ph[j], axis) > pivot);
            if (i >= j) break;
            swap_photons(&ph[i], &ph[j]);
        }
        /* now [lo, j] <= pivot <= [j + 1, hi], both parts non-empty */
        if (nth <= j) hi = j;
        else lo = j + 1;
    }
}

/* Makes the photon at the middle of [lo, hi) the root of that range; returns its index. */
static size_t split_range(pm_photon *photons, uint8_t *axis, size_t lo, size_t hi) {
    size_t n = hi - lo, half = n / 2;
    int a = widest_axis(photons + lo, n);
    select_nth(photons + lo, n, half, a);
    axis[lo + half] = (uint8_t)a;
    return lo + half;
}

static void build_range(pm_photon *photons, uint8_t *axis, size_t lo, size_t hi) {
    /* recursing on the left half only bounds the depth by the tree height */
    while (hi - lo > 1) {
        size_t mid = split_range(photons, axis, lo, hi);
        build_range(photons, axis, lo, mid);
        lo = mid + 1;
    }
    if (hi - lo == 1) axis[lo] = LEAF_AXIS;
}

typedef struct { size_t lo, hi; } index_range;

typedef struct {
    pm_photon *photons;
    uint8_t *axis;
    const index_range *ranges;
    index_range *children; /* 2 per range, for the next level */
} build_job;

static void split_level_task(void *ctx, size_t task, int thread) {
    build_job *job = ctx;
    index_range r = job->ranges[task];
    index_range *kids = &job->children[2 * task];
    if (r.hi - r.lo <= 1) {
        if (r.hi - r.lo == 1) job->axis[r.lo] = LEAF_AXIS;
        kids[0] = kids[1] = (index_range){r.hi, r.hi};
        return;
    }
    size_t mid = split_range(job->photons, job->axis, r.lo, r.hi);
    kids[0] = (index_range){r.lo, mid};
    kids[1] = (index_range){mid + 1, r.hi};
}

static void build_subtree_task(void *ctx, size_t task, int thread) {
    build_job *job = ctx;
    build_range(job->photons, job->axis, job->ranges[task].lo, job->ranges[task].hi);
}

static void build_parallel(pm_photon *photons, uint8_t *axis, size_t count, int threads) {
    /* enough subtrees that the atomic task counter can balance uneven ones */
    size_t subtrees = 1;
    while (subtrees * 2 <= MAX_PARALLEL_SUBTREES && subtrees * 2 <= (size_t)threads * 16 &&
           count / (subtrees * 2) >= MIN_PARALLEL_SUBTREE)
        subtrees *= 2;
    if (subtrees == 1) {
        build_range(photons, axis, 0, count);
        return;
    }
    index_range levels[2][MAX_PARALLEL_SUBTREES];
    levels[0][0] = (index_range){0, count};
    int current = 0;
    for (size_t nodes = 1; nodes < subtrees; nodes *= 2) {
        build_job job = {photons, axis, levels[current], levels[!current]};
        pm_parallel_for(threads, nodes, split_level_task, &job);
        current = !current;
    }
    build_job job = {photons, axis, levels[current], NULL};
    pm_parallel_for(threads, subtrees, build_subtree_task, &job);
}

bool pm_kdtree_build(pm_kdtree *t, pm_photon *photons, size_t count, int threads) {
    memset(t, 0, sizeof *t);
    uint8_t *axis = NULL;
    if (count) {
        axis = pm_malloc(count, "photon kd-tree");
        if (!axis) {
            free(photons);
            return false;
        }
        if (threads < 1) threads = 1;
        if (threads == 1) build_range(photons, axis, 0, count);
        else build_parallel(photons, axis, count, threads);
    }
    t->photons = photons;
    t->axis = axis;
    t->count = count;
    return true;
}

void pm_kdtree_free(pm_kdtree *t) {
    free(t->photons);
    free(t->axis);
    memset(t, 0, sizeof *t);
}

size_t pm_kdtree_bytes(const pm_kdtree *t) { return t->count * (sizeof(pm_photon) + sizeof(uint8_t)); }

typedef struct {
    size_t lo, hi;
    float plane_dist2; /* lower bound of the distance to any photon in the range */
} pending_range;

/* One step down from the node at mid of [*lo, *hi): the range goes on to q's side of the split
 * plane, and the far side is returned to be visited later, with its plane's squared distance. */
static inline pending_range step_down(const float q[3], const pm_photon *photons, const uint8_t *axis, size_t mid,
                                      size_t *lo, size_t *hi) {
    int a = axis[mid];
    float offset = q[a] - photons[mid].pos[a];
    pending_range far = {*lo, mid, offset * offset};
    if (offset < 0.f) {
        far.lo = mid + 1;
        far.hi = *hi;
        *hi = mid;
    } else {
        *lo = mid + 1;
    }
    return far;
}

typedef struct {
    float q[3];
    uint32_t *index;
    float *dist2;
    size_t k, found;
    /* Until k are found: accept dist2 <= bound (the caller's maximum). Then bound is the heap
     * top and only strictly closer photons can replace it. */
    float bound;
    bool full;
    size_t visits;
} knn_state;

static inline float dist2_to(const float q[3], const pm_photon *ph) {
    float dx = ph->pos[0] - q[0], dy = ph->pos[1] - q[1], dz = ph->pos[2] - q[2];
    return dx * dx + dy * dy + dz * dz;
}

static inline bool knn_beyond(const knn_state *s, float dist2) {
    return s->full ? dist2 >= s->bound : dist2 > s->bound;
}

static inline void knn_consider(knn_state *s, const pm_photon *photons, size_t i) {
    float d2 = dist2_to(s->q, &photons[i]);
    s->visits++;
    if (knn_beyond(s, d2)) return;
    uint32_t *index = s->index;
    float *dist2 = s->dist2;
    if (!s->full) {
        size_t pos = s->found++;
        while (pos > 0) {
            size_t parent = (pos - 1) / 2;
            if (dist2[parent] >= d2) break;
            dist2[pos] = dist2[parent];
            index[pos] = index[parent];
            pos = parent;
        }
        dist2[pos] = d2;
        index[pos] = (uint32_t)i;
        if (s->found == s->k) {
            s->full = true;
            s->bound = dist2[0];
        }
        return;
    }
    size_t n = s->found, pos = 0;
    for (;;) {
        size_t child = 2 * pos + 1;
        if (child >= n) break;
        if (child + 1 < n && dist2[child + 1] > dist2[child]) child++;
        if (dist2[child] <= d2) break;
        dist2[pos] = dist2[child];
        index[pos] = index[child];
        pos = child;
    }
    dist2[pos] = d2;
    index[pos] = (uint32_t)i;
    s->bound = dist2[0];
}

static size_t nearest_search(const pm_kdtree *t, vec3 p, size_t k, float max_dist2, uint32_t *index_out,
                             float *dist2_out, float *radius2_out, size_t *visits_out) {
    knn_state s = {{p.x, p.y, p.z}, index_out, dist2_out, k, 0, max_dist2, false, 0};
    const pm_photon *photons = t->photons;
    const uint8_t *axis = t->axis;
    pending_range stack[STACK_DEPTH];
    int depth = 0;
    size_t lo = 0, hi = k ? t->count : 0;
    for (;;) {
        while (hi - lo > SCAN_RANGE) {
            size_t mid = lo + (hi - lo) / 2;
            knn_consider(&s, photons, mid);
            pending_range far = step_down(s.q, photons, axis, mid, &lo, &hi);
            if (far.hi > far.lo && !knn_beyond(&s, far.plane_dist2)) stack[depth++] = far;
        }
        for (size_t i = lo; i < hi; i++) knn_consider(&s, photons, i);
        /* the radius may have shrunk since a range was pushed */
        while (depth > 0 && knn_beyond(&s, stack[depth - 1].plane_dist2)) depth--;
        if (depth == 0) break;
        depth--;
        lo = stack[depth].lo;
        hi = stack[depth].hi;
    }
    *radius2_out = s.found ? dist2_out[0] : 0.f;
    if (visits_out) *visits_out = s.visits;
    return s.found;
}

size_t pm_kdtree_nearest(const pm_kdtree *t, vec3 p, size_t k, float max_dist2, uint32_t *index_out,
                         float *dist2_out, float *radius2_out) {
    return nearest_search(t, p, k, max_dist2, index_out, dist2_out, radius2_out, NULL);
}

size_t pm_kdtree_nearest_count_visits(const pm_kdtree *t, vec3 p, size_t k, float max_dist2, uint32_t *index_out,
                                      float *dist2_out, float *radius2_out, size_t *visits_out) {
    return nearest_search(t, p, k, max_dist2, index_out, dist2_out, radius2_out, visits_out);
}

/* The fixed-radius walk; static inline so that each caller's visitor is inlined into it. */
static inline void within_walk(const pm_kdtree *t, vec3 p, float radius2,
                               void (*visit)(void *ctx, const pm_photon *ph, float dist2), void *ctx) {
    const float q[3] = {p.x, p.y, p.z};
    const pm_photon *photons = t->photons;
    const uint8_t *axis = t->axis;
    pending_range stack[STACK_DEPTH];
    int depth = 0;
    size_t lo = 0, hi = t->count;
    for (;;) {
        while (hi - lo > SCAN_RANGE) {
            size_t mid = lo + (hi - lo) / 2;
            float d2 = dist2_to(q, &photons[mid]);
            if (d2 <= radius2) visit(ctx, &photons[mid], d2);
            pending_range far = step_down(q, photons, axis, mid, &lo, &hi);
            if (far.hi > far.lo && far.plane_dist2 <= radius2) stack[depth++] = far;
        }
        for (size_t i = lo; i < hi; i++) {
            float d2 = dist2_to(q, &photons[i]);
            if (d2 <= radius2) visit(ctx, &photons[i], d2);
        }
        if (depth == 0) break;
        depth--;
        lo = stack[depth].lo;
        hi = stack[depth].hi;
    }
}

void pm_kdtree_within(const pm_kdtree *t, vec3 p, float radius2,
                      void (*visit)(void *ctx, const pm_photon *ph, float dist2), void *ctx) {
    within_walk(t, p, radius2, visit, ctx);
}

typedef struct { vec3 n; unsigned path_mask; vec3 power; uint32_t count; } filtered_sum;

static inline void filtered_visit(void *ctx, const pm_photon *ph, float dist2) {
    filtered_sum *g = ctx;
    if (!pm_photon_counts_for(ph, g->n, g->path_mask)) return;
    g->power = v3_add(g->power, pm_photon_power(ph));
    g->count++;
}

uint32_t pm_kdtree_sum_facing(const pm_kdtree *t, vec3 p, vec3 n, float radius2, unsigned path_mask, vec3 *power) {
    filtered_sum g = {n, path_mask, {0.f, 0.f, 0.f}, 0};
    if (t->count && radius2 > 0.f) within_walk(t, p, radius2, filtered_visit, &g);
    *power = g.power;
    return g.count;
}
