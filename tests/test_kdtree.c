/* test_kdtree.c: the photon kd-tree against brute force (k-nearest, fixed radius) on uniform and degenerate sets, plus layout invariants, thread-count determinism and query cost. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "kdtree.h"
#include "rng.h"
#include "testing.h"

/* k values above this many photons are checked against a full sort only on sets this small */
enum { FULL_SORT_MAX = 10000, BIG_K = 500 };

/* The same float expression, in the same order, as the tree's own distance: results must be
 * bit-identical, not merely close. */
static float dist2_of(const float q[3], const pm_photon *ph) {
    float dx = ph->pos[0] - q[0], dy = ph->pos[1] - q[1], dz = ph->pos[2] - q[2];
    return dx * dx + dy * dy + dz * dz;
}

/* Each photon carries a unique id in its direction/normal fields so identity survives the reorder. */
static uint32_t photon_id(const pm_photon *ph) { return (uint32_t)ph->direction | (uint32_t)ph->normal_path << 16; }

static void set_photon(pm_photon *ph, uint32_t id, float x, float y, float z) {
    ph->pos[0] = x;
    ph->pos[1] = y;
    ph->pos[2] = z;
    ph->direction = (uint16_t)(id & 0xffff);
    ph->normal_path = (uint16_t)(id >> 16);
    uint64_t h = pm_hash64(id);
    memcpy(ph->power, &h, 4);
}

static int cmp_float(const void *a, const void *b) {
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static int cmp_u32(const void *a, const void *b) {
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static int cmp_photon_bytes(const void *a, const void *b) { return memcmp(a, b, sizeof(pm_photon)); }

static float gaussian(pm_rng *r) {
    float u1 = 1.f - pm_rng_float(r), u2 = pm_rng_float(r); /* u1 in (0, 1] */
    return sqrtf(-2.f * logf(u1)) * cosf(2.f * PM_PI * u2);
}

/* ---- point sets ---- */

typedef enum {
    SET_UNIFORM,
    SET_PLANE_Z0,      /* every photon at z = 0 */
    SET_DUPLICATES,    /* half of them at one position, the rest on 16 other positions */
    SET_ALL_SAME,      /* every photon at one position */
    SET_LINE_AXIS,     /* on a line parallel to x */
    SET_LINE_DIAG,     /* on a diagonal line */
    SET_GAUSS_OUTLIERS,/* tight Gaussian cluster and 1% outliers a thousand units away */
    SET_OFFSET_1E5,    /* unit-ish cube 1e5 from the origin: coordinates quantised to 1/128 */
    SET_SCALE_1EM3,    /* cube of side 1e-3 at the origin */
    SET_OFFSET_SCALED  /* cube of side 1e-3 at 1e5 * 1e-3 = 100: heavy float quantisation */
} set_kind;

static pm_photon *make_set(set_kind kind, size_t n, uint64_t seed) {
    pm_photon *ph = malloc((n ? n : 1) * sizeof *ph);
    if (!ph) abort();
    pm_rng r = pm_rng_for(seed, (uint64_t)kind, n);
    float dup[16][3];
    for (int i = 0; i < 16; i++)
        for (int a = 0; a < 3; a++) dup[i][a] = pm_rng_float(&r);
    for (size_t i = 0; i < n; i++) {
        float u = pm_rng_float(&r), v = pm_rng_float(&r), w = pm_rng_float(&r);
        float x = u, y = v, z = w;
        switch (kind) {
        case SET_UNIFORM: break;
        case SET_PLANE_Z0: z = 0.f; break;
        case SET_DUPLICATES:
            if (u < 0.5f) x = y = z = 0.5f;
            else {
                int d = (int)(v * 16.f) & 15;
                x = dup[d][0], y = dup[d][1], z = dup[d][2];
            }
            break;
        case SET_ALL_SAME: x = 0.25f, y = -3.f, z = 7.f; break;
        case SET_LINE_AXIS: y = 0.5f, z = -0.25f; break;
        case SET_LINE_DIAG: x = 1.f + u, y = 2.f - 0.5f * u, z = 3.f * u; break;
        case SET_GAUSS_OUTLIERS:
            if (w < 0.01f) {
                x = (u - 0.5f) * 2000.f, y = (v - 0.5f) * 2000.f, z = pm_rng_float(&r) < 0.5f ? -1000.f : 1000.f;
            } else {
                x = 0.3f + 0.01f * gaussian(&r), y = 0.3f + 0.01f * gaussian(&r), z = 0.3f + 0.01f * gaussian(&r);
            }
            break;
        case SET_OFFSET_1E5: x = 1e5f + u, y = 1e5f + 100.f * v, z = -1e5f + 10.f * w; break;
        case SET_SCALE_1EM3: x = 1e-3f * u, y = 1e-3f * v, z = 1e-3f * w; break;
        case SET_OFFSET_SCALED: x = 100.f + 1e-3f * u, y = 100.f + 1e-3f * v, z = -100.f + 1e-3f * w; break;
        }
        set_photon(&ph[i], (uint32_t)i, x, y, z);
    }
    return ph;
}

/* McIlroy's adversary ("A killer adversary for quicksort", 1999) against the build's first
 * median-of-three quickselect: replays that selection on items whose values are fixed lazily,
 * always so that the pivot lands near the end of its range, then lays the values out on x.
 * Quickselect alone would need O(n^2) on this input: the build must fall back to its heap sort
 * and still produce a valid tree. This mirrors select_nth in kdtree.c; if that changes, the
 * set is merely an awkward one, and the brute-force checks still hold. */
typedef struct { uint32_t *val, gas, solid, candidate; } adversary;

static int adv_cmp(adversary *A, uint32_t x, uint32_t y) {
    if (x == y) return 0;
    if (A->val[x] == A->gas && A->val[y] == A->gas) A->val[x == A->candidate ? x : y] = A->solid++;
    if (A->val[x] == A->gas) A->candidate = x;
    else if (A->val[y] == A->gas) A->candidate = y;
    return (A->val[x] > A->val[y]) - (A->val[x] < A->val[y]);
}

static void adv_swap(uint32_t *a, uint32_t *b) {
    uint32_t t = *a;
    *a = *b;
    *b = t;
}

static pm_photon *make_killer(size_t n) {
    uint32_t *item = malloc(n * sizeof *item), *val = malloc(n * sizeof *val);
    if (!item || !val) abort();
    adversary A = {val, (uint32_t)n, 0, 0};
    for (size_t i = 0; i < n; i++) item[i] = (uint32_t)i, val[i] = A.gas;
    size_t nth = n / 2, lo = 0, hi = n - 1;
    while (hi > lo && hi - lo + 1 > 12) {
        size_t mid = lo + (hi - lo) / 2;
        if (adv_cmp(&A, item[mid], item[lo]) < 0) adv_swap(&item[lo], &item[mid]);
        if (adv_cmp(&A, item[hi], item[mid]) < 0) {
            adv_swap(&item[mid], &item[hi]);
            if (adv_cmp(&A, item[mid], item[lo]) < 0) adv_swap(&item[lo], &item[mid]);
        }
        uint32_t pivot = item[mid];
        size_t i = lo, j = hi;
        for (;;) {
            do i++; while (adv_cmp(&A, item[i], pivot) < 0);
            do j--; while (adv_cmp(&A, item[j], pivot) > 0);
            if (i >= j) break;
            adv_swap(&item[i], &item[j]);
        }
        if (nth <= j) hi = j;
        else lo = j + 1;
    }
    /* items never compared with each other are still gas: any values above the solid
     * ones keep the replay exact, and scrambling them makes the fallback sort real work */
    pm_rng r = pm_rng_for(n, 3, 5);
    for (size_t i = 0; i < n; i++)
        if (val[i] == A.gas) val[i] = A.solid + (uint32_t)n + pm_rng_u32(&r) % (uint32_t)n;
    pm_photon *ph = malloc(n * sizeof *ph);
    if (!ph) abort();
    for (size_t i = 0; i < n; i++) set_photon(&ph[i], (uint32_t)i, (float)val[i] * 0.001f, 0.f, 0.f);
    free(item);
    free(val);
    return ph;
}

static pm_photon *copy_photons(const pm_photon *src, size_t n) {
    pm_photon *p = malloc((n ? n : 1) * sizeof *p);
    if (!p) abort();
    if (n) memcpy(p, src, n * sizeof *p);
    return p;
}

/* ---- invariants ---- */

typedef struct {
    size_t misplaced;   /* photons on the wrong side of their subtree root */
    size_t bad_axis;    /* axis out of range, or leaf marker wrong */
    size_t not_widest;  /* split axis is not the widest extent (ties to the lower axis) */
    size_t height;
} layout_report;

static void check_layout(const pm_kdtree *t, size_t lo, size_t hi, size_t depth, layout_report *rep) {
    if (hi <= lo) return;
    if (depth > rep->height) rep->height = depth;
    if (hi - lo == 1) {
        if (t->axis[lo] != 3) rep->bad_axis++;
        return;
    }
    size_t mid = lo + (hi - lo) / 2;
    int a = t->axis[mid];
    if (a > 2) {
        rep->bad_axis++;
        return;
    }
    float lo_b[3], hi_b[3];
    for (int k = 0; k < 3; k++) lo_b[k] = hi_b[k] = t->photons[lo].pos[k];
    for (size_t i = lo; i < hi; i++)
        for (int k = 0; k < 3; k++) {
            float v = t->photons[i].pos[k];
            if (v < lo_b[k]) lo_b[k] = v;
            if (v > hi_b[k]) hi_b[k] = v;
        }
    float ext[3] = {hi_b[0] - lo_b[0], hi_b[1] - lo_b[1], hi_b[2] - lo_b[2]};
    int widest = 0;
    if (ext[1] > ext[widest]) widest = 1;
    if (ext[2] > ext[widest]) widest = 2;
    if (a != widest) rep->not_widest++;
    float split = t->photons[mid].pos[a];
    for (size_t i = lo; i < mid; i++) rep->misplaced += !(t->photons[i].pos[a] <= split);
    for (size_t i = mid + 1; i < hi; i++) rep->misplaced += !(t->photons[i].pos[a] >= split);
    check_layout(t, lo, mid, depth + 1, rep);
    check_layout(t, mid + 1, hi, depth + 1, rep);
}

static void check_invariants(const char *name, const pm_kdtree *t, const pm_photon *src, size_t n) {
    CHECK(t->count == n, "%s: count %zu, built from %zu", name, t->count, n);
    if (n == 0) {
        CHECK(pm_kdtree_bytes(t) == 0, "%s: empty tree reports %zu bytes", name, pm_kdtree_bytes(t));
        return;
    }
    CHECK(pm_kdtree_bytes(t) > 0, "%s: non-empty tree reports 0 bytes", name);
    CHECK(t->photons != NULL && t->axis != NULL, "%s: tree arrays missing", name);
    layout_report rep = {0, 0, 0, 0};
    check_layout(t, 0, n, 1, &rep);
    CHECK(rep.misplaced == 0, "%s: %zu photons on the wrong side of their subtree root", name, rep.misplaced);
    CHECK(rep.bad_axis == 0, "%s: %zu nodes with a wrong axis / leaf marker", name, rep.bad_axis);
    CHECK(rep.not_widest == 0, "%s: %zu nodes not split on their widest axis", name, rep.not_widest);
    size_t want_height = 0;
    for (size_t m = n; m; m >>= 1) want_height++; /* floor(log2 n) + 1 */
    CHECK(rep.height == want_height, "%s: height %zu, want %zu", name, rep.height, want_height);
    /* the same photons, byte for byte, only reordered */
    pm_photon *a = copy_photons(src, n), *b = copy_photons(t->photons, n);
    qsort(a, n, sizeof *a, cmp_photon_bytes);
    qsort(b, n, sizeof *b, cmp_photon_bytes);
    CHECK(memcmp(a, b, n * sizeof *a) == 0, "%s: the tree's photons are not a permutation of the input", name);
    free(a);
    free(b);
}

/* ---- brute force ---- */

/* The kmax smallest values of d[0, n), sorted ascending, into out. */
static void smallest_sorted(const float *d, size_t n, size_t kmax, float *out) {
    if (kmax == 0) return;
    if (kmax >= n) {
        memcpy(out, d, n * sizeof *d);
        qsort(out, n, sizeof *out, cmp_float);
        return;
    }
    /* bounded max-heap */
    size_t size = 0;
    for (size_t i = 0; i < n; i++) {
        float v = d[i];
        if (size < kmax) {
            size_t pos = size++;
            while (pos > 0 && out[(pos - 1) / 2] < v) {
                out[pos] = out[(pos - 1) / 2];
                pos = (pos - 1) / 2;
            }
            out[pos] = v;
        } else if (v < out[0]) {
            size_t pos = 0;
            for (;;) {
                size_t c = 2 * pos + 1;
                if (c >= size) break;
                if (c + 1 < size && out[c + 1] > out[c]) c++;
                if (out[c] <= v) break;
                out[pos] = out[c];
                pos = c;
            }
            out[pos] = v;
        }
    }
    qsort(out, kmax, sizeof *out, cmp_float);
}

typedef struct {
    float r2;
    size_t count;
    uint64_t index_sum, id_sum;
} brute_within;

/* Counts, for each of several radii at once, the photons with d[i] <= r2: one pass over d. */
static void brute_count(const pm_kdtree *t, const float *d, size_t n, brute_within *b, size_t nb) {
    for (size_t j = 0; j < nb; j++) b[j].count = 0, b[j].index_sum = b[j].id_sum = 0;
    for (size_t i = 0; i < n; i++) {
        float di = d[i];
        uint32_t id = 0;
        bool have_id = false;
        for (size_t j = 0; j < nb; j++)
            if (di <= b[j].r2) {
                if (!have_id) id = photon_id(&t->photons[i]), have_id = true;
                b[j].count++;
                b[j].index_sum += i;
                b[j].id_sum += id;
            }
    }
}

/* ---- k-nearest ---- */

static void check_nearest(const char *name, size_t qi, const pm_kdtree *t, vec3 p, size_t k, float max_dist2,
                          const float *smallest, size_t within) {
    const float q[3] = {p.x, p.y, p.z};
    size_t cap = k ? k : 1;
    uint32_t *idx = malloc(cap * sizeof *idx), *idx2 = malloc(cap * sizeof *idx2);
    float *d2 = malloc(cap * sizeof *d2), *d2b = malloc(cap * sizeof *d2b), *sorted = malloc(cap * sizeof *sorted);
    if (!idx || !idx2 || !d2 || !d2b || !sorted) abort();
    float r2 = -1.f, r2b = -1.f;
    size_t got = pm_kdtree_nearest(t, p, k, max_dist2, idx, d2, &r2);
    size_t want = k < within ? k : within;
    CHECK(got == want, "%s q%zu k=%zu max_dist2=%g: found %zu, brute force %zu", name, qi, k, max_dist2, got, want);
    if (got > k) got = k;

    size_t visits = (size_t)-1;
    size_t got2 = pm_kdtree_nearest_count_visits(t, p, k, max_dist2, idx2, d2b, &r2b, &visits);
    if (got2 > k) got2 = k;
    CHECK(got2 == got && r2b == r2 && memcmp(idx, idx2, got * sizeof *idx) == 0 &&
              memcmp(d2, d2b, got * sizeof *d2) == 0,
          "%s q%zu k=%zu: the visit-counting query returns something else", name, qi, k);
    CHECK(visits >= got && visits <= t->count, "%s q%zu k=%zu: %zu visits for %zu found among %zu", name, qi, k,
          visits, got, t->count);

    size_t bad_index = 0, bad_dist = 0, over = 0;
    float largest = 0.f;
    for (size_t i = 0; i < got; i++) {
        if (idx[i] >= t->count) {
            bad_index++;
            continue;
        }
        if (dist2_of(q, &t->photons[idx[i]]) != d2[i]) bad_dist++;
        if (!(d2[i] <= max_dist2)) over++;
        if (d2[i] > largest) largest = d2[i];
    }
    CHECK(bad_index == 0, "%s q%zu k=%zu: %zu indices out of range", name, qi, k, bad_index);
    CHECK(bad_dist == 0, "%s q%zu k=%zu: %zu reported distances differ from the photon's", name, qi, k, bad_dist);
    CHECK(over == 0, "%s q%zu k=%zu: %zu results beyond max_dist2 %g", name, qi, k, over, max_dist2);
    CHECK(r2 == largest, "%s q%zu k=%zu max_dist2=%g: radius2 %.9g, largest result %.9g", name, qi, k, max_dist2, r2,
          largest);

    memcpy(idx2, idx, got * sizeof *idx);
    qsort(idx2, got, sizeof *idx2, cmp_u32);
    size_t repeats = 0;
    for (size_t i = 1; i < got; i++) repeats += idx2[i] == idx2[i - 1];
    CHECK(repeats == 0, "%s q%zu k=%zu: %zu photons returned twice", name, qi, k, repeats);

    if (got == want) {
        memcpy(sorted, d2, got * sizeof *d2);
        qsort(sorted, got, sizeof *sorted, cmp_float);
        size_t first_diff = got;
        for (size_t i = 0; i < got && first_diff == got; i++)
            if (sorted[i] != smallest[i]) first_diff = i;
        CHECK(first_diff == got, "%s q%zu k=%zu max_dist2=%g: distance #%zu is %.9g, brute force %.9g", name, qi, k,
              max_dist2, first_diff, first_diff < got ? sorted[first_diff] : 0.f,
              first_diff < got ? smallest[first_diff] : 0.f);
    }
    free(idx);
    free(idx2);
    free(d2);
    free(d2b);
    free(sorted);
}

/* ---- fixed radius ---- */

typedef struct {
    const pm_kdtree *t;
    float q[3], r2;
    uint32_t *stamp, mark;
    size_t count, bad_index, repeats, bad_dist, outside;
    uint64_t index_sum, id_sum;
} within_ctx;

static void within_visit(void *ctx, const pm_photon *ph, float dist2) {
    within_ctx *c = ctx;
    c->count++;
    if (ph < c->t->photons || ph >= c->t->photons + c->t->count) {
        c->bad_index++;
        return;
    }
    size_t i = (size_t)(ph - c->t->photons);
    if (c->stamp[i] == c->mark) c->repeats++;
    c->stamp[i] = c->mark;
    c->index_sum += i;
    c->id_sum += photon_id(ph);
    if (dist2_of(c->q, ph) != dist2) c->bad_dist++;
    if (!(dist2 <= c->r2)) c->outside++;
}

static void check_within(const char *name, size_t qi, const pm_kdtree *t, vec3 p, brute_within b, uint32_t *stamp,
                         uint32_t *mark) {
    float r2 = b.r2;
    within_ctx c;
    memset(&c, 0, sizeof c);
    c.t = t;
    c.q[0] = p.x, c.q[1] = p.y, c.q[2] = p.z;
    c.r2 = r2;
    c.stamp = stamp;
    c.mark = ++*mark;
    pm_kdtree_within(t, p, r2, within_visit, &c);
    CHECK(c.bad_index == 0 && c.repeats == 0 && c.bad_dist == 0 && c.outside == 0,
          "%s q%zu r2=%g: %zu foreign pointers, %zu repeats, %zu wrong distances, %zu outside", name, qi, r2,
          c.bad_index, c.repeats, c.bad_dist, c.outside);
    CHECK(c.count == b.count && c.index_sum == b.index_sum && c.id_sum == b.id_sum,
          "%s q%zu r2=%g: visited %zu (index sum %llu), brute force %zu (index sum %llu)", name, qi, r2, c.count,
          (unsigned long long)c.index_sum, b.count, (unsigned long long)b.index_sum);
}

/* ---- one point set ---- */

static void run_set(const char *name, const pm_photon *src, size_t n, size_t queries, uint64_t seed) {
    /* build with several thread counts: byte-identical trees */
    static const int thread_counts[] = {1, 2, 3, 4};
    pm_kdtree trees[4];
    for (int i = 0; i < 4; i++) {
        pm_photon *copy = n ? copy_photons(src, n) : NULL;
        bool ok = pm_kdtree_build(&trees[i], copy, n, thread_counts[i]);
        CHECK(ok, "%s: build with %d threads failed", name, thread_counts[i]);
        if (!ok) abort();
    }
    for (int i = 1; i < 4; i++) {
        bool same = trees[i].count == n &&
                    (n == 0 || (memcmp(trees[i].photons, trees[0].photons, n * sizeof(pm_photon)) == 0 &&
                                memcmp(trees[i].axis, trees[0].axis, n) == 0));
        CHECK(same, "%s: the tree built on %d threads differs from the one-thread tree", name, thread_counts[i]);
    }
    const pm_kdtree *t = &trees[3];
    check_invariants(name, &trees[0], src, n);

    size_t ks[] = {0, 1, 8, 50, BIG_K, n + 3};
    size_t nks = n <= FULL_SORT_MAX ? 6 : 5;
    size_t kmax = 0;
    for (size_t i = 0; i < nks; i++) kmax = ks[i] > kmax ? ks[i] : kmax;
    if (kmax > n) kmax = n;

    float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    if (n) {
        for (int a = 0; a < 3; a++) lo[a] = hi[a] = src[0].pos[a];
        for (size_t i = 1; i < n; i++)
            for (int a = 0; a < 3; a++) {
                lo[a] = fminf(lo[a], src[i].pos[a]);
                hi[a] = fmaxf(hi[a], src[i].pos[a]);
            }
    }
    float ext = fmaxf(hi[0] - lo[0], fmaxf(hi[1] - lo[1], hi[2] - lo[2]));
    float margin = ext > 0.f ? 0.1f * ext : 1.f;

    float *d = malloc((n ? n : 1) * sizeof *d), *smallest = malloc((kmax ? kmax : 1) * sizeof *smallest);
    uint32_t *stamp = calloc(n ? n : 1, sizeof *stamp), mark = 0;
    if (!d || !smallest || !stamp) abort();
    pm_rng r = pm_rng_for(seed, 0x6b64, n);
    for (size_t qi = 0; qi < queries; qi++) {
        /* query points: exactly on a photon, near one, anywhere around the set, and far outside */
        float q[3];
        const pm_photon *near = n ? &src[pm_rng_u32(&r) % n] : NULL;
        int type = (int)(qi % 4);
        if (qi == 0 || !near) type = 4;
        for (int a = 0; a < 3; a++) {
            float u = pm_rng_float(&r) - 0.5f;
            switch (type) {
            case 0: q[a] = near->pos[a]; break;
            case 1: q[a] = near->pos[a] + u * 0.02f * (ext > 0.f ? ext : 1.f); break;
            case 2: q[a] = near->pos[a] + u * 1e-6f * (ext > 0.f ? ext : 1.f); break;
            case 3: q[a] = lo[a] - margin + (pm_rng_float(&r)) * (hi[a] - lo[a] + 2.f * margin); break;
            default: q[a] = hi[a] + 10.f * margin + u; break;
            }
        }
        vec3 p = v3(q[0], q[1], q[2]);
        for (size_t i = 0; i < n; i++) d[i] = dist2_of(q, &t->photons[i]);
        smallest_sorted(d, n, kmax, smallest);

        /* max_dist2: unlimited, exactly the 8th and 50th distance (ties at the boundary are
         * inside), just below the 50th, a quarter of the 8th, and 0 (only coincident photons) */
        brute_within th[13]; /* the max_dist2 values, then the radii */
        size_t nmax = 0, nth = 0;
        th[nth++].r2 = INFINITY;
        th[nth++].r2 = 0.f;
        if (n) {
            float d8 = smallest[(n < 8 ? n : 8) - 1], d50 = smallest[(n < 50 ? n : 50) - 1];
            th[nth++].r2 = d8;
            th[nth++].r2 = 0.25f * d8;
            th[nth++].r2 = d50;
            th[nth++].r2 = nextafterf(d50, 0.f);
        }
        nmax = nth;
        /* radii: 0, the 1st/8th/50th/kmax-th distance, a tenth of the set; everything on small sets */
        th[nth++].r2 = 0.f;
        if (n) {
            th[nth++].r2 = smallest[0];
            th[nth++].r2 = smallest[(n < 8 ? n : 8) - 1];
            th[nth++].r2 = smallest[(n < 50 ? n : 50) - 1];
            th[nth++].r2 = smallest[kmax - 1];
            if (n <= FULL_SORT_MAX) th[nth++].r2 = (0.1f * ext) * (0.1f * ext);
        }
        if (n <= FULL_SORT_MAX) th[nth++].r2 = INFINITY;
        brute_count(t, d, n, th, nth);

        for (size_t m = 0; m < nmax; m++)
            for (size_t ki = 0; ki < nks; ki++) check_nearest(name, qi, t, p, ks[ki], th[m].r2, smallest, th[m].count);
        for (size_t i = nmax; i < nth; i++) check_within(name, qi, t, p, th[i], stamp, &mark);
    }
    free(d);
    free(smallest);
    free(stamp);
    for (int i = 0; i < 4; i++) pm_kdtree_free(&trees[i]);
}

/* ---- the rest ---- */

static void count_visit(void *ctx, const pm_photon *ph, float dist2) { (*(size_t *)ctx)++; }

static void check_empty(void) {
    pm_kdtree t;
    CHECK(pm_kdtree_build(&t, NULL, 0, 1), "empty build failed");
    CHECK(t.count == 0 && pm_kdtree_bytes(&t) == 0, "empty tree: count %zu, %zu bytes", t.count, pm_kdtree_bytes(&t));
    uint32_t idx[4] = {7, 7, 7, 7};
    float d2[4] = {-1, -1, -1, -1}, r2 = -1.f;
    size_t visits = 99;
    CHECK(pm_kdtree_nearest(&t, v3(0, 0, 0), 4, INFINITY, idx, d2, &r2) == 0 && r2 == 0.f,
          "empty tree: nearest found something (radius2 %g)", r2);
    r2 = -1.f;
    CHECK(pm_kdtree_nearest_count_visits(&t, v3(1, 2, 3), 4, 1.f, idx, d2, &r2, &visits) == 0 && r2 == 0.f &&
              visits == 0,
          "empty tree: counted query found something (radius2 %g, %zu visits)", r2, visits);
    size_t seen = 0;
    pm_kdtree_within(&t, v3(0, 0, 0), INFINITY, count_visit, &seen);
    CHECK(seen == 0, "empty tree: within visited %zu", seen);
    pm_kdtree_free(&t);
    pm_kdtree_free(&t); /* free zeroes the tree, so twice is fine */

    /* an empty malloc'ed array is owned and freed too */
    CHECK(pm_kdtree_build(&t, malloc(sizeof(pm_photon)), 0, 4), "empty build with an array failed");
    CHECK(pm_kdtree_nearest(&t, v3(0, 0, 0), 1, INFINITY, idx, d2, &r2) == 0, "empty tree with array found something");
    pm_kdtree_free(&t);
}

/* A real tree measures a few hundred photons per 50-nearest query, not a scan of all of them. */
static void check_visits(void) {
    const size_t n = 200000, k = 50, queries = 1000;
    pm_photon *src = make_set(SET_UNIFORM, n, 99);
    pm_kdtree t;
    CHECK(pm_kdtree_build(&t, src, n, 2), "build failed");
    uint32_t idx[50];
    float d2[50], r2;
    pm_rng r = pm_rng_for(99, 1, 2);
    double total = 0.;
    size_t worst = 0, short_results = 0;
    for (size_t i = 0; i < queries; i++) {
        vec3 p = v3(pm_rng_float(&r), pm_rng_float(&r), pm_rng_float(&r));
        size_t visits = 0;
        size_t got = pm_kdtree_nearest_count_visits(&t, p, k, INFINITY, idx, d2, &r2, &visits);
        short_results += got != k;
        total += (double)visits;
        worst = visits > worst ? visits : worst;
    }
    double mean = total / (double)queries;
    CHECK(short_results == 0, "%zu queries found fewer than %zu photons", short_results, k);
    CHECK(mean < 0.02 * (double)n, "50-nearest visits %.0f photons on average of %zu: not a tree search", mean, n);
    CHECK(mean >= (double)k, "mean visits %.1f below k", mean);
    printf("visits: 50-nearest on %zu uniform photons measures %.0f on average (worst %zu, %.2f%%)\n", n, mean,
           worst, 100. * mean / (double)n);
    pm_kdtree_free(&t);
}

int main(void) {
    check_empty();

    static const size_t uniform_sizes[] = {0, 1, 2, 7, 100, 10000, 200000};
    for (size_t i = 0; i < sizeof uniform_sizes / sizeof *uniform_sizes; i++) {
        size_t n = uniform_sizes[i];
        char name[64];
        snprintf(name, sizeof name, "uniform %zu", n);
        pm_photon *src = make_set(SET_UNIFORM, n, 1);
        run_set(name, src, n, n >= 100000 ? 200 : (n >= 10000 ? 50 : 300), 1);
        free(src);
    }

    /* big enough for the parallel build to split them (>= 8192), small enough for brute force */
    static const struct { set_kind kind; const char *name; size_t n, queries; } sets[] = {
        {SET_PLANE_Z0, "plane z=0", 30000, 60},
        {SET_DUPLICATES, "duplicates", 30000, 60},
        {SET_DUPLICATES, "duplicates small", 500, 200},
        {SET_ALL_SAME, "all at one point", 20000, 25},
        {SET_ALL_SAME, "all at one point small", 9, 50},
        {SET_LINE_AXIS, "line along x", 20000, 60},
        {SET_LINE_DIAG, "diagonal line", 20000, 60},
        {SET_GAUSS_OUTLIERS, "gaussian cluster + outliers", 30000, 40},
        {SET_OFFSET_1E5, "offset 1e5", 30000, 60},
        {SET_SCALE_1EM3, "scale 1e-3", 30000, 60},
        {SET_OFFSET_SCALED, "offset 1e5 scaled 1e-3", 30000, 60},
    };
    for (size_t i = 0; i < sizeof sets / sizeof *sets; i++) {
        pm_photon *src = make_set(sets[i].kind, sets[i].n, 2 + i);
        run_set(sets[i].name, src, sets[i].n, sets[i].queries, 2 + i);
        free(src);
    }

    /* the quickselect's worst case: the build must take its heap-sort fallback */
    static const size_t killer_sizes[] = {333, 1000, 3001, 9000};
    for (size_t i = 0; i < sizeof killer_sizes / sizeof *killer_sizes; i++) {
        size_t n = killer_sizes[i];
        char name[64];
        snprintf(name, sizeof name, "median-of-three killer %zu", n);
        pm_photon *killer = make_killer(n);
        run_set(name, killer, n, 50, 20 + i);
        free(killer);
    }

    check_visits();
    return pm_test_done("test_kdtree");
}
