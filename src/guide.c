/* guide.c: the marks of where estimates read photons (a hashed bit set) and the learned emission guide's cells, probabilities and sampling. */
#include "guide.h"

#include <assert.h>
#include <stdlib.h>
#include <string.h>

#include "memory.h"

#define MARK_WORDS (PM_GUIDE_MARK_BITS / 64)

/* A mark's side: 1-6 (0 stands for either side). */
static inline uint32_t facing_class(vec3 n) { return 1u + pm_axis_side(n); }

/* A mark's bit: p's cell, and the side its surface faces (facing 1-6) or either side (0). */
static inline size_t mark_bit(const pm_marks *m, vec3 p, uint32_t facing) {
    return (size_t)(pm_cell_hash(p, m->inv_cell) ^ (facing * 0x9e3779b9u)) & (PM_GUIDE_MARK_BITS - 1);
}

static inline void set_bit(uint64_t *bits, size_t b) {
    uint64_t bit = 1ull << (b & 63);
    /* most points mark a cell already marked: read before the atomic write */
    if (!(__atomic_load_n(&bits[b >> 6], __ATOMIC_RELAXED) & bit)) __atomic_fetch_or(&bits[b >> 6], bit, __ATOMIC_RELAXED);
}

static inline bool test_bit(const uint64_t *bits, size_t b) { return (bits[b >> 6] >> (b & 63)) & 1u; }

bool pm_marks_init(pm_marks *m) {
    memset(m, 0, sizeof *m);
    m->bits = pm_calloc(MARK_WORDS, sizeof(uint64_t), "photon guide marks");
    m->facing_bits = pm_calloc(MARK_WORDS, sizeof(uint64_t), "photon guide marks");
    return m->bits && m->facing_bits;
}

void pm_marks_free(pm_marks *m) {
    free(m->bits);
    free(m->facing_bits);
    memset(m, 0, sizeof *m);
}

void pm_marks_clear(pm_marks *m, float cell) {
    memset(m->bits, 0, MARK_WORDS * sizeof(uint64_t));
    memset(m->facing_bits, 0, MARK_WORDS * sizeof(uint64_t));
    m->cell = cell > 0.f && isfinite(cell) ? cell : 1.f;
    m->inv_cell = 1.f / m->cell;
    m->any = false;
}

void pm_marks_set(pm_marks *m, vec3 p, vec3 n) {
    set_bit(m->bits, mark_bit(m, p, 0));
    set_bit(m->facing_bits, mark_bit(m, p, facing_class(n)));
    if (!__atomic_load_n(&m->any, __ATOMIC_RELAXED)) __atomic_store_n(&m->any, true, __ATOMIC_RELAXED);
}

bool pm_marks_test(const pm_marks *m, vec3 p) { return test_bit(m->bits, mark_bit(m, p, 0)); }

bool pm_marks_test_facing(const pm_marks *m, vec3 p, vec3 n) { return test_bit(m->facing_bits, mark_bit(m, p, facing_class(n))); }

bool pm_cell_values_init(pm_cell_values *v) {
    memset(v, 0, sizeof *v);
    v->count = pm_calloc(PM_CELL_VALUES_CELLS, sizeof *v->count, "cell values");
    v->sum = pm_calloc(PM_CELL_VALUES_CELLS, sizeof *v->sum, "cell values");
    if (v->count && v->sum) return true;
    pm_cell_values_free(v);
    return false;
}

void pm_cell_values_free(pm_cell_values *v) {
    free(v->count);
    free(v->sum);
    memset(v, 0, sizeof *v);
}

void pm_cell_values_clear(pm_cell_values *v, float cell) {
    memset(v->count, 0, PM_CELL_VALUES_CELLS * sizeof *v->count);
    memset(v->sum, 0, PM_CELL_VALUES_CELLS * sizeof *v->sum);
    v->cell = cell > 0.f && isfinite(cell) ? cell : 1.f;
    v->inv_cell = 1.f / v->cell;
    v->total_sum = v->total_count = v->mean = 0.0;
    memset(v->touched, 0, sizeof v->touched);
}

void pm_cell_values_add(pm_cell_values *v, vec3 p, uint32_t value) {
    size_t i = pm_cell_hash(p, v->inv_cell) & (PM_CELL_VALUES_CELLS - 1);
    /* past 2^31 values a cell has been measured enough: it stops, and sums stay below 2^63 */
    if (v->count[i] >= (1u << 31)) return;
    v->count[i]++;
    v->sum[i] += value;
    size_t block = i / PM_CELL_VALUES_BLOCK;
    v->touched[block / 64] |= 1ull << (block % 64);
}

bool pm_cell_values_mean(const pm_cell_values *v, vec3 p, float *mean) {
    size_t i = pm_cell_hash(p, v->inv_cell) & (PM_CELL_VALUES_CELLS - 1);
    if (!v->count[i]) return false;
    *mean = (float)v->sum[i] / (float)v->count[i];
    return true;
}

/* Empties from's touched blocks, adding their values to into's first (into NULL: dropped). */
static void take_touched(pm_cell_values *into, pm_cell_values *from) {
    const uint32_t full = 1u << 31;
    for (size_t w = 0; w < sizeof from->touched / sizeof from->touched[0]; w++)
        for (uint64_t bits = from->touched[w]; bits; bits &= bits - 1) {
            size_t first = (w * 64 + (size_t)__builtin_ctzll(bits)) * PM_CELL_VALUES_BLOCK;
            for (size_t i = first; i < first + PM_CELL_VALUES_BLOCK; i++) {
                uint32_t n = from->count[i];
                if (!n) continue;
                /* a full cell keeps its mean: what from adds to it is dropped */
                if (into && into->count[i] < full) {
                    into->count[i] += n;
                    into->sum[i] += from->sum[i];
                    into->total_count += n;
                    into->total_sum += (double)from->sum[i];
                }
                from->count[i] = 0;
                from->sum[i] = 0;
            }
        }
    memset(from->touched, 0, sizeof from->touched);
}

void pm_cell_values_merge(pm_cell_values *into, pm_cell_values *from) {
    assert(into->cell == from->cell);
    take_touched(into, from);
    into->mean = into->total_count > 0.0 ? into->total_sum / into->total_count : 0.0;
}

void pm_cell_values_drop(pm_cell_values *v) { take_touched(NULL, v); }

bool pm_guide_init(pm_guide *g, uint32_t sources) {
    memset(g, 0, sizeof *g);
    g->sources = sources;
    if (!sources) return true;
    g->cdf = pm_malloc(sizeof(float) * sources * (PM_GUIDE_CELL_COUNT + 1), "photon guide");
    g->cut = pm_malloc(sizeof(uint32_t) * sources * PM_GUIDE_CELL_COUNT, "photon guide");
    g->emitted = pm_calloc((size_t)sources * PM_GUIDE_CELL_COUNT, sizeof(uint64_t), "photon guide counts");
    g->useful = pm_calloc((size_t)sources * PM_GUIDE_CELL_COUNT, sizeof(uint64_t), "photon guide counts");
    if (!g->cdf || !g->cut || !g->emitted || !g->useful) { pm_guide_free(g); return false; }
    pm_guide_reset(g);
    return true;
}

void pm_guide_free(pm_guide *g) {
    free(g->cdf);
    free(g->cut);
    free(g->emitted);
    free(g->useful);
    memset(g, 0, sizeof *g);
}

void pm_guide_copy(pm_guide *dst, const pm_guide *src) {
    assert(dst->sources == src->sources);
    size_t cells = (size_t)src->sources * PM_GUIDE_CELL_COUNT;
    if (!cells) return;
    memcpy(dst->cdf, src->cdf, (cells + src->sources) * sizeof(float));
    memcpy(dst->cut, src->cut, cells * sizeof(uint32_t));
    memcpy(dst->emitted, src->emitted, cells * sizeof(uint64_t));
    memcpy(dst->useful, src->useful, cells * sizeof(uint64_t));
}

/* Source s's CDF from its counts: each cell's useful records per photon (the mean rate where a
 * cell has emitted few, see below); uniform before anything useful was seen. The uniform share that
 * keeps every emission possible is mixed in per photon, over all of its guided numbers at once
 * (pm_guide_density). */
static void draw_cdf(pm_guide *g, uint32_t s) {
    const uint64_t *emitted = g->emitted + (size_t)s * PM_GUIDE_CELL_COUNT, *useful = g->useful + (size_t)s * PM_GUIDE_CELL_COUNT;
    float *cdf = g->cdf + (size_t)s * (PM_GUIDE_CELL_COUNT + 1);
    double all_emitted = 0.0, all_useful = 0.0, total = 0.0;
    for (int c = 0; c < PM_GUIDE_CELL_COUNT; c++) {
        all_emitted += (double)emitted[c];
        all_useful += (double)useful[c];
    }
    /* a cell's rate is shrunk toward the mean by PM_GUIDE_PRIOR photons' worth: a cell that sent
     * few photons, none of them useful yet, keeps a share, so the photons it does send when it
     * is useful are not rare and heavy */
    double mean_rate = all_emitted > 0.0 ? all_useful / all_emitted : 0.0;
#define CELL_RATE(c) (((double)useful[c] + PM_GUIDE_PRIOR * mean_rate) / ((double)emitted[c] + PM_GUIDE_PRIOR))
    for (int c = 0; c < PM_GUIDE_CELL_COUNT; c++) total += CELL_RATE(c);
    double acc = 0.0;
    cdf[0] = 0.f;
    for (int c = 0; c < PM_GUIDE_CELL_COUNT; c++) {
        double rate = CELL_RATE(c);
        acc += total > 0.0 ? rate / total : 1.0 / PM_GUIDE_CELL_COUNT;
        cdf[c + 1] = (float)acc;
    }
#undef CELL_RATE
    for (int c = 1; c <= PM_GUIDE_CELL_COUNT; c++) cdf[c] = (float)(cdf[c] / acc);
    cdf[PM_GUIDE_CELL_COUNT] = 1.f;
    pm_cdf_cut_points(cdf, PM_GUIDE_CELL_COUNT, g->cut + (size_t)s * PM_GUIDE_CELL_COUNT);
}

void pm_guide_reset(pm_guide *g) {
    if (!g->sources) return;
    memset(g->emitted, 0, sizeof(uint64_t) * g->sources * PM_GUIDE_CELL_COUNT);
    memset(g->useful, 0, sizeof(uint64_t) * g->sources * PM_GUIDE_CELL_COUNT);
    for (uint32_t s = 0; s < g->sources; s++) draw_cdf(g, s);
}

uint32_t pm_guide_pick(const pm_guide *g, uint32_t s, float u_cell, float *u1, float *u2) {
    uint32_t c = pm_cdf_interval_cut(g->cdf + (size_t)s * (PM_GUIDE_CELL_COUNT + 1), g->cut + (size_t)s * PM_GUIDE_CELL_COUNT,
                                     PM_GUIDE_CELL_COUNT, u_cell);
    *u1 = pm_minf(((float)(c % PM_GUIDE_CELLS) + *u1) * (1.f / PM_GUIDE_CELLS), 0x1.fffffep-1f);
    *u2 = pm_minf(((float)(c / PM_GUIDE_CELLS) + *u2) * (1.f / PM_GUIDE_CELLS), 0x1.fffffep-1f);
    return c;
}

uint32_t pm_guide_cell_of(float u1, float u2) {
    uint32_t x = (uint32_t)(u1 * PM_GUIDE_CELLS), y = (uint32_t)(u2 * PM_GUIDE_CELLS);
    x = x < PM_GUIDE_CELLS ? x : PM_GUIDE_CELLS - 1;
    y = y < PM_GUIDE_CELLS ? y : PM_GUIDE_CELLS - 1;
    return y * PM_GUIDE_CELLS + x;
}

double pm_guide_density(const pm_guide *g, uint32_t s, uint32_t cell) {
    const float *cdf = g->cdf + (size_t)s * (PM_GUIDE_CELL_COUNT + 1);
    return ((double)cdf[cell + 1] - (double)cdf[cell]) * PM_GUIDE_CELL_COUNT;
}

void pm_guide_learn(pm_guide *g, const uint32_t *emitted, const uint32_t *useful) {
    for (uint32_t s = 0; s < g->sources; s++) {
        for (int c = 0; c < PM_GUIDE_CELL_COUNT; c++) {
            size_t k = (size_t)s * PM_GUIDE_CELL_COUNT + c;
            g->emitted[k] += emitted[k];
            g->useful[k] += useful[k];
        }
        draw_cdf(g, s);
    }
}
