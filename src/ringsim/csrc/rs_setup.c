/**
 * @file    rs_setup.c
 * @brief   Set-up of a sheet: all particles added to a REBOUND simulation in one call;
 *          grids of cells per radius class for the overlap-free placement and for the
 *          overlap count of every output.
 *
 * | effect     | appends n particles, in index order, as REBOUND's Python `sim.add` does |
 * |------------|--------------------------------------------------------------------------|
 * | called by  | ringsim.engine.sheet.add_particles (ctypes)                              |
 * | parameters | SI arrays of length n: m [kg], r [m], x y z [m], vx vy vz [m/s]          |
 * | REBOUND    | reb_simulation_add, passed in as a pointer (librebound is loaded by      |
 * |            | REBOUND's Python package with local symbols: this library cannot link it)|
 *
 * `sim.add(m=..., ...)` builds a Python Particle and calls reb_simulation_add for each
 * particle (~20 us apiece, 20 s for 10^6 particles).  This loop makes the very same calls
 * with particles whose other fields (accelerations, name, ap) are zero, so the simulation,
 * its tree included, is the same bit for bit.
 *
 * The grids (`rs_grid`) find overlapping pairs for the initial placement
 * (ringsim.engine.placement) and count the deeply overlapping pairs of every time-series
 * output (`rs_count_overlaps`, ringsim.engine.box.count_overlaps: shear-periodic, the
 * same count as its numpy twin ringsim.testing.count_overlaps_numpy).  The count's search
 * runs on the run's threads: each thread collects the pairs of its particles, and the
 * pairs are sorted and counted once, so the count does not depend on the threads.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "rebound.h"

/** REBOUND's reb_simulation_add. */
typedef void (*rs_add_function)(struct reb_simulation* const, struct reb_particle);

/** Add n particles to r in index order with `add` (REBOUND's reb_simulation_add); returns
 *  the number of particles afterwards. */
int64_t rs_add_particles(struct reb_simulation* r, rs_add_function add, int64_t n,
                         const double* m,
                         const double* rad, const double* x, const double* y,
                         const double* z, const double* vx, const double* vy,
                         const double* vz) {
    for (int64_t i = 0; i < n; i++) {
        struct reb_particle p;
        memset(&p, 0, sizeof(p));
        p.m = m[i];
        p.r = rad[i];
        p.x = x[i];
        p.y = y[i];
        p.z = z[i];
        p.vx = vx[i];
        p.vy = vy[i];
        p.vz = vz[i];
        add(r, p);
    }
    return (int64_t)r->N;
}

/* --- overlap search of the initial placement ------------------------------------------- */

/** Particles a thread at least in the overlap count (below, one thread). */
#define RS_OVERLAP_PARTICLES_PER_THREAD 4096
/** Radius classes of the overlap grid at most (ringsim.engine.placement.MAX_CLASSES). */
#define RS_MAX_CLASSES 32
/** Of an overlapping pair, a particle more than this many times smaller than the other is
 *  drawn again (ringsim.engine.placement.YIELD_RATIO). */
#define RS_YIELD_RATIO 10.0


/** Cell index of a coordinate c >= 0 in cells of width w, clamped to [0, n). */
static int64_t rs_cell(double c, double w, int64_t n) {
    int64_t k = (int64_t)(c / w);
    return k < 0 ? 0 : (k >= n ? n - 1 : k);
}

/** A particle of the overlap grid, stored in "slots" in the order of the cells it was
 *  first placed in, so that neighbours in space are neighbours in memory. */
struct rs_grid_particle {
    double x, y, z, r;   /* x in [0, Lx), y in [0, Ly), z [m]; radius [m] (copies) */
    int64_t next, prev;  /* next and previous slot in the same cell, -1: none */
    int64_t cell;        /* its cell in the grid of its class */
    int32_t index;       /* the particle's index */
    int32_t searched;    /* searched in the present call of rs_grid_overlapping */
};

/** Particles found overlapping: flags by index, and the flagged indices in a list. */
struct rs_found {
    uint8_t* flag;   /* n entries, all 0 between calls */
    int64_t* list;   /* n entries */
    int64_t count;
};

/** Slots a and b overlap: the exact test of ringsim.engine.placement.overlapping_later
 *  (lower index first, minimal image in x and y, squares summed x + y then + z, compared
 *  with (r_lo + r_hi)^2); the one that yields goes into `found`: the smaller one where the
 *  other is more than RS_YIELD_RATIO times larger (so the largest particles are placed first
 *  and much smaller ones fill the room around them), else the higher index. */
static void rs_test_pair(const struct rs_grid_particle* a, const struct rs_grid_particle* b,
                         double Lx, double Ly, struct rs_found* found) {
    const struct rs_grid_particle* lo = a->index < b->index ? a : b;
    const struct rs_grid_particle* hi = a->index < b->index ? b : a;
    double rr = lo->r + hi->r;
    double dz = lo->z - hi->z;
    /* exact shortcut: the sum of squares below is at least dz * dz */
    if (dz * dz >= rr * rr) return;
    double dx = lo->x - hi->x;
    dx -= Lx * nearbyint(dx / Lx);
    double dy = lo->y - hi->y;
    dy -= Ly * nearbyint(dy / Ly);
    double s = dx * dx + dy * dy;
    s += dz * dz;
    const struct rs_grid_particle* yields =
        lo->r > RS_YIELD_RATIO * hi->r ? hi : (hi->r > RS_YIELD_RATIO * lo->r ? lo : hi);
    if (s < rr * rr && !found->flag[yields->index]) {
        found->flag[yields->index] = 1;
        found->list[found->count++] = yields->index;
    }
}

/** The cells of one radius class: slots in linked lists per cell. */
struct rs_class_grid {
    int64_t nx, ny, nz;
    double wx, wy, wz, largest;   /* cell widths [m], largest radius of the class [m] */
    int64_t* head;                /* first slot of each cell, -1: empty */
};

/** One grid of cells per radius class over the box [0, Lx) x [0, Ly) x [z_lo, ...)
 *  (periodic in x and y); a particle drawn again moves between cells in O(1). */
struct rs_grid {
    int64_t n;
    int n_classes;
    double Lx, Ly, z_lo, margin;
    struct rs_class_grid classes[RS_MAX_CLASSES];
    const int32_t* class_of;      /* class of each particle (the caller's array) */
    struct rs_grid_particle* p;   /* by slot */
    int64_t* slot_of;             /* slot of each particle */
    uint8_t* flag;                /* scratch of rs_grid_overlapping, all 0 between calls */
};

void rs_grid_free(struct rs_grid* g) {
    if (!g) return;
    for (int c = 0; c < g->n_classes; c++) free(g->classes[c].head);
    free(g->p); free(g->slot_of); free(g->flag);
    free(g);
}

/** Cells of one class: at least 2 `largest` (1 + margin) wide, at most ~4 per particle of
 *  the class (fewer layers in z first, then wider cells).  0, or -1 without memory. */
static int rs_class_grid_init(struct rs_class_grid* cg, int64_t members, double largest,
                              double Lx, double Ly, double z_extent, double margin) {
    double w = 2.0 * largest * (1.0 + margin);
    double cap = 4.0 * (double)members + 64.0;
    if (!(w > 0.0)) w = 1.0;
    /* doubled as below from where no cell count overflows int64 (radii below 1e-18 of the
     * box did): the same cells otherwise */
    double widest = Lx > Ly ? Lx : Ly;
    while (w < widest / (2.0 * cap)) w *= 2.0;
    for (;;) {
        cg->nx = (int64_t)(Lx / w); cg->ny = (int64_t)(Ly / w);
        cg->nx = cg->nx < 1 ? 1 : cg->nx; cg->ny = cg->ny < 1 ? 1 : cg->ny;
        if ((double)cg->nx * cg->ny <= cap) break;
        w *= 2.0;
    }
    int64_t nz = (int64_t)(z_extent / w) + 1;
    int64_t room = (int64_t)(cap / ((double)cg->nx * cg->ny));
    cg->nz = nz < room ? nz : (room < 1 ? 1 : room);
    cg->wx = Lx / (double)cg->nx; cg->wy = Ly / (double)cg->ny;
    cg->wz = z_extent / (double)cg->nz > w ? z_extent / (double)cg->nz : w;
    cg->largest = largest;
    int64_t n_cells = cg->nx * cg->ny * cg->nz;
    cg->head = malloc((size_t)n_cells * sizeof(int64_t));
    if (!cg->head) return -1;
    for (int64_t c = 0; c < n_cells; c++) cg->head[c] = -1;
    return 0;
}

/** Cell of a position in the grid of class grid cg. */
static int64_t rs_cell_of(const struct rs_grid* g, const struct rs_class_grid* cg, double x,
                          double y, double z) {
    return (rs_cell(x, cg->wx, cg->nx) * cg->ny + rs_cell(y, cg->wy, cg->ny)) * cg->nz
           + rs_cell(z - g->z_lo, cg->wz, cg->nz);
}

/** Link slot s into the cell list of its cell. */
static void rs_link(struct rs_grid* g, int64_t s) {
    struct rs_grid_particle* p = g->p;
    int64_t* head = g->classes[g->class_of[p[s].index]].head;
    p[s].prev = -1;
    p[s].next = head[p[s].cell];
    if (head[p[s].cell] >= 0) p[head[p[s].cell]].prev = s;
    head[p[s].cell] = s;
}

/** A particle index with a sort key (its class and cell). */
struct rs_keyed {
    int64_t key, i;
};

static int rs_compare_keyed(const void* a, const void* b) {
    const struct rs_keyed* ka = a;
    const struct rs_keyed* kb = b;
    if (ka->key != kb->key) return ka->key < kb->key ? -1 : 1;
    return ka->i < kb->i ? -1 : (ka->i > kb->i ? 1 : 0);
}

/**
 * Grids for n < 2^31 particles of radius classes class_of[i] in [0, n_classes) (the
 * largest radius of class c is largest[c] [m]) at x in [0, Lx), y in [0, Ly) (periodic)
 * and z [m], with radii rad [m]; the cells span heights [z_lo, z_hi] (heights outside go to
 * the end cells, which keeps neighbours neighbours).  `margin` widens the searched
 * distances against rounding.  Every particle is placed, slots in the order of the cells
 * (and of the particles' indices within a cell: a counting sort).  NULL: no memory or bad
 * arguments.
 */
struct rs_grid* rs_grid_create(int64_t n, int32_t n_classes, const int32_t* class_of,
                               const double* largest, double Lx, double Ly, double z_lo,
                               double z_hi, double margin, const double* x, const double* y,
                               const double* z, const double* rad) {
    if (n_classes < 1 || n_classes > RS_MAX_CLASSES || n < 0 || n >= INT32_MAX) return NULL;
    struct rs_grid* g = calloc(1, sizeof(struct rs_grid));
    if (!g) return NULL;
    g->n = n; g->n_classes = n_classes; g->class_of = class_of;
    g->Lx = Lx; g->Ly = Ly; g->z_lo = z_lo; g->margin = margin;
    int64_t members[RS_MAX_CLASSES] = {0};
    for (int64_t i = 0; i < n; i++) members[class_of[i]]++;
    for (int c = 0; c < n_classes; c++) {
        if (rs_class_grid_init(&g->classes[c], members[c], largest[c], Lx, Ly, z_hi - z_lo,
                               margin)) { rs_grid_free(g); return NULL; }
    }
    size_t m = (size_t)(n > 0 ? n : 1);
    int64_t base[RS_MAX_CLASSES + 1] = {0};   /* first sort bin of each class */
    for (int c = 0; c < n_classes; c++)
        base[c + 1] = base[c] + g->classes[c].nx * g->classes[c].ny * g->classes[c].nz;
    g->p = malloc(m * sizeof(struct rs_grid_particle));
    g->slot_of = malloc(m * sizeof(int64_t));
    g->flag = calloc(m, 1);
    int64_t* bin = malloc(m * sizeof(int64_t));    /* sort bin (class and cell) by particle */
    int64_t* start = calloc((size_t)base[n_classes] + 1, sizeof(int64_t));
    if (!g->p || !g->slot_of || !g->flag || !bin || !start) {
        free(bin); free(start); rs_grid_free(g); return NULL;
    }
    for (int64_t i = 0; i < n; i++) {
        bin[i] = base[class_of[i]] + rs_cell_of(g, &g->classes[class_of[i]], x[i], y[i], z[i]);
        start[bin[i] + 1]++;
    }
    for (int64_t b = 0; b < base[n_classes]; b++) start[b + 1] += start[b];
    for (int64_t i = 0; i < n; i++) g->slot_of[i] = start[bin[i]]++;   /* by index in a bin */
    for (int64_t i = 0; i < n; i++) {
        struct rs_grid_particle* q = &g->p[g->slot_of[i]];
        q->x = x[i]; q->y = y[i]; q->z = z[i]; q->r = rad[i];
        q->index = (int32_t)i;
        q->searched = 0;
        q->cell = bin[i] - base[class_of[i]];
    }
    for (int64_t s = n - 1; s >= 0; s--) rs_link(g, s);   /* each cell's list in slot order */
    free(bin); free(start);
    return g;
}

/** Move particles idx[0..k) to their new positions (x, y, z [m] indexed by particle). */
void rs_grid_move(struct rs_grid* g, int64_t k, const int64_t* idx, const double* x,
                  const double* y, const double* z) {
    struct rs_grid_particle* p = g->p;
    for (int64_t l = 0; l < k; l++) {
        int64_t i = idx[l], s = g->slot_of[i];
        const struct rs_class_grid* cg = &g->classes[g->class_of[i]];
        if (p[s].prev >= 0) p[p[s].prev].next = p[s].next;
        else cg->head[p[s].cell] = p[s].next;
        if (p[s].next >= 0) p[p[s].next].prev = p[s].prev;
        p[s].x = x[i]; p[s].y = y[i]; p[s].z = z[i];
        p[s].cell = rs_cell_of(g, cg, x[i], y[i], z[i]);
        rs_link(g, s);
    }
}

/** Cells within `reach` cells of cell index c0 along an axis of n cells: first offset and
 *  count (all n cells once when the range covers a periodic axis). */
static void rs_range(int64_t reach, int64_t n, int periodic, int64_t c0, int64_t* first,
                     int64_t* count) {
    if (periodic && 2 * reach + 1 >= n) { *first = 0; *count = n; return; }
    int64_t lo = c0 - reach, hi = c0 + reach;
    if (!periodic) { lo = lo < 0 ? 0 : lo; hi = hi >= n ? n - 1 : hi; }
    *first = lo;
    *count = hi - lo + 1;
}

/** Test slot s against every slot of class grid cg within reach; `all`: every particle is
 *  searched (else those flagged `searched`); a pair of two searched ones is tested from its
 *  lower index only. */
static void rs_search_class(const struct rs_grid* g, const struct rs_class_grid* cg,
                               int64_t s, int all, struct rs_found* found) {
    const struct rs_grid_particle* p = g->p;
    const struct rs_grid_particle* a = &p[s];
    double reach = (a->r + cg->largest) * (1.0 + g->margin);
    int64_t fx, nx, fy, ny, fz, nz;
    rs_range((int64_t)ceil(reach / cg->wx), cg->nx, 1, rs_cell(a->x, cg->wx, cg->nx), &fx,
             &nx);
    rs_range((int64_t)ceil(reach / cg->wy), cg->ny, 1, rs_cell(a->y, cg->wy, cg->ny), &fy,
             &ny);
    rs_range((int64_t)ceil(reach / cg->wz), cg->nz, 0, rs_cell(a->z - g->z_lo, cg->wz, cg->nz),
             &fz, &nz);
    for (int64_t ix = fx; ix < fx + nx; ix++) {
        int64_t cx = ((ix % cg->nx) + cg->nx) % cg->nx;
        for (int64_t iy = fy; iy < fy + ny; iy++) {
            int64_t cy = ((iy % cg->ny) + cg->ny) % cg->ny;
            const int64_t* column = &cg->head[(cx * cg->ny + cy) * cg->nz];
            for (int64_t cz = fz; cz < fz + nz; cz++) {
                for (int64_t t = column[cz]; t >= 0; t = p[t].next) {
                    const struct rs_grid_particle* b = &p[t];
                    if (t == s || ((all || b->searched) && b->index < a->index)) continue;
                    rs_test_pair(a, b, g->Lx, g->Ly, found);
                }
            }
        }
    }
}

static void rs_search(const struct rs_grid* g, int64_t s, int all, struct rs_found* found) {
    for (int c = 0; c < g->n_classes; c++) rs_search_class(g, &g->classes[c], s, all, found);
}

/**
 * The yielding particle (rs_test_pair) of every overlapping pair with at least one of the
 * k particles idx (all n particles if idx is NULL), each pair tested once, written to
 * out[0..count) (unsorted, each once; out has room for n); returns count, or -1 without
 * memory.  Particle i looks at
 * the cells of class c within r_i + largest[c] (1 + margin).  Particles are searched in the
 * order of their cells (neighbours stay in the cache).
 */
int64_t rs_grid_overlapping(struct rs_grid* g, int64_t k, const int64_t* idx, int64_t* out) {
    struct rs_found found = {g->flag, out, 0};
    if (!idx) {
        for (int64_t s = 0; s < g->n; s++) rs_search(g, s, 1, &found);
        for (int64_t l = 0; l < found.count; l++) g->flag[out[l]] = 0;
        return found.count;
    }
    struct rs_keyed* order = malloc((size_t)(k > 0 ? k : 1) * sizeof(struct rs_keyed));
    if (!order) return -1;
    for (int64_t l = 0; l < k; l++) {   /* searched in the order of their present cells */
        int64_t s = g->slot_of[idx[l]];
        order[l].key = ((int64_t)g->class_of[idx[l]] << 40) + g->p[s].cell;
        order[l].i = s;
        g->p[s].searched = 1;
    }
    qsort(order, (size_t)k, sizeof(struct rs_keyed), rs_compare_keyed);
    for (int64_t l = 0; l < k; l++) rs_search(g, order[l].i, 0, &found);
    for (int64_t l = 0; l < k; l++) g->p[order[l].i].searched = 0;
    free(order);
    for (int64_t l = 0; l < found.count; l++) g->flag[out[l]] = 0;
    return found.count;
}

/* --- overlap count of a time-series output --------------------------------------------- */

/** A deeply overlapping pair, lower index first. */
struct rs_pair {
    int64_t i, j;
};

/** The deep pairs found so far (a growing array; duplicates are removed at the end). */
struct rs_deep {
    struct rs_pair* pairs;
    int64_t count, capacity;
    int failed;   /* 1: no memory */
};

static void rs_deep_add(struct rs_deep* deep, int64_t i, int64_t j) {
    if (deep->count == deep->capacity) {
        int64_t capacity = deep->capacity ? 2 * deep->capacity : 64;
        struct rs_pair* grown = realloc(deep->pairs, (size_t)capacity * sizeof(struct rs_pair));
        if (!grown) { deep->failed = 1; return; }
        deep->pairs = grown;
        deep->capacity = capacity;
    }
    deep->pairs[deep->count].i = i;
    deep->pairs[deep->count].j = j;
    deep->count++;
}

static int rs_compare_pairs(const void* a, const void* b) {
    const struct rs_pair* pa = a;
    const struct rs_pair* pb = b;
    if (pa->i != pb->i) return pa->i < pb->i ? -1 : 1;
    return pa->j < pb->j ? -1 : (pa->j > pb->j ? 1 : 0);
}

/** What the overlap count reads beside the grid: the caller's positions and radii (the
 *  exact test uses them as they are), the box, the shear offset and the depth. */
struct rs_overlap_query {
    const double *x, *y, *z, *rad;   /* [m], by particle index */
    double Lx, Ly;                   /* box [m] */
    double shift;                    /* shear offset 1.5 Omega Lx t [m], as given */
    double shift_wrapped;            /* the same in [0, Ly) [m], to choose cells */
    double fraction;                 /* depth counted, of the smaller radius */
    double tolerance;                /* [m]: the grid's copies are within this of exact */
};

/** The exact test of ringsim.testing.count_overlaps_numpy for particles i < j, j seen as
 *  its image w (0: itself; +1: at x + Lx, y - shift; -1: at x - Lx, y + shift), with the
 *  same operations in the same order (no contraction: -ffp-contract=off). */
static int rs_deep_pair(const struct rs_overlap_query* q, int64_t i, int64_t j, int w) {
    double bx = q->x[j], by = q->y[j];
    if (w > 0) { bx = bx + q->Lx; by = by - q->shift; }
    if (w < 0) { bx = bx - q->Lx; by = by + q->shift; }
    double dx = q->x[i] - bx;
    double dy = q->y[i] - by;
    double dz = q->z[i] - q->z[j];
    dy -= q->Ly * nearbyint(dy / q->Ly);
    double dist = sqrt(dx * dx + dy * dy + dz * dz);
    double ri = q->rad[i], rj = q->rad[j];
    return ri + rj - dist > q->fraction * (ri < rj ? ri : rj);
}

/** Test slot s's particle a against particle b of a class at least a's, b seen as its
 *  image w (see rs_deep_pair), on the grid's copies (x + Lx/2, y in [0, Ly)) with
 *  `tolerance` to spare; rs_deep_pair decides, with the lower index first. */
static void rs_overlap_candidate(const struct rs_grid_particle* a,
                                 const struct rs_grid_particle* b, int w, double bx_offset,
                                 double by_offset, const struct rs_overlap_query* q,
                                 struct rs_deep* deep) {
    double limit = a->r + b->r - q->fraction * (a->r < b->r ? a->r : b->r) + q->tolerance;
    double dz = a->z - b->z;
    if (limit <= 0.0 || dz * dz >= limit * limit) return;
    double dx = a->x - (b->x + bx_offset);
    double dy = a->y - (b->y + by_offset);   /* by_offset in [-Ly/2, Ly/2]: one wrap */
    dy += dy > 0.5 * q->Ly ? -q->Ly : (dy < -0.5 * q->Ly ? q->Ly : 0.0);
    if (dx * dx + dy * dy + dz * dz >= limit * limit) return;
    int deep_pair = a->index < b->index ? rs_deep_pair(q, a->index, b->index, w)
                                        : rs_deep_pair(q, b->index, a->index, -w);
    if (deep_pair) rs_deep_add(deep, a->index < b->index ? a->index : b->index,
                               a->index < b->index ? b->index : a->index);
}

/** Pairs of slot s with the particles of class grid cg (of its own class only those in later
 *  slots: a pair and its mirror image are found from both sides), each image w of the
 *  partner in the cells where it can be within reach.  The slots of a class are sorted by
 *  cell, so the cells of a column (x and y cell, the heights in reach) are one run of
 *  slots, read in order from first[cell]: no list to follow. */
static void rs_overlaps_class(const struct rs_grid* g, const struct rs_class_grid* cg,
                              const int64_t* first, int64_t s, int same_class,
                              const struct rs_overlap_query* q, struct rs_deep* deep) {
    const struct rs_grid_particle* p = g->p;
    const struct rs_grid_particle* a = &p[s];
    double reach = a->r + cg->largest + q->tolerance;
    int64_t kx = (int64_t)ceil(reach / cg->wx), c0 = rs_cell(a->x, cg->wx, cg->nx);
    int64_t ky = (int64_t)ceil(reach / cg->wy);
    int64_t fz, nz;
    rs_range((int64_t)ceil(reach / cg->wz), cg->nz, 0, rs_cell(a->z - g->z_lo, cg->wz, cg->nz),
             &fz, &nz);
    for (int64_t ix = c0 - kx; ix <= c0 + kx; ix++) {
        int w = ix < 0 ? -1 : (ix >= cg->nx ? 1 : 0);
        int64_t cx = ix - w * cg->nx;
        if (cx < 0 || cx >= cg->nx) continue;   /* a second image: never within reach */
        double bx_offset = w * q->Lx, by_offset = -w * q->shift_wrapped;
        by_offset += by_offset > 0.5 * q->Ly ? -q->Ly : (by_offset < -0.5 * q->Ly ? q->Ly : 0.0);
        double yc = a->y - by_offset;   /* where the partner's copy must be */
        yc -= q->Ly * floor(yc / q->Ly);
        int64_t fy, ny;
        rs_range(ky, cg->ny, 1, rs_cell(yc, cg->wy, cg->ny), &fy, &ny);
        for (int64_t iy = fy; iy < fy + ny; iy++) {
            int64_t cy = iy < 0 ? iy + cg->ny : (iy >= cg->ny ? iy - cg->ny : iy);
            int64_t cell = (cx * cg->ny + cy) * cg->nz + fz;
            int64_t t = first[cell], end = first[cell + nz];
            if (same_class && t <= s) t = s + 1;
            for (; t < end; t++) rs_overlap_candidate(a, &p[t], w, bx_offset, by_offset, q, deep);
        }
    }
}

/** first[c][cell]: the first slot of each cell of class c (and one past the class's last
 *  slot at n_cells), from the grid's slots sorted by class and cell; NULL without memory. */
static int64_t** rs_cell_starts(const struct rs_grid* g) {
    int64_t** first = calloc((size_t)g->n_classes, sizeof(int64_t*));
    if (!first) return NULL;
    int64_t s = 0;
    for (int c = 0; c < g->n_classes; c++) {
        const struct rs_class_grid* cg = &g->classes[c];
        int64_t n_cells = cg->nx * cg->ny * cg->nz;
        first[c] = malloc((size_t)(n_cells + 1) * sizeof(int64_t));
        if (!first[c]) {
            for (int k = 0; k < c; k++) free(first[k]);
            free(first);
            return NULL;
        }
        for (int64_t cell = 0; cell <= n_cells; cell++) {
            while (s < g->n && g->class_of[g->p[s].index] == c && g->p[s].cell < cell) s++;
            first[c][cell] = s;
        }
    }
    return first;
}

/**
 * Pairs of the n particles (positions x, y, z [m] centred on the box, radii rad [m]) that
 * overlap by more than `fraction` of the smaller radius, each physical pair once: periodic
 * in y (Ly [m]); across the radial boundary the partner's image at x +- Lx is shifted in y
 * by -+ shift [m] (1.5 Omega Lx t: the shear flow carries the neighbouring boxes along); not
 * periodic in z.  The same count as ringsim.testing.count_overlaps_numpy (positions in the
 * box, as REBOUND keeps them at the end of a step).  Searched on the placement's grids of
 * cells per radius class (here radii within a factor 4 a class), each particle looking at
 * the cells of its own and the larger classes within its radius plus the class's largest
 * radius.  Returns the count, or -1 without memory.
 */
int64_t rs_count_overlaps(int64_t n, const double* x, const double* y, const double* z,
                          const double* rad, double Lx, double Ly, double shift,
                          double fraction, int threads) {
    if (n < 2) return 0;
    double r_min = rad[0], r_max = rad[0], z_lo = z[0], z_hi = z[0];
    for (int64_t i = 1; i < n; i++) {
        r_min = rad[i] < r_min ? rad[i] : r_min;
        r_max = rad[i] > r_max ? rad[i] : r_max;
        z_lo = z[i] < z_lo ? z[i] : z_lo;
        z_hi = z[i] > z_hi ? z[i] : z_hi;
    }
    int32_t* class_of = malloc((size_t)n * sizeof(int32_t));
    double* gx = malloc((size_t)n * sizeof(double));
    double* gy = malloc((size_t)n * sizeof(double));
    if (!class_of || !gx || !gy) { free(class_of); free(gx); free(gy); return -1; }
    /* classes: radii within a factor 4 (the last class takes any beyond 4^31), wider than
     * the placement's factor 2, which makes the count slower (docs/performance.md,
     * "Per-output work") */
    int32_t label_top = 0;
    for (int64_t i = 0; i < n; i++) {
        double octaves = r_min > 0.0 ? floor(0.5 * log2(rad[i] / r_min)) : 0.0;
        class_of[i] = octaves < RS_MAX_CLASSES - 1 ? (int32_t)octaves : RS_MAX_CLASSES - 1;
        label_top = class_of[i] > label_top ? class_of[i] : label_top;
        gx[i] = x[i] + 0.5 * Lx;
        gy[i] = y[i] + 0.5 * Ly;
        gy[i] -= Ly * floor(gy[i] / Ly);
    }
    double largest[RS_MAX_CLASSES] = {0.0};
    for (int64_t i = 0; i < n; i++)
        largest[class_of[i]] = rad[i] > largest[class_of[i]] ? rad[i] : largest[class_of[i]];
    for (int c = 0; c <= label_top; c++)    /* an empty class: no neighbours, small cells */
        if (!(largest[c] > 0.0)) largest[c] = r_max > 0.0 ? r_max : 1.0;
    struct rs_overlap_query q = {x, y, z, rad, Lx, Ly, shift, 0.0, fraction, 0.0};
    q.shift_wrapped = shift - Ly * floor(shift / Ly);
    /* copies and the exact image coordinates differ by rounding of values up to this */
    q.tolerance = 1e-9 * (Lx + Ly + fabs(shift) + (z_hi - z_lo) + r_max);
    struct rs_grid* g = rs_grid_create(n, label_top + 1, class_of, largest, Lx, Ly, z_lo,
                                       z_hi, 0.0, gx, gy, z, rad);
    free(gx); free(gy);
    int64_t** first = g ? rs_cell_starts(g) : NULL;
    if (!first) { rs_grid_free(g); free(class_of); return -1; }
    struct rs_deep deep = {NULL, 0, 0, 0};
    const int team = threads > 1 && n >= RS_OVERLAP_PARTICLES_PER_THREAD
        ? (int)(n / RS_OVERLAP_PARTICLES_PER_THREAD < threads
                ? n / RS_OVERLAP_PARTICLES_PER_THREAD : threads)
        : 1;
    (void)team;
#pragma omp parallel num_threads(team)
    {
        struct rs_deep local = {NULL, 0, 0, 0};
#pragma omp for schedule(static)
        for (int64_t s = 0; s < n; s++) {   /* a pair from the particle of the smaller class */
            int own = class_of[g->p[s].index];
            for (int c = own; c < g->n_classes; c++)
                rs_overlaps_class(g, &g->classes[c], first[c], s, c == own, &q, &local);
        }
#pragma omp critical(rs_count_overlaps_join)
        {   /* any order: the pairs are sorted below */
            deep.failed |= local.failed;
            for (int64_t k = 0; k < local.count && !deep.failed; k++)
                rs_deep_add(&deep, local.pairs[k].i, local.pairs[k].j);
        }
        free(local.pairs);
    }
    for (int c = 0; c < g->n_classes; c++) free(first[c]);
    free(first);
    rs_grid_free(g);
    free(class_of);
    if (deep.failed) { free(deep.pairs); return -1; }
    qsort(deep.pairs, (size_t)deep.count, sizeof(struct rs_pair), rs_compare_pairs);
    int64_t unique = 0;
    for (int64_t k = 0; k < deep.count; k++)
        if (k == 0 || rs_compare_pairs(&deep.pairs[k], &deep.pairs[k - 1])) unique++;
    free(deep.pairs);
    return unique;
}
