/**
 * @file    rs_sheet_detect.c
 * @brief   Swept-sphere collision detection for REBOUND shearing sheets, with contact-time
 *          resolution by rs_resolver.c (ringsim, issue 7).
 *
 * Effect          finds every pair whose straight relative path over the last time step
 *                 came within the sum of the radii, in a shear-periodic box
 * Implementation  ringsim developers
 * Compiled for    REBOUND 5.2.2 (struct reb_simulation as in its rebound.h)
 * Replaces        REBOUND's `linetree` search in ringsim's `line` mode
 *
 * Why
 * ---
 * REBOUND's linetree widens every search by dt times the largest ABSOLUTE speed of any
 * particle.  In a shearing sheet that speed is the shear flow at the box edge, 1.5 Omega
 * Lx / 2, so the search volume grows with the box and the cost per particle-step with N
 * (measured: 1.4 us at N = 1e3, 9.3 us at N = 1e5; docs/performance.md).  Here particles are
 * binned in the shear frame and every search is widened only by the speeds relative to the
 * local shear flow, so the cost per particle-step stays flat in N.
 *
 * Method (one call per step, as REBOUND's post_timestep_modifications)
 * --------------------------------------------------------------------
 * 1. Each particle i gets its speed relative to the local shear flow,
 *        w_i = |(vx, vy + 1.5 Omega x, vz)|,
 *    and its reach rho_i = R_i + dt w_i (dt = dt_last_done).  A pair (i, j) with end-of-step
 *    separation dr and relative velocity dv = w_i - w_j - 1.5 Omega dx e_y can touch within
 *    the step only if |dr| <= rho_i + rho_j + 1.5 Omega dt |dx|  (exact bound), hence only
 *    if |dr| <= 2 max(rho) / (1 - 1.5 Omega dt) = s.
 * 2. Particles, wrapped into the primary box as REBOUND's shear boundary would wrap them
 *    (x - m Lx, y + m a, vy + 1.5 m Omega Lx with a = 1.5 Omega Lx t mod Ly), are sorted
 *    into a grid of cells of at least s on each side (x, y over the box; z over the
 *    particles' range, not periodic), by a counting sort: O(N) per step.
 * 3. Each particle looks at the 27 cells around it.  Across the radial boundary the
 *    neighbouring column belongs to a ghost box sliding along y, so the particle's image
 *    is moved into that box's frame (x -+ Lx, y +- a, vy +- 1.5 Omega Lx, as REBOUND's
 *    reb_boundary_get_ghostbox) before its y cell is computed.  Only j > i is examined, so
 *    each pair is seen once; every (cell, image) combination is distinct, and when the
 *    box is at least 2 s wide at most one image of a pair can be within reach.
 * 4. A candidate is reported (struct reb_collision, gb = ghost-box offset of p1 relative to
 *    the particles' current, unwrapped coordinates) if the closest approach of its straight
 *    relative path over [t - dt, t] is <= R_i + R_j: REBOUND's linetree criterion.
 * 5. The reports are shuffled with rand_r(&r->rand_seed), as REBOUND shuffles its own,
 *    and resolved by rs_resolve_pair(..., swept = 1): first contact on the path, impulse
 *    of the restitution law there, both particles moved on with their new velocities.
 *
 * Parameters: none beyond the simulation's (box, OMEGA, boundary, dt_last_done, t,
 * rand_seed) and the resolver's.  Counters (rs_sheet_detector_counters): steps,
 * candidates (pairs whose path was tested), reports, cells and cell size of the last step.
 *
 * Validity limits
 * ---------------
 * - Paths are straight lines with the end-of-step velocities (epicyclic curvature ignored):
 *   valid for Omega dt << 1; 1.5 Omega dt < 0.5 is required (else the step is refused).
 * - Boundaries: shear (needs OMEGA) or periodic; z is never periodic here (REBOUND's box is
 *   periodic in z, ringsim's vertical guard keeps particles far from it).
 * - The box should be at least 2 s wide in x and y.  If not, several images of one pair
 *   may be in reach; they are reported like REBOUND's ghost boxes and the resolver
 *   resolves the pair once per step.
 * - Pairs are found on the paths at the START of the resolution; a particle deflected by
 *   one collision into a third particle within the same step is found in the next step
 *   (as with REBOUND's linetree).  Keep several encounters per particle per step rare:
 *   see multi_encounters in the resolver statistics.
 * - Particles outside the box (not yet wrapped: detection runs before REBOUND's boundary
 *   check) are handled through their wrap offsets; the particles are not moved.
 *
 * No global mutable state: the work space lives in the resolver struct of the simulation.
 */
#define _POSIX_C_SOURCE 200809L     /* rand_r */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "rebound.h"
#include "rs_resolver.h"

/* Error codes of rs_sheet_find_pairs (also in ringsim/resolver.py). */
#define RS_DETECT_OK 0
#define RS_DETECT_NO_MEMORY 1
#define RS_DETECT_BAD_BOUNDARY 2
#define RS_DETECT_STEP_TOO_LONG 3

/* Largest 1.5 Omega dt accepted: the straight-path approximation needs Omega dt << 1. */
#define RS_MAX_SHEAR_STEP 0.5
/* Cells per particle at most (the z range of a few outliers must not blow the grid up). */
#define RS_CELLS_PER_PARTICLE 4

struct rs_sheet_particle {
    double x, y, z;         /* [m] current position */
    double vx, vy, vz;      /* [m/s] current velocity */
    double radius;          /* [m] */
    double reach;           /* [m] radius + dt x speed relative to the shear flow */
    double ox, oy, ovy;     /* [m], [m], [m/s] wrapped minus current coordinates */
    double xw, yw;          /* [m] position wrapped into the primary box */
    int64_t index;          /* in r->particles */
};

struct rs_sheet_detector {
    int64_t particle_capacity;
    struct rs_sheet_particle* unsorted;
    struct rs_sheet_particle* sorted;
    int64_t* cell_of;
    int64_t cell_capacity;
    int64_t* cell_start;            /* n_cells + 1 entries */
    int64_t collision_capacity;
    int64_t n_collisions;
    struct reb_collision* collisions;
    /* counters */
    int64_t steps;
    int64_t candidates;
    int64_t reports;
    int64_t cells_last;
    double cell_size_last;          /* [m] */
    int32_t error;                  /* RS_DETECT_* of the last step */
};

static void rs_sheet_detector_free(struct rs_sheet_detector* d){
    if (d == NULL){
        return;
    }
    free(d->unsorted);
    free(d->sorted);
    free(d->cell_of);
    free(d->cell_start);
    free(d->collisions);
    free(d);
}

static int rs_grow(void** buffer, int64_t* capacity, int64_t needed, size_t item){
    if (*capacity >= needed){
        return 1;
    }
    int64_t n = *capacity > 0 ? *capacity : 64;
    while (n < needed){
        n *= 2;
    }
    void* grown = realloc(*buffer, (size_t)n * item);
    if (grown == NULL){
        return 0;
    }
    *buffer = grown;
    *capacity = n;
    return 1;
}

/* floor(a / b) for b > 0 and small |a| (cell offsets beyond the grid). */
static int64_t rs_floor_div(int64_t a, int64_t b){
    const int64_t q = a / b;
    return (a % b != 0 && a < 0) ? q - 1 : q;
}

static int64_t rs_cell_coordinate(double u, double low, double width, int64_t n){
    const double c = floor((u - low) / width);
    if (!(c >= 0.0)){
        return 0;       /* also NaN */
    }
    return c >= (double)n ? n - 1 : (int64_t)c;
}

static int rs_report(struct rs_sheet_detector* d, size_t p1, size_t p2, struct reb_vec6d gb){
    if (d->n_collisions >= d->collision_capacity){
        int64_t capacity = d->collision_capacity;
        if (!rs_grow((void**)&d->collisions, &capacity, d->n_collisions + 1,
                     sizeof(struct reb_collision))){
            return 0;
        }
        d->collision_capacity = capacity;
    }
    struct reb_collision* c = &d->collisions[d->n_collisions++];
    c->p1 = p1;
    c->p2 = p2;
    c->gb = gb;
    c->ri = 0;
    return 1;
}

/* Fills d->collisions with the pairs whose paths touched in the last step. */
static int rs_sheet_find_pairs(struct reb_simulation* const r, struct rs_sheet_detector* d){
    d->n_collisions = 0;
    const int64_t n = (int64_t)r->N;
    if (n < 2){
        return RS_DETECT_OK;
    }
    const int shear = r->boundary == REB_BOUNDARY_SHEAR;
    if (!shear && r->boundary != REB_BOUNDARY_PERIODIC){
        return RS_DETECT_BAD_BOUNDARY;
    }
    const double Lx = r->root_size * (double)r->N_root_x;
    const double Ly = r->root_size * (double)r->N_root_y;
    const double Omega = shear ? r->OMEGA : 0.0;
    const double dt = fabs(r->dt_last_done);
    const double shear_step = 1.5 * fabs(Omega) * dt;  /* relative shear drift per metre of dx */
    if (!(shear_step < RS_MAX_SHEAR_STEP) || !(Lx > 0.0) || !(Ly > 0.0)){
        return RS_DETECT_STEP_TOO_LONG;
    }
    /* The ghost box at x + Lx has slid by -a in y (REBOUND: reb_boundary_get_ghostbox). */
    const double slide = shear ? fmod(1.5 * Omega * Lx * r->t, Ly) : 0.0;      /* a [m] */
    const double box_speed = 1.5 * Omega * Lx;                                  /* [m/s] */

    int64_t capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->unsorted, &capacity, n, sizeof(struct rs_sheet_particle))){
        return RS_DETECT_NO_MEMORY;
    }
    capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->sorted, &capacity, n, sizeof(struct rs_sheet_particle))){
        return RS_DETECT_NO_MEMORY;
    }
    capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->cell_of, &capacity, n, sizeof(int64_t))){
        return RS_DETECT_NO_MEMORY;
    }
    d->particle_capacity = capacity;

    /* 1. Wrap, reach, vertical range. */
    double reach_max = 0.0;
    double z_min = INFINITY;
    double z_max = -INFINITY;
    for (int64_t i = 0; i < n; i++){
        const struct reb_particle p = r->particles[i];
        struct rs_sheet_particle* q = &d->unsorted[i];
        const double mx = floor((p.x + 0.5 * Lx) / Lx);
        double xw = p.x - mx * Lx;
        double yw = p.y + mx * slide;
        yw -= Ly * floor((yw + 0.5 * Ly) / Ly);
        q->x = p.x;
        q->y = p.y;
        q->z = p.z;
        q->vx = p.vx;
        q->vy = p.vy;
        q->vz = p.vz;
        q->radius = p.r;
        const double wy = p.vy + 1.5 * Omega * p.x;
        q->reach = p.r + dt * sqrt(p.vx * p.vx + wy * wy + p.vz * p.vz);
        q->xw = xw;
        q->yw = yw;
        q->ox = xw - p.x;
        q->oy = yw - p.y;
        q->ovy = mx * box_speed;
        q->index = i;
        if (q->reach > reach_max){
            reach_max = q->reach;
        }
        if (p.z < z_min){
            z_min = p.z;
        }
        if (p.z > z_max){
            z_max = p.z;
        }
    }
    if (!isfinite(reach_max) || !isfinite(z_min) || !isfinite(z_max)){
        return RS_DETECT_STEP_TOO_LONG;     /* non-finite state: nothing sensible to do */
    }

    /* 2. Grid: cells of at least s on every side. */
    double s = 2.0 * reach_max / (1.0 - shear_step);
    s = s * (1.0 + 1e-12) + DBL_MIN;
    const int64_t cell_cap = RS_CELLS_PER_PARTICLE * n + 64;
    int64_t nx = Lx / s >= (double)cell_cap ? cell_cap : (int64_t)floor(Lx / s);
    int64_t ny = Ly / s >= (double)cell_cap ? cell_cap : (int64_t)floor(Ly / s);
    nx = nx < 1 ? 1 : nx;
    ny = ny < 1 ? 1 : ny;
    while (nx * ny > cell_cap){
        nx = nx > 1 ? (nx + 1) / 2 : 1;
        ny = ny > 1 ? (ny + 1) / 2 : 1;
    }
    const double z_range = z_max - z_min;
    int64_t nz = z_range / s >= (double)cell_cap ? cell_cap : (int64_t)floor(z_range / s) + 1;
    if (nx * ny * nz > cell_cap){
        nz = cell_cap / (nx * ny);
        nz = nz < 1 ? 1 : nz;
    }
    const double sx = Lx / (double)nx;
    const double sy = Ly / (double)ny;
    const double sz = nz > 1 ? fmax(s, z_range / (double)(nz - 1) * (1.0 + 1e-12)) : INFINITY;
    const int64_t n_cells = nx * ny * nz;
    capacity = d->cell_capacity;
    if (!rs_grow((void**)&d->cell_start, &capacity, n_cells + 1, sizeof(int64_t))){
        return RS_DETECT_NO_MEMORY;
    }
    d->cell_capacity = capacity;
    d->cells_last = n_cells;
    d->cell_size_last = s;

    /* Counting sort into cells. */
    int64_t* const start = d->cell_start;
    memset(start, 0, (size_t)(n_cells + 1) * sizeof(int64_t));
    for (int64_t i = 0; i < n; i++){
        const struct rs_sheet_particle* q = &d->unsorted[i];
        const int64_t cx = rs_cell_coordinate(q->xw, -0.5 * Lx, sx, nx);
        const int64_t cy = rs_cell_coordinate(q->yw, -0.5 * Ly, sy, ny);
        const int64_t cz = nz > 1 ? rs_cell_coordinate(q->z, z_min, sz, nz) : 0;
        const int64_t cell = (cz * ny + cy) * nx + cx;
        d->cell_of[i] = cell;
        start[cell + 1]++;
    }
    for (int64_t c = 0; c < n_cells; c++){
        start[c + 1] += start[c];
    }
    for (int64_t i = 0; i < n; i++){
        /* start[c] is the next free slot of cell c during placement ... */
        d->sorted[start[d->cell_of[i]]++] = d->unsorted[i];
    }
    for (int64_t c = n_cells; c > 0; c--){
        start[c] = start[c - 1];    /* ... and is shifted back to the cell's first slot */
    }
    start[0] = 0;

    /* 3-4. Neighbour cells, images, exact path test. */
    const struct rs_sheet_particle* const sorted = d->sorted;
    for (int64_t a = 0; a < n; a++){
        const struct rs_sheet_particle pi = sorted[a];
        const int64_t cx = rs_cell_coordinate(pi.xw, -0.5 * Lx, sx, nx);
        const int64_t cz = nz > 1 ? rs_cell_coordinate(pi.z, z_min, sz, nz) : 0;
        for (int64_t kx = -1; kx <= 1; kx++){
            const int64_t box_x = rs_floor_div(cx + kx, nx);
            const int64_t column_x = cx + kx - box_x * nx;
            /* Image of i in the frame of the box the column belongs to. */
            const double image_x = -(double)box_x * Lx;
            const double image_vy = (double)box_x * box_speed;
            double image_y = (double)box_x * slide;
            double yq = pi.yw + image_y;
            const double wrap_y = floor((yq + 0.5 * Ly) / Ly);
            yq -= wrap_y * Ly;
            image_y -= wrap_y * Ly;
            const int64_t cyq = rs_cell_coordinate(yq, -0.5 * Ly, sy, ny);
            for (int64_t ky = -1; ky <= 1; ky++){
                const int64_t box_y = rs_floor_div(cyq + ky, ny);
                const int64_t column_y = cyq + ky - box_y * ny;
                const double gy_i = image_y - (double)box_y * Ly;
                for (int64_t kz = -1; kz <= 1; kz++){
                    const int64_t layer = cz + kz;
                    if (layer < 0 || layer >= nz){
                        continue;
                    }
                    const int64_t cell = (layer * ny + column_y) * nx + column_x;
                    for (int64_t b = start[cell]; b < start[cell + 1]; b++){
                        const struct rs_sheet_particle* pj = &sorted[b];
                        if (pj->index <= pi.index){
                            continue;
                        }
                        struct reb_vec6d gb;
                        gb.x = pi.ox + image_x - pj->ox;
                        gb.y = pi.oy + gy_i - pj->oy;
                        gb.z = 0.0;
                        gb.vx = 0.0;
                        gb.vy = pi.ovy + image_vy - pj->ovy;
                        gb.vz = 0.0;
                        const double dx = pi.x + gb.x - pj->x;
                        const double dy = pi.y + gb.y - pj->y;
                        const double dz = pi.z - pj->z;
                        const double bound = pi.reach + pj->reach + shear_step * fabs(dx);
                        const double d2 = dx * dx + dy * dy + dz * dz;
                        if (d2 > bound * bound){
                            continue;
                        }
                        d->candidates++;
                        const double dvx = pi.vx - pj->vx;
                        const double dvy = pi.vy + gb.vy - pj->vy;
                        const double dvz = pi.vz - pj->vz;
                        /* Closest approach on dr(s) = dr - s dv, 0 <= s <= dt. */
                        const double dv2 = dvx * dvx + dvy * dvy + dvz * dvz;
                        double s_closest = dv2 > 0.0 ? (dx * dvx + dy * dvy + dz * dvz) / dv2
                                                     : 0.0;
                        s_closest = s_closest < 0.0 ? 0.0 : (s_closest > dt ? dt : s_closest);
                        const double ex = dx - s_closest * dvx;
                        const double ey = dy - s_closest * dvy;
                        const double ez = dz - s_closest * dvz;
                        const double sum_radii = pi.radius + pj->radius;
                        if (ex * ex + ey * ey + ez * ez > sum_radii * sum_radii){
                            continue;
                        }
                        if (!rs_report(d, (size_t)pi.index, (size_t)pj->index, gb)){
                            return RS_DETECT_NO_MEMORY;
                        }
                    }
                }
            }
        }
    }
    d->reports += d->n_collisions;
    return RS_DETECT_OK;
}

static struct rs_sheet_detector* rs_detector_of(struct rs_resolver* res){
    if (res->detector == NULL){
        res->detector = calloc(1, sizeof(struct rs_sheet_detector));
        /* rs_resolver.c frees it through this pointer: no link-time dependency on this
         * file, so the resolver also builds and works without the detector */
        res->detector_free = rs_sheet_detector_free;
    }
    return res->detector;
}

/* REBOUND's post_timestep_modifications: detect and resolve the collisions of the step
 * just done (runs before REBOUND wraps the particles into the box). */
void rs_sheet_step(struct reb_simulation* const r){
    struct rs_resolver* const res = rs_resolver_of(r);
    if (res == NULL){
        r->status = REB_STATUS_GENERIC_ERROR;   /* installed without its resolver */
        return;
    }
    struct rs_sheet_detector* const d = rs_detector_of(res);
    if (d == NULL){
        r->status = REB_STATUS_GENERIC_ERROR;
        return;
    }
    d->steps++;
    d->error = rs_sheet_find_pairs(r, d);
    if (d->error != RS_DETECT_OK){
        r->status = REB_STATUS_GENERIC_ERROR;
        return;
    }
    const int64_t n = d->n_collisions;
    struct reb_collision* const c = d->collisions;
    for (int64_t i = 0; i < n; i++){
        /* Random order, reproducible from rand_seed (saved with the simulation). */
        const int64_t other = (int64_t)(rand_r(&r->rand_seed) % (unsigned int)n);
        const struct reb_collision swap = c[i];
        c[i] = c[other];
        c[other] = swap;
    }
    for (int64_t i = 0; i < n; i++){
        rs_resolve_pair(r, res, c[i], 1);
    }
}

/* Detection only, for tests: writes up to `capacity` pairs (p1, p2) and their ghost-box
 * offsets gb[6] of the current state, in search order; returns the number found, or
 * -(1 + error code). */
int64_t rs_sheet_detect_pairs(struct reb_simulation* const r, int64_t capacity,
                              int64_t* pairs, double* offsets){
    struct rs_resolver* const res = rs_resolver_of(r);
    if (res == NULL){
        return -(1 + RS_DETECT_BAD_BOUNDARY);
    }
    struct rs_sheet_detector* const d = rs_detector_of(res);
    if (d == NULL){
        return -(1 + RS_DETECT_NO_MEMORY);
    }
    const int error = rs_sheet_find_pairs(r, d);
    if (error != RS_DETECT_OK){
        return -(1 + error);
    }
    for (int64_t i = 0; i < d->n_collisions && i < capacity; i++){
        const struct reb_collision c = d->collisions[i];
        pairs[2 * i] = (int64_t)c.p1;
        pairs[2 * i + 1] = (int64_t)c.p2;
        const double gb[6] = {c.gb.x, c.gb.y, c.gb.z, c.gb.vx, c.gb.vy, c.gb.vz};
        memcpy(&offsets[6 * i], gb, sizeof(gb));
    }
    return d->n_collisions;
}

/* Counters since the detector was created: out[0] steps, out[1] candidate pairs whose path
 * was tested, out[2] pairs reported, out[3] cells of the last grid, out[4] last error;
 * *cell_size [m] of the last grid.  Returns 0 if the detector has not run yet. */
int rs_sheet_detector_counters(const struct rs_resolver* res, int64_t* out,
                               double* cell_size){
    const struct rs_sheet_detector* d = res->detector;
    if (d == NULL){
        memset(out, 0, 5 * sizeof(int64_t));
        *cell_size = 0.0;
        return 0;
    }
    out[0] = d->steps;
    out[1] = d->candidates;
    out[2] = d->reports;
    out[3] = d->cells_last;
    out[4] = d->error;
    *cell_size = d->cell_size_last;
    return 1;
}

/* Largest 1.5 Omega dt the detector accepts (exclusive), for ringsim's scenario validation:
 * a fixed integration.dt in line mode must satisfy 1.5 |Omega| dt < this value. */
double rs_sheet_max_shear_step(void){
    return RS_MAX_SHEAR_STEP;
}
