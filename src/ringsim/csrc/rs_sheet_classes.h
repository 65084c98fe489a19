/**
 * @file    rs_sheet_classes.h
 * @brief   The cell grids of the sheet detector (rs_sheet_detect.c): one grid of all
 *          particles, or a grid per reach class (rs_sheet_classes.c, Method 2a).
 */
#ifndef RS_SHEET_CLASSES_H
#define RS_SHEET_CLASSES_H

#include <float.h>
#include <math.h>
#include <stdint.h>

/* Cells per particle at most (the z range of a few outliers must not blow the grid up). */
#define RS_CELLS_PER_PARTICLE 4
/* Reach classes at most (Method 2a). */
#define RS_MAX_CLASSES 8

/* What the search's first test reads of a particle, in cell order (d->points) and in index
 * order (d->wrapped): 40 bytes instead of the 128 of rs_sheet_particle, so that the cells
 * around a particle stay in the cache. */
struct rs_sheet_point {
    double xw, yw, z;       /* [m] position wrapped into the primary box */
    double reach;           /* [m] */
    int64_t index;          /* in r->particles */
};

/* The cells of one reach class (Method 2a; the one grid of all particles without classes):
 * its cells are d->cell_start[cell_base ...], its particles consecutive in d->points. */
struct rs_cell_grid {
    double sx, sy, sz;      /* [m] cell sides (sz infinite with one layer) */
    double ix, iy, iz;      /* [1/m] their inverses (iz 0 with one layer) */
    double z_min;           /* [m] bottom of the lowest layer */
    double z_range;         /* [m] height of the class's range */
    double reach_max;       /* [m] largest reach in the class */
    int64_t nx, ny, nz;
    int64_t cell_base;      /* index of its first cell in d->cell_start */
    int64_t n;              /* particles */
    double side;            /* [m] least side of a cell */
    int half_shell;         /* 1: each pair of the class in one box looked at from one side */
};

/* Cells a search over `distance` [m] must look at on each side along a side of `side` [m]. */
static inline int64_t rs_sheet_span(double distance, double side){
    const double cells = ceil(distance / side);
    return cells >= 1.0 ? (cells < 1e9 ? (int64_t)cells : 1000000000) : 1;
}

/* s of Method 1 for particles of reaches up to reach_max [m] in a step of shear drift
 * shear_step = 1.5 |Omega| dt: the largest distance [m] at which two of them can touch
 * within the step. */
static inline double rs_sheet_pair_reach(double reach_max, double shear_step){
    const double s = 2.0 * reach_max / (1.0 - shear_step);
    return s * (1.0 + 1e-12) + DBL_MIN;
}

/* The cell [0, n) of coordinate u [m] along an axis of cells of 1 / inverse [m] from low
 * [m] (clamped at the ends; NaN: 0). */
static inline int64_t rs_cell_coordinate(double u, double low, double inverse, int64_t n){
    const double c = floor((u - low) * inverse);
    if (!(c >= 0.0)){
        return 0;       /* also NaN */
    }
    return c >= (double)n ? n - 1 : (int64_t)c;
}

int64_t rs_sheet_cell_layout(struct rs_cell_grid* c, double Lx, double Ly, double slack,
                             double s, double side);
int rs_sheet_classify(const struct rs_sheet_point* wrapped, int64_t n, int threads,
                      double reach_max, int classes, uint8_t* class_of,
                      struct rs_cell_grid* cells);
int64_t rs_sheet_class_layout(struct rs_cell_grid* cells, int classes, double Lx, double Ly,
                              double slack, double shear_step, double reach_max,
                              struct rs_cell_grid* one, double one_side);
void rs_sheet_counting_sort(const struct rs_sheet_point* wrapped, struct rs_sheet_point* points,
                            int64_t n, int asked, const struct rs_cell_grid* cells,
                            const uint8_t* class_of, double Lx, double Ly, int32_t* counts,
                            int32_t* cell_of, int32_t* start, int64_t n_cells);

#endif
