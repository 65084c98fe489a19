/**
 * @file    rs_sheet_classes.c
 * @brief   The cell grids of the sheet detector (rs_sheet_detect.c, Method 2 and 2a):
 *          the layout of one grid, the sorting of the particles into reach classes, each
 *          with a grid of its own, and the counting sort of the particles into the cells
 *          (ringsim).
 *
 * Why
 * ---
 * One grid has cells set by the largest reach, and every particle looks at the cells within
 * its own reach plus the largest one.  In a ring of centimetre-to-metre particles (q = 3)
 * almost all particles are small, and each of them then looks at hundreds of small
 * neighbours it cannot touch.  In reach classes, each with cells set by its own largest
 * reach, a particle looks into its own class's grid and the grids of the larger classes,
 * each over its own reach plus that class's largest (the multilevel search of Ogarko &
 * Luding 2012, Comput. Phys. Commun. 183, 931, as rs_setup.c's rs_count_overlaps does for
 * the set-up's overlaps).
 *
 * Method
 * ------
 * - Class k holds the reaches in (rho_max / RS_CLASS_RATIO^(k+1), rho_max / RS_CLASS_RATIO^k]
 *   (rho_max: the largest reach of the step), the last class all reaches below; classes
 *   that hold no particle get one empty cell.
 * - Class k's cells are at least (rho_max,k + rho_below) / (1 - 1.5 Omega dt) on a side
 *   (rho_max,k: its largest reach, rho_below: the largest reach a smaller class may hold),
 *   just wider than the search from a smaller class into it, so that such a search looks
 *   at three cells along each side; s_k / RS_NARROW_DIVISIONS where the box is too narrow
 *   for the half shell with those; at most RS_CELLS_PER_PARTICLE per particle.
 * - The classes are used only where they pay: where the search's estimated cost with them
 *   (rs_layout_cost: the particles and the rows of cells it looks at, each particle with
 *   its class's typical reach, in uniformly filled grids) is below the one grid's (else
 *   the rows looked at in several grids cost more than the neighbours a finer grid
 *   spares), and only if each class's grid is wider than two spans of the widest search
 *   into it (Method 3's half shell: then a pair is in reach through one image only,
 *   whatever the grid's cells).
 * - The pairs found do not depend on the grids (the search is complete in any grid and the
 *   reports are an exact set), so neither does any result, except after a re-check cut
 *   at RS_MAX_SPAN s or reaching beyond half the box: that looks at whole cells, which
 *   differ between the layouts (rs_sheet_detect.c, "Validity limits"; counted as
 *   span_limited).
 *
 * No global mutable state.
 */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include "rs_sheet_classes.h"
#ifdef _OPENMP
#include <omp.h>
#endif

/* Particles ahead whose cache lines the counting sort asks for (rs_sheet_counting_sort). */
#define RS_SORT_AHEAD 16
/* Ratio of the largest reaches of neighbouring classes. */
#ifndef RS_CLASS_RATIO
#define RS_CLASS_RATIO 4.0
#endif
/* Cells per s_k of a class grid in a box too narrow for the half shell with the wider
 * cells (as the one grid's RS_CELL_DIVISIONS). */
#define RS_NARROW_DIVISIONS 4
/* Particles tested that one row of cells costs as much as, in the estimate of a layout's
 * cost (rs_layout_cost): chosen so that the estimate picks the layout that was measured
 * faster in every sheet measured (docs/performance.md, "The detector's choice of classes
 * by estimated cost"). */
#ifndef RS_ROW_COST
#define RS_ROW_COST 8.0
#endif

/* The cells of grid c (its reach_max, z_min, z_range and n set) in a box of Lx x Ly [m]:
 * cells of at least `side` [m] on each side, at most RS_CELLS_PER_PARTICLE per particle;
 * whether its pairs can be looked at from one side (Method 3's half shell: a box wider
 * than two spans of the widest search into the grid, s [m], widened by slack [m]).
 * Returns the number of cells. */
int64_t rs_sheet_cell_layout(struct rs_cell_grid* c, double Lx, double Ly, double slack,
                             double s, double side){
    c->side = side;
    const int64_t cell_cap = RS_CELLS_PER_PARTICLE * c->n + 64;
    int64_t nx = Lx / side >= (double)cell_cap ? cell_cap : (int64_t)floor(Lx / side);
    int64_t ny = Ly / side >= (double)cell_cap ? cell_cap : (int64_t)floor(Ly / side);
    nx = nx < 1 ? 1 : nx;
    ny = ny < 1 ? 1 : ny;
    while (nx * ny > cell_cap){
        nx = nx > 1 ? (nx + 1) / 2 : 1;
        ny = ny > 1 ? (ny + 1) / 2 : 1;
    }
    const double z_range = c->z_range;
    int64_t nz = z_range / side >= (double)cell_cap ? cell_cap
                                                    : (int64_t)floor(z_range / side) + 1;
    if (nx * ny * nz > cell_cap){
        nz = cell_cap / (nx * ny);
        nz = nz < 1 ? 1 : nz;
    }
    c->nx = nx;
    c->ny = ny;
    c->nz = nz;
    c->sx = Lx / (double)nx;
    c->sy = Ly / (double)ny;
    c->sz = nz > 1 ? fmax(side, z_range / (double)(nz - 1) * (1.0 + 1e-12)) : INFINITY;
    c->ix = 1.0 / c->sx;
    c->iy = 1.0 / c->sy;
    c->iz = nz > 1 ? 1.0 / c->sz : 0.0;
    const double widest = s * (1.0 + 1e-12) + slack;
    const int64_t span_x = rs_sheet_span(widest, c->sx);
    const int64_t span_y = rs_sheet_span(widest, c->sy);
    const int64_t span = span_x > span_y ? span_x : span_y;
    c->half_shell = nx >= 2 * span + 1 && ny >= 2 * span + 1;
    return nx * ny * nz;
}

/* Each of the n particles' reach class (class_of, by index; `wrapped`: their points, by
 * index; reach_max [m]: the largest reach) and each class's particles, largest reach and
 * vertical range (cells[0 .. classes - 1]), on `threads` OpenMP threads.  The threads'
 * shares are merged by sums, maxima and minima: the same result on any number of
 * threads.  Returns the number of classes that hold particles. */
int rs_sheet_classify(const struct rs_sheet_point* wrapped, int64_t n, int threads,
                      double reach_max, int classes, uint8_t* class_of,
                      struct rs_cell_grid* cells){
    double limit[RS_MAX_CLASSES];
    limit[0] = reach_max / RS_CLASS_RATIO;
    for (int k = 1; k < classes; k++){
        limit[k] = limit[k - 1] / RS_CLASS_RATIO;
    }
    limit[classes - 1] = -INFINITY;
    for (int k = 0; k < classes; k++){
        cells[k] = (struct rs_cell_grid){.z_min = INFINITY, .z_range = -INFINITY};
    }
#pragma omp parallel num_threads(threads)
    {
        int64_t count[RS_MAX_CLASSES] = {0};
        double top[RS_MAX_CLASSES], low[RS_MAX_CLASSES], high[RS_MAX_CLASSES];
        for (int k = 0; k < classes; k++){
            top[k] = 0.0;
            low[k] = INFINITY;
            high[k] = -INFINITY;
        }
#pragma omp for schedule(static)
        for (int64_t i = 0; i < n; i++){
            const struct rs_sheet_point* q = &wrapped[i];
            int k = 0;
            while (q->reach <= limit[k]){
                k++;
            }
            class_of[i] = (uint8_t)k;
            count[k]++;
            top[k] = fmax(top[k], q->reach);
            low[k] = fmin(low[k], q->z);
            high[k] = fmax(high[k], q->z);
        }
#pragma omp critical (rs_sheet_classify_merge)
        for (int k = 0; k < classes; k++){
            struct rs_cell_grid* c = &cells[k];
            c->n += count[k];
            c->reach_max = fmax(c->reach_max, top[k]);
            c->z_min = fmin(c->z_min, low[k]);
            c->z_range = fmax(c->z_range, high[k]);    /* the top, until below */
        }
    }
    int used = 0;
    for (int k = 0; k < classes; k++){
        struct rs_cell_grid* c = &cells[k];
        c->z_range = c->n > 0 ? c->z_range - c->z_min : 0.0;
        c->z_min = c->n > 0 ? c->z_min : 0.0;
        used += c->n > 0;
    }
    return used;
}

/* The estimated cost of one search over `distance` [m] into grid c (uniformly filled):
 * the particles of the cells it looks at plus RS_ROW_COST per row of cells, halved for
 * Method 3's half shell. */
static double rs_look_cost(const struct rs_cell_grid* c, double distance, int half){
    const double x = fmin(2.0 * (double)rs_sheet_span(distance, c->sx) + 1.0, (double)c->nx);
    const double y = fmin(2.0 * (double)rs_sheet_span(distance, c->sy) + 1.0, (double)c->ny);
    const double z = c->nz > 1
        ? fmin(2.0 * (double)rs_sheet_span(distance, c->sz) + 1.0, (double)c->nz) : 1.0;
    const double cells = (double)c->nx * (double)c->ny * (double)c->nz;
    const double cost = x * y * z * (double)c->n / cells + RS_ROW_COST * y * z;
    return half && c->half_shell ? 0.5 * cost : cost;
}

/* The estimated cost of the search of every particle: in the class grids
 * cells[0 .. classes - 1] (one NULL), or in the one grid `one` (the class grids then give
 * only how many particles reach how far).  Each particle of class k is taken to search with
 * half its class's largest reach, an assumption of the estimate (rs_search_from uses each
 * particle's own reach; the last class holds every smaller reach).  A cost only: it
 * decides the layout, never a pair. */
static double rs_layout_cost(const struct rs_cell_grid* cells, int classes,
                             const struct rs_cell_grid* one, double shear_step){
    double cost = 0.0;
    for (int i = 0; i < classes; i++){
        const struct rs_cell_grid* ci = &cells[i];
        if (ci->n == 0){
            continue;
        }
        const double reach = 0.5 * ci->reach_max;
        if (one != NULL){
            cost += (double)ci->n * rs_look_cost(one, (reach + one->reach_max)
                                                 / (1.0 - shear_step), 1);
            continue;
        }
        for (int j = 0; j <= i; j++){
            const struct rs_cell_grid* cj = &cells[j];
            if (cj->n > 0){
                cost += (double)ci->n * rs_look_cost(cj, (reach + cj->reach_max)
                                                     / (1.0 - shear_step), j == i);
            }
        }
    }
    return cost;
}

/* The grids of the classes rs_sheet_classify filled (cells[0 .. classes - 1]; box Lx x Ly
 * [m], slack [m] of the pre-test, shear_step = 1.5 |Omega| dt, reach_max [m]), their cells
 * numbered one after the other (cell_base), against the one grid of all the particles
 * (`one`: n, z_min, z_range and reach_max set; cells of at least one_side [m]; laid out
 * here).  Returns the number of cells of all classes, 0 if the classes do not pay (their
 * estimated search cost, rs_layout_cost, is not below the one grid's) or a class grid is
 * too narrow for its half shell (see the Method above). */
int64_t rs_sheet_class_layout(struct rs_cell_grid* cells, int classes, double Lx, double Ly,
                              double slack, double shear_step, double reach_max,
                              struct rs_cell_grid* one, double one_side){
    rs_sheet_cell_layout(one, Lx, Ly, slack, rs_sheet_pair_reach(reach_max, shear_step),
                         one_side);
    int64_t n_cells = 0;
    double below = reach_max;
    for (int k = 0; k < classes; k++){
        struct rs_cell_grid* c = &cells[k];
        c->cell_base = n_cells;
        below = k + 1 < classes ? below / RS_CLASS_RATIO : 0.0;
        if (c->n == 0){
            c->nx = c->ny = c->nz = 1;
            c->half_shell = 1;
            n_cells += 1;
            continue;
        }
        /* just wider than the search from a smaller class (reaches <= below) */
        const double side = ((c->reach_max + below) / (1.0 - shear_step) * (1.0 + 1e-12)
                             + slack) * (1.0 + 1e-9);
        const double s = rs_sheet_pair_reach(c->reach_max, shear_step);
        int64_t here = rs_sheet_cell_layout(c, Lx, Ly, slack, s, side);
        if (!c->half_shell){
            /* a narrow box: the finer cells of one grid need less width for the half shell */
            here = rs_sheet_cell_layout(c, Lx, Ly, slack, s, s / RS_NARROW_DIVISIONS);
        }
        if (!c->half_shell){
            return 0;
        }
        n_cells += here;
    }
    const double with_classes = rs_layout_cost(cells, classes, NULL, shear_step);
    return with_classes < rs_layout_cost(cells, classes, one, shear_step) ? n_cells : 0;
}

/* The counting sort of the n particles (`wrapped`, by index) into the cells of `cells`
 * (one grid, or a grid per class with class_of their classes; NULL: one grid, cells[0]):
 * `points` in cell order and `start`, each cell's first slot (n_cells + 1 entries), on
 * `asked` OpenMP threads (box Lx x Ly [m]; work space: counts, asked (n_cells + 1) of
 * them, and cell_of, n).  Stable: a cell holds its particles in index order, whatever the
 * number of threads.  Thread t of T counts the particles of its share [n t / T,
 * n (t + 1) / T) per cell; the slots of cell c are then handed out cell after cell and,
 * within a cell, share after share (each thread does this for its share of the cells after
 * the totals of the shares before it are known); last, each thread places its particles
 * in index order.  So the order is the serial sort's: same seed, same bits with 1 and 2
 * threads. */
void rs_sheet_counting_sort(const struct rs_sheet_point* wrapped, struct rs_sheet_point* points,
                            int64_t n, int asked, const struct rs_cell_grid* cells,
                            const uint8_t* class_of, double Lx, double Ly, int32_t* counts,
                            int32_t* cell_of, int32_t* start, int64_t n_cells){
#pragma omp parallel num_threads(asked)
    {
#ifdef _OPENMP
        const int64_t team = omp_get_num_threads();
        const int64_t t = omp_get_thread_num();
#else
        const int64_t team = 1;
        const int64_t t = 0;
#endif
        const int64_t i0 = n * t / team, i1 = n * (t + 1) / team;
        const int64_t c0 = n_cells * t / team, c1 = n_cells * (t + 1) / team;
        int32_t* const mine = counts + t * n_cells;
        int32_t* const totals = counts + team * n_cells;   /* one per share of the cells */
        memset(mine, 0, (size_t)n_cells * sizeof(int32_t));
        for (int64_t i = i0; i < i1; i++){
            const struct rs_sheet_point* q = &wrapped[i];
            const struct rs_cell_grid* c = &cells[class_of != NULL ? class_of[i] : 0];
            const int64_t cx = rs_cell_coordinate(q->xw, -0.5 * Lx, c->ix, c->nx);
            const int64_t cy = rs_cell_coordinate(q->yw, -0.5 * Ly, c->iy, c->ny);
            const int64_t cz = c->nz > 1 ? rs_cell_coordinate(q->z, c->z_min, c->iz, c->nz)
                                         : 0;
            cell_of[i] = (int32_t)(c->cell_base + (cz * c->ny + cy) * c->nx + cx);
        }
        /* the counts and slots are read at random (particles in index order are scattered
         * over the sheet): their cache lines are asked for RS_SORT_AHEAD particles ahead */
        for (int64_t i = i0; i < i1; i++){
            if (i + RS_SORT_AHEAD < i1){
                __builtin_prefetch(&mine[cell_of[i + RS_SORT_AHEAD]], 1);
            }
            mine[cell_of[i]]++;
        }
#pragma omp barrier
        int64_t total = 0;
        for (int64_t c = c0; c < c1; c++){
            for (int64_t k = 0; k < team; k++){
                total += counts[k * n_cells + c];
            }
        }
        totals[t] = (int32_t)total;
#pragma omp barrier
        int64_t slot = 0;
        for (int64_t k = 0; k < t; k++){
            slot += totals[k];
        }
        for (int64_t c = c0; c < c1; c++){
            start[c] = (int32_t)slot;
            for (int64_t k = 0; k < team; k++){
                const int64_t here = counts[k * n_cells + c];
                counts[k * n_cells + c] = (int32_t)slot;    /* share k's next slot in c */
                slot += here;
            }
        }
#pragma omp barrier
        for (int64_t i = i0; i < i1; i++){
            if (i + RS_SORT_AHEAD < i1){
                const int32_t ahead = mine[cell_of[i + RS_SORT_AHEAD]];
                __builtin_prefetch(&points[ahead], 1);
                __builtin_prefetch(&mine[cell_of[i + 2 * RS_SORT_AHEAD < i1
                                                 ? i + 2 * RS_SORT_AHEAD : i]], 1);
            }
            points[mine[cell_of[i]]++] = wrapped[i];
        }
    }
    start[n_cells] = (int32_t)n;
}
