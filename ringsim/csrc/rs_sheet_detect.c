/**
 * @file    rs_sheet_detect.c
 * @brief   Swept-sphere collision detection for REBOUND shearing sheets, with the contacts of
 *          a step resolved in time order by rs_resolver.c (ringsim, issues 7 and 11).
 *
 * Effect          finds every pair whose straight relative path over the last time step
 *                 came within the sum of the radii, in a shear-periodic box, and resolves
 *                 the contacts earliest first, re-checking every path a collision changed
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
 * local shear flow, so the cost per particle-step stays flat in N.  REBOUND resolves the
 * pairs it finds in shuffled order, each on the straight path its particles had at the start
 * of the resolution; here the contacts of a step are resolved in the order they happen and
 * a particle deflected into a third one meets it in the same step.
 *
 * Method (one call per step, as REBOUND's post_timestep_modifications)
 * --------------------------------------------------------------------
 * Times are back times s before the end of the step t (0 <= s <= dt, dt = dt_last_done);
 * a particle's path is the straight line through its end-of-step position with its current
 * velocity, x(s) = x - s v.
 * 1. Each particle i gets its speed relative to the local shear flow,
 *        w_i = |(vx, vy + 1.5 Omega x, vz)|,
 *    and its reach rho_i = R_i + dt w_i.  A pair (i, j) with end-of-step separation dr and
 *    relative velocity dv = w_i - w_j - 1.5 Omega dx e_y can touch within the step only if
 *    |dr| <= rho_i + rho_j + 1.5 Omega dt |dx|  (exact bound), hence only if
 *    |dr| <= 2 max(rho) / (1 - 1.5 Omega dt) = s.
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
 *    relative path over the step is <= R_i + R_j: REBOUND's linetree criterion.
 * 5. Time order.  Each report gets its contact time: the entry root of |dr - s dv| = R_i +
 *    R_j (as rs_resolve_pair computes it) if it lies in (0, dt]; s = dt if the pair already
 *    touches at the start of the step and still approaches; else none.  The contacts wait
 *    in a binary heap, earliest (largest s) first, ties broken by p1, p2 and the ghost
 *    offset: the order depends on times and particle indices only.  The earliest contact is
 *    resolved by rs_resolve_contact (impulse of the restitution law at the contact, both
 *    particles moved on with their new velocities to the end of the step), and its time
 *    s_c becomes "now".
 * 6. Re-check.  Every particle carries the serial number of its last collision in the
 *    step and every waiting contact the serials of its two particles when it was computed,
 *    so the contacts computed on a path that has since changed are dropped when they come
 *    up.  Both particles of the collision look around them again (step 3, all partners)
 *    and every partner within the bound of step 7 gets its contact on the new paths within
 *    [now, end of step]: the entry time if it is after now, now itself if the pair touches
 *    now and approaches.  A particle deflected into a third one - on course before or not -
 *    is so resolved in the same step, at the contact on its new path, in time order.
 * 7. Bound of the re-check.  A particle's deviation D_i is the largest distance between its
 *    position and its start-of-resolution path x_0(s) at any time of the step so far.
 *    Between collisions it moves on a straight line, so |x(s) - x_0(s)| is convex in s and
 *    its largest value over the step is bounded by the largest end-of-step displacement
 *    |x(0) - x_0(0)| after any of its collisions: D_i is that running maximum, updated at
 *    each collision.  A pair can then touch at any time only if
 *        |dr_0| <= rho_i + rho_j + 1.5 Omega dt |dx_0| + D_i + D_j
 *    (dr_0, dx_0, rho at the start of the resolution, as in step 1); the re-check tests
 *    this with the current D of both particles, in as many cells around the particle as
 *    (rho_i + D_i + max rho + max D) / (1 - 1.5 Omega dt) needs (one unless deflections
 *    are large).  D of a pair grows only when one of its particles collides, and that
 *    particle is then re-checked with the new D: no contact on the piecewise-straight
 *    paths is missed (but see the limits).
 * 8. Collisions of one pair.  After a collision (eps >= 0) the pair's normal velocity is
 *    >= 0 and, on straight paths, its distance can only grow: it can meet again in the same
 *    step only after a third body has deflected one of the two.  A pair is therefore not
 *    re-checked while the last collision of both its particles is the one between them
 *    (equal serials); once a third body deflected one of them it may collide again (e.g.
 *    re-approaching after the push).  This replaces rs_resolver.c's per-step pair memory,
 *    which allowed one resolution per pair and step, and keeps eps = 0 (grazing) pairs from
 *    resolving again and again.  Chains of contacts in one step, which for small eps can in
 *    principle be infinite (inelastic collapse), are cut: a particle with RS_MAX_CONTACTS
 *    resolved contacts in a step gets no more in that step.
 * No shuffle and no random numbers: sim.rand_seed is not used and does not advance.
 *
 * Parameters: none beyond the simulation's (box, OMEGA, boundary, dt_last_done, t) and the
 * resolver's.  Counters (rs_sheet_detector_counters): steps, candidates (pairs whose path
 * was tested, also in re-checks), reports, cells and cell size of the last step; of the time
 * order (rs_sheet_order_counters): contacts resolved, of which on a path changed earlier in
 * the step, re-checks, re-checks wider than one cell, re-checks cut at RS_MAX_SPAN cells,
 * particles that reached RS_MAX_CONTACTS.
 *
 * Validity limits
 * ---------------
 * - Paths are straight lines with the velocities after the last collision (epicyclic
 *   curvature ignored): valid for Omega dt << 1; 1.5 Omega dt < 0.5 is required (else the
 *   step is refused).
 * - Boundaries: shear (needs OMEGA) or periodic; z is never periodic here (REBOUND's box is
 *   periodic in z, ringsim's vertical guard keeps particles far from it).
 * - The box should be at least 2 s wide in x and y.  If not, several images of one pair
 *   may be in reach; all are queued, the first contact is resolved and the pair's other
 *   images wait, like any pair, for a third body's deflection.
 * - A re-check looks at most RS_MAX_SPAN cells away (counted when it would need more, i.e.
 *   when collisions within one step have moved particles off their first paths by several
 *   times the largest reach); contacts beyond are found in the next step, as overlaps or
 *   crossings.  Measured in line-mode rings at 1e-3 orbit: never reached; one re-check in
 *   10 to 20 needs two cells.
 * - A particle has at most RS_MAX_CONTACTS contacts resolved per step; further contacts of
 *   that step are left to the next step (counted).
 * - Pairs touching at the start of the step are resolved then if they approach (with
 *   REBOUND's minimum_collision_velocity floor for overlaps), else left alone.
 * - Particles outside the box (not yet wrapped: detection runs before REBOUND's boundary
 *   check) are handled through their wrap offsets; the search does not move them.
 * - Cost: on top of the search, O(log) per contact for the heap and one neighbour search
 *   per particle and collision.
 *
 * No global mutable state: the work space lives in the resolver struct of the simulation.
 */
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
/* Contacts resolved per particle and step at most (cuts inelastic collapse). */
#define RS_MAX_CONTACTS 32
/* Cells a re-check looks at in each direction at most. */
#define RS_MAX_SPAN 3

struct rs_sheet_particle {
    double x, y, z;         /* [m] current position */
    double vx, vy, vz;      /* [m/s] current velocity */
    double radius;          /* [m] */
    double reach;           /* [m] radius + dt x speed relative to the shear flow */
    double ox, oy, ovy;     /* [m], [m], [m/s] wrapped minus current coordinates */
    double xw, yw;          /* [m] position wrapped into the primary box */
    int64_t index;          /* in r->particles */
};

/* A particle within the current step (indexed like r->particles). */
struct rs_sheet_track {
    double deviation;       /* [m] D of Method 7: bound on the distance from its first path */
    int64_t last;           /* serial of its last collision in this step, 0: none */
    int64_t contacts;       /* collisions resolved in this step */
};

/* A contact on the paths of the moment it was computed. */
struct rs_event {
    double back_time;       /* [s] before the end of the step */
    int64_t last1, last2;   /* serials of p1's and p2's last collisions then */
    struct reb_collision c; /* p1 < p2, gb of p1 */
};

/* The cell grid of the last search. */
struct rs_sheet_grid {
    double Lx, Ly;          /* [m] box */
    double slide;           /* [m] y offset a of the ghost box at x + Lx */
    double box_speed;       /* [m/s] 1.5 Omega Lx */
    double shear_step;      /* 1.5 |Omega| dt */
    double dt;              /* [s] */
    double sx, sy, sz;      /* [m] cell sides (sz infinite with one layer) */
    double side_min;        /* [m] smallest of them */
    double z_min;           /* [m] bottom of the lowest layer */
    double reach_max;       /* [m] */
    int64_t nx, ny, nz;
};

struct rs_sheet_detector {
    int64_t particle_capacity;
    struct rs_sheet_particle* unsorted;     /* by particle index: the state before resolution */
    struct rs_sheet_particle* sorted;       /* by cell */
    struct rs_sheet_track* track;           /* by particle index */
    int64_t* cell_of;
    int64_t cell_capacity;
    int64_t* cell_start;            /* n_cells + 1 entries */
    int64_t collision_capacity;
    int64_t n_collisions;
    struct reb_collision* collisions;
    int64_t event_capacity;
    int64_t n_events;
    struct rs_event* events;        /* binary heap, earliest contact at the root */
    struct rs_sheet_grid grid;
    double deviation_max;           /* [m] largest D of this step */
    int64_t serial;                 /* collisions resolved in this step */
    /* counters */
    int64_t steps;
    int64_t candidates;
    int64_t reports;
    int64_t cells_last;
    double cell_size_last;          /* [m] */
    int32_t error;                  /* RS_DETECT_* of the last step */
    int64_t resolved;               /* contacts resolved */
    int64_t rescheduled;            /* of which timed on a path changed earlier in the step */
    int64_t rechecks;               /* neighbour searches after a collision */
    int64_t wide_rechecks;          /* of which over more than one cell */
    int64_t span_limited;           /* of which cut at RS_MAX_SPAN cells */
    int64_t saturated;              /* particles that reached RS_MAX_CONTACTS in a step */
};

static void rs_sheet_detector_free(struct rs_sheet_detector* d){
    if (d == NULL){
        return;
    }
    free(d->unsorted);
    free(d->sorted);
    free(d->track);
    free(d->cell_of);
    free(d->cell_start);
    free(d->collisions);
    free(d->events);
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

/* ---------------------------------------------------------------------------------- */
/* Contacts in time order (Method 5-8).                                               */

/* Back time [s] of pair c's next contact on the current straight paths within the last
 * `window` of the step: the entry into contact if it is in (0, window], `window` itself if
 * the pair touches then and approaches; 0 if none. */
static double rs_contact_back_time(const struct reb_simulation* const r,
                                   const struct reb_collision c, double window){
    const struct reb_particle* const p1 = &r->particles[c.p1];
    const struct reb_particle* const p2 = &r->particles[c.p2];
    const double dx = p1->x + c.gb.x - p2->x;
    const double dy = p1->y + c.gb.y - p2->y;
    const double dz = p1->z + c.gb.z - p2->z;
    const double dvx = p1->vx + c.gb.vx - p2->vx;
    const double dvy = p1->vy + c.gb.vy - p2->vy;
    const double dvz = p1->vz + c.gb.vz - p2->vz;
    const double sum_radii = p1->r + p2->r;
    const double a = dvx * dvx + dvy * dvy + dvz * dvz;
    const double b = dx * dvx + dy * dvy + dz * dvz;
    const double gap = dx * dx + dy * dy + dz * dz - sum_radii * sum_radii;
    const double discriminant = b * b - a * gap;
    if (!(a > 0.0) || !(discriminant >= 0.0)){
        return 0.0;
    }
    const double entry = (b + sqrt(discriminant)) / a;
    if (!(entry > 0.0)){
        return 0.0;
    }
    if (entry <= window){
        return entry;
    }
    return window * a > b ? window : 0.0;   /* dr(window).dv < 0: still approaching */
}

/* a happens before b: larger back time, then smaller indices and offsets. */
static int rs_event_before(const struct rs_event* a, const struct rs_event* b){
    if (a->back_time != b->back_time){
        return a->back_time > b->back_time;
    }
    if (a->c.p1 != b->c.p1){
        return a->c.p1 < b->c.p1;
    }
    if (a->c.p2 != b->c.p2){
        return a->c.p2 < b->c.p2;
    }
    if (a->c.gb.x != b->c.gb.x){
        return a->c.gb.x < b->c.gb.x;
    }
    return a->c.gb.y < b->c.gb.y;
}

/* Queues pair c's next contact within the last `window` of the step, if it has one.
 * Returns 0 if memory ran out. */
static int rs_queue(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                    const struct reb_collision c, double window){
    const double back_time = rs_contact_back_time(r, c, window);
    if (!(back_time > 0.0)){
        return 1;
    }
    if (!rs_grow((void**)&d->events, &d->event_capacity, d->n_events + 1,
                 sizeof(struct rs_event))){
        return 0;
    }
    const struct rs_event e = {back_time, d->track[c.p1].last, d->track[c.p2].last, c};
    int64_t k = d->n_events++;
    while (k > 0){
        const int64_t parent = (k - 1) / 2;
        if (!rs_event_before(&e, &d->events[parent])){
            break;
        }
        d->events[k] = d->events[parent];
        k = parent;
    }
    d->events[k] = e;
    return 1;
}

static struct rs_event rs_pop(struct rs_sheet_detector* d){
    const struct rs_event first = d->events[0];
    const int64_t n = --d->n_events;
    const struct rs_event last = d->events[n];
    int64_t k = 0;
    for (int64_t child = 1; child < n; child = 2 * k + 1){
        if (child + 1 < n && rs_event_before(&d->events[child + 1], &d->events[child])){
            child++;
        }
        if (!rs_event_before(&d->events[child], &last)){
            break;
        }
        d->events[k] = d->events[child];
        k = child;
    }
    if (n > 0){
        d->events[k] = last;
    }
    return first;
}

/* Method 6 for the pair of particle i and partner j (image offset gb of i): queued unless
 * their last collisions are the one between them, or either has its fill of contacts. */
static int rs_recheck_pair(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                           int64_t i, int64_t j, struct reb_vec6d gb, double window){
    const struct rs_sheet_track* ti = &d->track[i];
    const struct rs_sheet_track* tj = &d->track[j];
    if ((ti->last == tj->last && ti->last != 0) || ti->contacts >= RS_MAX_CONTACTS
        || tj->contacts >= RS_MAX_CONTACTS){
        return 1;
    }
    d->candidates++;
    struct reb_collision c = {0};
    if (i < j){
        c.p1 = (size_t)i;
        c.p2 = (size_t)j;
        c.gb = gb;
    }else{
        c.p1 = (size_t)j;
        c.p2 = (size_t)i;
        c.gb.x = -gb.x;
        c.gb.y = -gb.y;
        c.gb.vy = -gb.vy;
    }
    return rs_queue(r, d, c, window);
}

/* ---------------------------------------------------------------------------------- */
/* The search.                                                                        */

enum RS_SCAN {
    RS_SCAN_REPORT = 0,     /* Method 3-4: partners j > i, report swept contacts */
    RS_SCAN_RECHECK = 1,    /* Method 6-7: partners j != i, queue their next contacts */
};

/* Looks at the cells up to `span` cells around particle pi (state before the resolution)
 * for partners within the bound of Method 1 (REPORT) or 7 (RECHECK, contacts within the
 * last `window` of the step).  Returns 0 if memory ran out. */
static int rs_scan(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                   const struct rs_sheet_particle pi, int64_t span, int mode, double window){
    const struct rs_sheet_grid g = d->grid;     /* a copy: the loop below writes to d */
    const int64_t* const start = d->cell_start;
    const struct rs_sheet_particle* const sorted = d->sorted;
    const double deviation_i = mode == RS_SCAN_RECHECK ? d->track[pi.index].deviation : 0.0;
    const int64_t cx = rs_cell_coordinate(pi.xw, -0.5 * g.Lx, g.sx, g.nx);
    const int64_t cz = g.nz > 1 ? rs_cell_coordinate(pi.z, g.z_min, g.sz, g.nz) : 0;
    int64_t candidates = 0;
    for (int64_t kx = -span; kx <= span; kx++){
        const int64_t box_x = rs_floor_div(cx + kx, g.nx);
        const int64_t column_x = cx + kx - box_x * g.nx;
        /* Image of i in the frame of the box the column belongs to. */
        const double image_x = -(double)box_x * g.Lx;
        const double image_vy = (double)box_x * g.box_speed;
        double image_y = (double)box_x * g.slide;
        double yq = pi.yw + image_y;
        const double wrap_y = floor((yq + 0.5 * g.Ly) / g.Ly);
        yq -= wrap_y * g.Ly;
        image_y -= wrap_y * g.Ly;
        const int64_t cyq = rs_cell_coordinate(yq, -0.5 * g.Ly, g.sy, g.ny);
        for (int64_t ky = -span; ky <= span; ky++){
            const int64_t box_y = rs_floor_div(cyq + ky, g.ny);
            const int64_t column_y = cyq + ky - box_y * g.ny;
            const double gy_i = image_y - (double)box_y * g.Ly;
            for (int64_t kz = -span; kz <= span; kz++){
                const int64_t layer = cz + kz;
                if (layer < 0 || layer >= g.nz){
                    continue;
                }
                const int64_t cell = (layer * g.ny + column_y) * g.nx + column_x;
                const int64_t end = start[cell + 1];
                for (int64_t b = start[cell]; b < end; b++){
                    const struct rs_sheet_particle* pj = &sorted[b];
                    if (mode == RS_SCAN_REPORT ? pj->index <= pi.index
                                               : pj->index == pi.index){
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
                    double bound = pi.reach + pj->reach + g.shear_step * fabs(dx);
                    if (mode == RS_SCAN_RECHECK){
                        bound += deviation_i + d->track[pj->index].deviation;
                    }
                    const double d2 = dx * dx + dy * dy + dz * dz;
                    if (d2 > bound * bound){
                        continue;
                    }
                    if (mode == RS_SCAN_RECHECK){
                        if (!rs_recheck_pair(r, d, pi.index, pj->index, gb, window)){
                            return 0;
                        }
                        continue;
                    }
                    candidates++;
                    const double dvx = pi.vx - pj->vx;
                    const double dvy = pi.vy + gb.vy - pj->vy;
                    const double dvz = pi.vz - pj->vz;
                    /* Closest approach on dr(s) = dr - s dv, 0 <= s <= dt. */
                    const double dv2 = dvx * dvx + dvy * dvy + dvz * dvz;
                    double s_closest = dv2 > 0.0 ? (dx * dvx + dy * dvy + dz * dvz) / dv2
                                                 : 0.0;
                    s_closest = s_closest < 0.0 ? 0.0 : (s_closest > g.dt ? g.dt : s_closest);
                    const double ex = dx - s_closest * dvx;
                    const double ey = dy - s_closest * dvy;
                    const double ez = dz - s_closest * dvz;
                    const double sum_radii = pi.radius + pj->radius;
                    if (ex * ex + ey * ey + ez * ez > sum_radii * sum_radii){
                        continue;
                    }
                    if (!rs_report(d, (size_t)pi.index, (size_t)pj->index, gb)){
                        return 0;
                    }
                }
            }
        }
    }
    d->candidates += candidates;
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
    struct rs_sheet_grid* const g = &d->grid;
    g->Lx = r->root_size * (double)r->N_root_x;
    g->Ly = r->root_size * (double)r->N_root_y;
    const double Lx = g->Lx;
    const double Ly = g->Ly;
    const double Omega = shear ? r->OMEGA : 0.0;
    g->dt = fabs(r->dt_last_done);
    g->shear_step = 1.5 * fabs(Omega) * g->dt;  /* relative shear drift per metre of dx */
    if (!(g->shear_step < RS_MAX_SHEAR_STEP) || !(Lx > 0.0) || !(Ly > 0.0)){
        return RS_DETECT_STEP_TOO_LONG;
    }
    /* The ghost box at x + Lx has slid by -a in y (REBOUND: reb_boundary_get_ghostbox). */
    g->slide = shear ? fmod(1.5 * Omega * Lx * r->t, Ly) : 0.0;     /* a [m] */
    g->box_speed = 1.5 * Omega * Lx;                                 /* [m/s] */

    int64_t capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->unsorted, &capacity, n, sizeof(struct rs_sheet_particle))){
        return RS_DETECT_NO_MEMORY;
    }
    capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->sorted, &capacity, n, sizeof(struct rs_sheet_particle))){
        return RS_DETECT_NO_MEMORY;
    }
    capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->track, &capacity, n, sizeof(struct rs_sheet_track))){
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
        double yw = p.y + mx * g->slide;
        yw -= Ly * floor((yw + 0.5 * Ly) / Ly);
        q->x = p.x;
        q->y = p.y;
        q->z = p.z;
        q->vx = p.vx;
        q->vy = p.vy;
        q->vz = p.vz;
        q->radius = p.r;
        const double wy = p.vy + 1.5 * Omega * p.x;
        q->reach = p.r + g->dt * sqrt(p.vx * p.vx + wy * wy + p.vz * p.vz);
        q->xw = xw;
        q->yw = yw;
        q->ox = xw - p.x;
        q->oy = yw - p.y;
        q->ovy = mx * g->box_speed;
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
    g->reach_max = reach_max;

    /* 2. Grid: cells of at least s on every side. */
    double s = 2.0 * reach_max / (1.0 - g->shear_step);
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
    g->nx = nx;
    g->ny = ny;
    g->nz = nz;
    g->sx = Lx / (double)nx;
    g->sy = Ly / (double)ny;
    g->sz = nz > 1 ? fmax(s, z_range / (double)(nz - 1) * (1.0 + 1e-12)) : INFINITY;
    g->side_min = fmin(fmin(g->sx, g->sy), g->sz);
    g->z_min = z_min;
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
        const int64_t cx = rs_cell_coordinate(q->xw, -0.5 * Lx, g->sx, nx);
        const int64_t cy = rs_cell_coordinate(q->yw, -0.5 * Ly, g->sy, ny);
        const int64_t cz = nz > 1 ? rs_cell_coordinate(q->z, z_min, g->sz, nz) : 0;
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
    for (int64_t a = 0; a < n; a++){
        if (!rs_scan(r, d, d->sorted[a], 1, RS_SCAN_REPORT, g->dt)){
            return RS_DETECT_NO_MEMORY;
        }
    }
    d->reports += d->n_collisions;
    return RS_DETECT_OK;
}

/* Method 6-7 after a collision of particle q: its deviation, then its new contacts within
 * the last `window` of the step.  Returns 0 if memory ran out. */
static int rs_after_collision(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                              int64_t q, double window){
    struct rs_sheet_track* t = &d->track[q];
    const struct rs_sheet_particle* const before = &d->unsorted[q];
    const struct reb_particle* const p = &r->particles[q];
    const double ex = p->x - before->x;
    const double ey = p->y - before->y;
    const double ez = p->z - before->z;
    const double deviation = sqrt(ex * ex + ey * ey + ez * ez);
    t->deviation = fmax(t->deviation, deviation);
    d->deviation_max = fmax(d->deviation_max, t->deviation);
    t->last = d->serial;
    t->contacts++;
    if (t->contacts >= RS_MAX_CONTACTS){
        d->saturated += t->contacts == RS_MAX_CONTACTS;
        return 1;
    }
    const struct rs_sheet_grid* g = &d->grid;
    const double needed = (before->reach + t->deviation + g->reach_max + d->deviation_max)
                          / (1.0 - g->shear_step);
    int64_t span = 1;
    if (!(needed <= g->side_min)){
        span = needed <= RS_MAX_SPAN * g->side_min ? (int64_t)ceil(needed / g->side_min)
                                                   : RS_MAX_SPAN;
        d->wide_rechecks++;
        d->span_limited += !(needed <= RS_MAX_SPAN * g->side_min);
    }
    d->rechecks++;
    return rs_scan(r, d, *before, span, RS_SCAN_RECHECK, window);
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
 * just done, in time order (runs before REBOUND wraps the particles into the box). */
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
    if (d->n_collisions == 0){
        return;
    }
    memset(d->track, 0, (size_t)r->N * sizeof(struct rs_sheet_track));
    d->n_events = 0;
    d->serial = 0;
    d->deviation_max = 0.0;
    for (int64_t k = 0; k < d->n_collisions; k++){
        if (!rs_queue(r, d, d->collisions[k], d->grid.dt)){
            d->error = RS_DETECT_NO_MEMORY;
        }
    }
    while (d->n_events > 0 && d->error == RS_DETECT_OK){
        const struct rs_event e = rs_pop(d);
        const int64_t p1 = (int64_t)e.c.p1;
        const int64_t p2 = (int64_t)e.c.p2;
        if (d->track[p1].last != e.last1 || d->track[p2].last != e.last2){
            continue;   /* computed on a path that has changed since */
        }
        if (!rs_resolve_contact(r, res, e.c, e.back_time)){
            continue;   /* receding, or a normal speed below round-off */
        }
        d->serial++;
        d->resolved++;
        d->rescheduled += e.last1 != 0 || e.last2 != 0;
        if (!rs_after_collision(r, d, p1, e.back_time)
            || !rs_after_collision(r, d, p2, e.back_time)){
            d->error = RS_DETECT_NO_MEMORY;
        }
    }
    if (d->error != RS_DETECT_OK){
        r->status = REB_STATUS_GENERIC_ERROR;
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

/* Counters of the time-ordered resolution since the detector was created: out[0] contacts
 * resolved, out[1] of which timed on a path changed earlier in the same step, out[2]
 * re-checks (one per particle and collision), out[3] of which over more than one cell,
 * out[4] of which cut at RS_MAX_SPAN cells, out[5] particles that reached RS_MAX_CONTACTS
 * contacts in a step.  Returns 0 (and zeros) if the detector has not run yet. */
int rs_sheet_order_counters(const struct rs_resolver* res, int64_t* out){
    const struct rs_sheet_detector* d = res->detector;
    if (d == NULL){
        memset(out, 0, 6 * sizeof(int64_t));
        return 0;
    }
    out[0] = d->resolved;
    out[1] = d->rescheduled;
    out[2] = d->rechecks;
    out[3] = d->wide_rechecks;
    out[4] = d->span_limited;
    out[5] = d->saturated;
    return 1;
}

/* Largest 1.5 Omega dt the detector accepts (exclusive), for ringsim's scenario validation:
 * a fixed integration.dt in line mode must satisfy 1.5 |Omega| dt < this value. */
double rs_sheet_max_shear_step(void){
    return RS_MAX_SHEAR_STEP;
}
