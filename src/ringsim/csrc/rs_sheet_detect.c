/**
 * @file    rs_sheet_detect.c
 * @brief   Swept-sphere collision detection for REBOUND shearing sheets, with the contacts of
 *          a step resolved in time order by rs_resolver.c (ringsim).
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
 * (docs/performance.md, "Hot rings: line vs tree").  Here particles are binned in the shear
 * frame and every search is widened only by the speeds relative to the
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
 * 1a. Kicks (self-gravity).  REBOUND's SEI drifts dt/2, kicks every velocity by the
 *    accelerations of the step, v += a dt (REBOUND leaves a in the particles), and drifts
 *    dt/2.  A particle's path over the step is then two straight pieces (the epicyclic
 *    curvature ignored as above): x(s) = x - s v for s <= kick_time = dt/2, and
 *    x(s) = x - s v + (s - kick_time) a dt before the kick, with the velocity v - a dt.
 *    When any particle has a != 0 (an exact zero without self-gravity: then nothing below
 *    changes, bit for bit), the reach gets |a| dt (dt - kick_time), the path test of
 *    step 4 and the contact times of step 5 use both pieces, and a contact before the kick
 *    is resolved with the velocities before it (rs_resolve_contact).  A collision adds the
 *    same impulse to both pieces, so the moves and deviations of steps 5-7 are unchanged.
 *    The kick is the one REBOUND applied, computed from the positions at mid-step before
 *    any collision of the step; a collision does not change it (as REBOUND would not).
 *    Two particles that collided with each other before the kick may be turned back
 *    towards each other by it (a pair resting in contact under its own gravity), so
 *    Method 8's exemption holds only for collisions after the kick.
 * 2. Particles, wrapped into the primary box as REBOUND's shear boundary would wrap them
 *    (x - m Lx, y + m a, vy + 1.5 m Omega Lx with a = 1.5 Omega Lx t mod Ly), are sorted
 *    into a grid of cells of at least s / RS_CELL_DIVISIONS on each side (x, y over the
 *    box; z over the particles' range, not periodic), by a counting sort: O(N) per step
 *    (rs_sheet_classes.c).
 *    The sort is stable, so a cell holds its particles in index order.
 * 2a. Reach classes (rs_sheet_classes.c).  Where most particles reach far less than the
 *    largest ones (a broad size distribution), the particles are sorted into classes of
 *    reach (a factor RS_CLASS_RATIO apart), each class with a grid of its own whose cells
 *    are set by the class's largest reach; all classes' cells are one counting sort, class
 *    after class.  Particle i of class c looks into the grid of its own class (step 3's
 *    pairs) and into the grids of all classes of larger reaches (every partner there),
 *    each over d_ik = (rho_i + max rho of class k) / (1 - 1.5 Omega dt): every pair is
 *    looked for once, from its particle of the smaller class, in the grid of the larger,
 *    and a small particle no longer looks over the largest reach among small neighbours
 *    (the multilevel search of Ogarko & Luding 2012, Comput. Phys. Commun. 183, 931).  A
 *    pair across the radial boundary found from its particle of higher index is reported
 *    with the offset the search from the other particle computes (rs_offset_of_lower), so
 *    the reports are the same to the bit as with one grid; the classes are used only if
 *    every class's grid is wide enough for the half shell (then a pair is in reach through
 *    one image only).  Where the classes do not pay, the search keeps one grid for the
 *    next RS_CLASS_RETRY steps before it weighs them again.  rs_sheet_set_classes(res, 1)
 *    keeps one grid.
 * 3. Each particle i looks at the cells within d_i = (rho_i + max rho) / (1 - 1.5 Omega dt)
 *    of it (the bound of step 1 with rho_j <= max rho; with classes, step 2a's d_ik): a
 *    small particle beside large ones looks at fewer cells than the largest pair distance
 *    s would need.  The cells of one
 *    row (same y and z cell, one box) are consecutive in the sorted order, so a row is one
 *    run of particles.  Across the radial boundary the neighbouring columns belong to a
 *    ghost box sliding along y, so the particle's image is moved into that box's frame
 *    (x -+ Lx, y +- a, vy +- 1.5 Omega Lx, as REBOUND's reb_boundary_get_ghostbox) before
 *    its y cell is computed.  Each pair is examined once: across the radial boundary
 *    from its particle of lower index (j > i); in the primary box, when the box is wider
 *    than two spans of the widest search, from the particle whose row of the grid (y cell,
 *    then layer) comes first, or within a row whose slot comes first ("half shell": every
 *    particle reads only the cells on its side, half the neighbours of a full search; the
 *    pair, its offsets and its tests are then computed as the particle of lower index
 *    would, exactly, so the reports are the same).  Every (cell, image) combination is
 *    distinct, and when the box is at least 2 s wide at most one image of a pair can be
 *    within reach.  A first test of the bound on a compact copy
 *    of the wrapped positions (rs_cell_report) keeps the cells around a particle in the
 *    cache; it is widened by round-off, so it passes every pair the exact test passes.
 * 3a. Threads.  The particles are split over integration.threads OpenMP threads, each
 *    with its own list of reports; the lists are joined in thread order (rs_search).  The
 *    resolution below stays serial: its contacts are applied one after the other in time
 *    order, and each one changes the paths, hence the contact times, of the pairs that
 *    wait; resolving two contacts at once would need to know they share no particle and
 *    no later contact of either, which is the serial order itself.  The contacts wait in
 *    a heap ordered by a total order (step 5), so neither the thread count nor the order
 *    of the reports changes any result: same seed, same bits.
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
 *    up.  Both particles of the collision look around them again (step 3, all partners;
 *    with classes, in every class's grid) and every partner within the bound of step 7
 *    gets its contact on the new paths within
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
 *    (rho_i + D_i + max rho + max D) / (1 - 1.5 Omega dt) needs (at most RS_MAX_SPAN s;
 *    with classes, max rho of each class in its grid).
 *    D of a pair grows only when one of its particles collides, and that particle is then
 *    re-checked with the new D: no contact on the piecewise-straight paths is missed (but
 *    see the limits).
 * 8. Collisions of one pair.  After a collision (eps >= 0) the pair's normal velocity is
 *    >= 0 and, on straight paths, its distance can only grow: it can meet again in the same
 *    step only after a third body has deflected one of the two.  A pair is therefore not
 *    re-checked while the last collision of both its particles is the one between them
 *    (equal serials) and came after the step's kick (Method 1a); once a third body deflected
 *    one of them it may collide again (e.g. re-approaching after the push).  This rule
 *    takes the place of rs_resolver.c's per-step pair memory (one resolution per pair and
 *    step, REBOUND's searches) and keeps eps = 0 (grazing) pairs from resolving again and
 *    again.  Chains of contacts in one step, which for small eps can in
 *    principle be infinite (inelastic collapse), are cut: a particle deflected in
 *    RS_MAX_CONTACTS contacts of a step gets no more in that step.  A contact deflects a
 *    particle when its partner carries at least RS_DEFLECTING_MASS_SHARE of the pair's
 *    mass (rs_resolver.h): a collapse needs particles of comparable mass turning each
 *    other back, while a metre-sized particle in a layer of centimetre grains meets
 *    hundreds of them in one step without being turned by any; were those counted, its
 *    later grains would pass into it unresolved.
 * 9. Neighbour list (Verlet's, with a skin per particle).  Where the particles move little
 *    in a step against their sizes (a cool sheet), the search of steps 3-4 goes through a
 *    list of pairs kept over several steps instead of the cells: at its build, every pair
 *    with |dr_0| <= (1 + a)(rho_i + rho_j) + b_i + b_j (found in the cells, Method 3's half
 *    shell where the grid allows; each particle's position, reach and skin b_i kept as
 *    its anchor).  At every step each particle's drift Delta_i from its anchor carried by
 *    the shear flow (y0 - 1.5 Omega x0 T, T the time since the build) and the growth of
 *    its reach give M (rs_list_margin): since dr = dr_0 + Delta_i - Delta_j - 1.5 Omega T
 *    dx_0 e_y, no pair outside the list can be within the bound of step 1 while M > 0, nor
 *    within the re-check bound of step 7 while D_i + D_j < M.  The list is built again when
 *    M <= 0, or when the box, Omega or the boundary has changed.  a covers the shear of
 *    d->list_steps steps; b_i covers steps + 1 steps of the particle's own motion rho_i -
 *    R_i, at least RS_LIST_FLOOR times its rms over the particles and at most RS_LIST_FAST
 *    times that.  Each listed pair is tested as the search from its particle of lower
 *    index tests it, through its nearest image (the only one in reach in a box wider than
 *    2 s): the same reports, offsets and bits.  A re-check goes through the particle's
 *    listed partners and the particles of the step with D >= M / 2 (d->wide), unless the
 *    particle's own D >= M / 2, or the re-check would be cut at RS_MAX_SPAN s or reach
 *    beyond half the box: then it searches the cells, which are sorted for that step only
 *    then.  The cells are laid out every step
 *    all the same (the reach classes' state is that of a search without lists).  Lists
 *    are not built where the least pair skin exceeds RS_LIST_SKIN_RATIO smallest reaches
 *    (particles that move their size in a step: the list would hold more partners than
 *    the cells read), nor in boxes narrower than two list reaches.  rs_sheet_set_lists(res,
 *    0) searches the cells at every step.  Neither changes any result.
 * No shuffle and no random numbers: sim.rand_seed is not used and does not advance.
 *
 * Parameters: none beyond the simulation's (box, OMEGA, boundary, dt_last_done, t) and the
 * resolver's, the number of threads of the search (rs_sheet_set_threads; the library
 * is compiled with OpenMP where the compiler has it, rs_sheet_openmp), the most reach
 * classes (rs_sheet_set_classes) and the steps a neighbour list is built to last
 * (rs_sheet_set_lists; none of them changes any result).  Counters
 * (rs_sheet_detector_counters): steps, candidates (pairs whose path was tested, also in
 * re-checks), reports, cells and cell size of the last step, whether it used the half
 * shell, the reach classes it used; of the time
 * order (rs_sheet_order_counters): contacts resolved, of which on a path changed earlier in
 * the step, re-checks, re-checks wider than s, re-checks cut at RS_MAX_SPAN s,
 * particles that reached RS_MAX_CONTACTS.
 *
 * Validity limits
 * ---------------
 * - Paths are straight lines with the velocities after the last collision (epicyclic
 *   curvature ignored), kinked at mid-step by the kick (Method 1a): valid for
 *   Omega dt << 1; 1.5 Omega dt < 0.5 is required (else the step is refused).
 * - Boundaries: shear (needs OMEGA) or periodic; z is never periodic here (REBOUND's box is
 *   periodic in z, ringsim's vertical guard keeps particles far from it).
 * - The box should be at least 2 s wide in x and y.  If not, several images of one pair
 *   may be in reach; all are queued, the first contact is resolved and the pair's other
 *   images wait, like any pair, for a third body's deflection.
 * - A re-check looks at most RS_MAX_SPAN s away (counted when it would need more, i.e.
 *   when collisions within one step have moved particles off their first paths by several
 *   times the largest reach); contacts beyond are found in the next step, as overlaps or
 *   crossings (how often: docs/performance.md, "Hot rings: line vs tree").  Such a cut
 *   re-check, and one that reaches beyond half the box, looks at whole cells, which differ
 *   between one grid and the class grids: only there can the two searches differ.
 * - A particle has at most RS_MAX_CONTACTS deflecting contacts resolved per step (Method
 *   8); further contacts of that step are left to the next step (counted).
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
#include "rs_sheet_classes.h"
#ifdef _OPENMP
#include <omp.h>
#endif

/* Error codes of rs_sheet_find_pairs (also in ringsim/engine/native.py, DETECTOR_ERRORS). */
#define RS_DETECT_OK 0
#define RS_DETECT_NO_MEMORY 1
#define RS_DETECT_BAD_BOUNDARY 2
#define RS_DETECT_STEP_TOO_LONG 3

/* Largest 1.5 Omega dt accepted: the straight-path approximation needs Omega dt << 1. */
#define RS_MAX_SHEAR_STEP 0.5
/* Contacts resolved per particle and step at most (cuts inelastic collapse). */
#define RS_MAX_CONTACTS 32
/* Steps in one grid after the classes did not pay, before they are weighed again. */
#define RS_CLASS_RETRY 16
/* A re-check looks at most this many times s (Method 1) away. */
#define RS_MAX_SPAN 3
/* Steps a neighbour list is built to last (Method 9), unless rs_sheet_set_lists says
 * otherwise; 0 would turn the lists off. */
#define RS_LIST_STEPS 10
/* A particle's skin covers at least this many times the rms motion of a step (Method 9):
 * the slow particles share the typical one's skin. */
#ifndef RS_LIST_FLOOR
#define RS_LIST_FLOOR 3.0
#endif
/* A particle's skin is at most this many times the least skin (Method 9): the build looks
 * as far as the largest list reach. */
#ifndef RS_LIST_FAST
#define RS_LIST_FAST 4.0
#endif
/* A list is built only if its least pair skin is at most this many times the smallest
 * reach: a skin wider than the particles (particles that move their size in a step) would
 * list more partners than the cells read. */
#ifndef RS_LIST_SKIN_RATIO
#define RS_LIST_SKIN_RATIO 8.0
#endif
/* Particles per thread at least: below, the threads' start and join cost more than they
 * save (the search of 4096 particles takes about a millisecond). */
#define RS_PARTICLES_PER_THREAD 4096
/* Cells per s (Method 1) along each side: each particle looks only as far as its own
 * reach needs, so that small particles beside large ones look at fewer partners. */
#ifndef RS_CELL_DIVISIONS
#define RS_CELL_DIVISIONS 4
#endif

/* A particle's state before the resolution, as the exact tests read it.  Made from
 * r->particles and the particle's rs_sheet_point when a test needs it (rs_state), and saved
 * only for the particles that collide, before their first collision changes them
 * (rs_save): the per-particle passes write and read 40 bytes instead of these 128. */
struct rs_sheet_particle {
    double xw, yw;          /* [m] position wrapped into the primary box */
    double z;               /* [m] current position */
    double reach;           /* [m] radius + dt x speed relative to the shear flow */
    int64_t index;          /* in r->particles */
    double x, y;            /* [m] current position */
    double vx, vy, vz;      /* [m/s] current velocity */
    double radius;          /* [m] */
    double ox, oy, ovy;     /* [m], [m], [m/s] wrapped minus current coordinates */
};

/* A particle within the current step (indexed like r->particles). */
struct rs_sheet_track {
    double deviation;       /* [m] D of Method 7: bound on the distance from its first path */
    int64_t last;           /* serial of its last collision in this step, 0: none */
    int64_t contacts;       /* collisions in this step that deflected it (Method 8) */
    int64_t saved;          /* 1 + its slot in d->saved, 0: not saved (not collided) */
    int64_t wide;           /* 1: in d->wide (Method 9) */
};

/* A contact on the paths of the moment it was computed. */
struct rs_event {
    double back_time;       /* [s] before the end of the step */
    int64_t last1, last2;   /* serials of p1's and p2's last collisions then */
    struct reb_collision c; /* p1 < p2, gb of p1 */
};

/* A particle when its neighbour list was built (Method 9), by index. */
struct rs_sheet_anchor {
    double x, y, z;         /* [m] wrapped position */
    double reach;           /* [m] */
    double skin;            /* [m] b_i of Method 9 */
};

/* The pairs (lo, hi) one thread listed in its share of a list build, in search order. */
struct rs_index_pairs {
    int64_t n;
    int64_t capacity;
    int32_t* items;         /* 2 per pair */
    int ok;                 /* 0 if memory ran out */
};

/* Pairs one thread found in its share of the search, in search order. */
struct rs_pair_list {
    int64_t n;
    int64_t capacity;
    struct reb_collision* items;
    int64_t candidates;     /* pairs whose path was tested */
    int ok;                 /* 0 if memory ran out */
};

/* The cell grid of the last search. */
struct rs_sheet_grid {
    double Lx, Ly;          /* [m] box */
    double slide;           /* [m] y offset a of the ghost box at x + Lx */
    double box_speed;       /* [m/s] 1.5 Omega Lx */
    double shear_step;      /* 1.5 |Omega| dt */
    double dt;              /* [s] */
    double sx, sy, sz;      /* [m] cell sides (sz infinite with one layer) */
    double pair_reach;      /* [m] s of Method 1: the largest distance of a pair in reach */
    double z_min;           /* [m] bottom of the lowest layer */
    double z_range;         /* [m] height of the particles' range */
    double reach_max;       /* [m] */
    double slack;           /* [m] widening of the wrapped-coordinate pre-test (rs_cell_report) */
    double kick_time;       /* [s] back time of the step's kick (Method 1a), 0: no kick */
    double shear_rate;      /* [1/s] 1.5 Omega (0 without the shear boundary) */
    double reach_min;       /* [m] least reach of the step */
    double excess_rms;      /* [m] rms of reach minus radius over the particles */
    double budget_min;      /* [m] least m_i of Method 9 (-infinity: no list) */
    int half_shell;         /* 1: each pair of one box looked at from one side (Method 3) */
};

struct rs_sheet_detector {
    int64_t particle_capacity;
    struct rs_sheet_point* wrapped;         /* by particle index */
    struct rs_sheet_point* points;          /* by cell */
    struct rs_sheet_particle* saved;        /* the states before resolution of the particles
                                             * that collided in this step (rs_save) */
    int64_t n_saved;
    int64_t saved_capacity;
    struct rs_sheet_track* track;           /* by particle index */
    int64_t track_n;                /* particles the track was last cleared for (0: never) */
    int32_t* cell_of;               /* the sort's cell of each particle */
    int64_t cell_capacity;
    int32_t* cell_start;            /* n_cells + 1 entries (slots: n < INT32_MAX) */
    int32_t* counts;                /* the sort's per-thread cell counts, then totals */
    int64_t count_capacity;
    int64_t n_collisions;
    struct reb_collision* collisions;       /* the lists of all threads, in thread order */
    int64_t collision_capacity;
    struct rs_pair_list* lists;             /* one per thread */
    int64_t list_capacity;
    int threads;                            /* OpenMP threads of the search (>= 1) */
    int team_last;                          /* threads the last search ran on */
    int64_t event_capacity;
    int64_t n_events;
    struct rs_event* events;        /* binary heap, earliest contact at the root */
    struct rs_sheet_grid grid;
    int class_limit;                /* reach classes at most (Method 2a), 1: one grid */
    int n_classes;                  /* classes of the last search (1: one grid) */
    int classes_used;               /* of which held particles */
    int one_grid_steps;             /* steps to search in one grid before classes are
                                     * weighed again (Method 2a) */
    struct rs_cell_grid cells[RS_MAX_CLASSES];      /* by class, largest reaches first */
    uint8_t* class_of;              /* each particle's class, by index (n_classes > 1) */
    int64_t class_capacity;
    const struct reb_particle* particles;   /* r->particles of the last search (kicks) */
    int64_t n_cells_step;           /* cells of this step's grid */
    int grid_sorted;                /* this step's counting sort is done */
    /* Method 9: the neighbour list */
    int list_steps;                 /* steps a list is built to last, 0: no lists */
    int list_ready;                 /* the list and its anchors hold list_n particles */
    int list_on;                    /* this step's search and re-checks use the list */
    int list_retry;                 /* steps before a list is weighed again */
    int64_t list_n;
    double list_time;               /* [s] r->t when the list was built */
    double list_a;                  /* the list's relative widening of each pair's reaches */
    double list_skin_floor;         /* [m] the least skin b_i */
    double list_skin_scale;         /* b_i per metre moved in a step: (steps + 1) / keep */
    double list_reach_of[RS_MAX_CLASSES];   /* [m] largest list reach of each class */
    double list_reach_min, list_reach_max;  /* [m] the reaches then */
    double list_Lx, list_Ly, list_shear_rate;   /* [m], [m], [1/s] the box and flow then */
    double list_margin;             /* [m] M of Method 9 at this step */
    struct rs_sheet_anchor* anchors;        /* by particle index */
    int64_t anchor_capacity;
    int32_t* list_pairs;            /* (lo, hi), 2 per pair */
    int64_t list_pair_n;
    int64_t list_pair_capacity;
    int32_t* partner_start;         /* list_n + 1 entries */
    int64_t partner_start_capacity;
    int32_t* partners;              /* each particle's listed partners */
    int64_t partner_capacity;
    struct rs_index_pairs* builders;        /* one per thread */
    int64_t builder_capacity;
    int list_half_shell[RS_MAX_CLASSES];    /* 1: the build looks at each pair of the
                                             * class's grid from one side (Method 3) */
    int64_t* wide;                  /* the particles of this step with D >= M / 2 */
    int64_t* stamp;                 /* by index: the re-check that last listed it (0: none;
                                     * serials only grow, so an old stamp never matches) */
    int64_t stamp_capacity;
    int64_t stamp_serial;           /* re-checks through the list so far */
    int64_t n_wide;
    int64_t wide_capacity;
    int64_t list_builds;            /* counters */
    int64_t list_steps_used;
    int64_t list_fallbacks;
    int64_t list_wide_checks;       /* unlisted partners of large deviation re-checked */
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
    int64_t wide_rechecks;          /* of which over more than s */
    int64_t span_limited;           /* of which cut at RS_MAX_SPAN s */
    int64_t saturated;              /* particles that reached RS_MAX_CONTACTS deflecting
                                     * contacts in a step */
};

static void rs_sheet_detector_free(struct rs_sheet_detector* d){
    if (d == NULL){
        return;
    }
    free(d->wrapped);
    free(d->saved);
    free(d->points);
    free(d->track);
    free(d->cell_of);
    free(d->cell_start);
    free(d->class_of);
    free(d->counts);
    free(d->collisions);
    for (int64_t k = 0; k < d->list_capacity; k++){
        free(d->lists[k].items);
    }
    free(d->lists);
    free(d->events);
    free(d->anchors);
    free(d->list_pairs);
    free(d->partner_start);
    free(d->partners);
    free(d->wide);
    free(d->stamp);
    for (int64_t k = 0; k < d->builder_capacity; k++){
        free(d->builders[k].items);
    }
    free(d->builders);
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

/* Grows *buffer to exactly `needed` items of `item` bytes if it holds fewer, the new ones
 * zeroed (the threads' lists, one per thread).  Returns 0 if memory ran out. */
static int rs_grow_cleared(void** buffer, int64_t* capacity, int64_t needed, size_t item){
    if (*capacity >= needed){
        return 1;
    }
    char* grown = realloc(*buffer, (size_t)needed * item);
    if (grown == NULL){
        return 0;
    }
    memset(grown + (size_t)*capacity * item, 0, (size_t)(needed - *capacity) * item);
    *buffer = grown;
    *capacity = needed;
    return 1;
}

/* Number of the calling thread in the current OpenMP team (0 without OpenMP). */
static int rs_thread_id(void){
#ifdef _OPENMP
    return omp_get_thread_num();
#else
    return 0;
#endif
}

/* Number of threads in the current OpenMP team (1 without OpenMP). */
static int rs_team_threads(void){
#ifdef _OPENMP
    return omp_get_num_threads();
#else
    return 1;
#endif
}

/* Threads for a loop over n particles: d->threads, fewer if each would get fewer than
 * RS_PARTICLES_PER_THREAD particles. */
static int rs_team_size(const struct rs_sheet_detector* d, int64_t n){
    const int64_t useful = n / RS_PARTICLES_PER_THREAD;
    const int64_t team = d->threads < useful ? d->threads : useful;
    return team >= 1 ? (int)team : 1;
}

/* floor(a / b) for b > 0 (cell offsets beyond the grid): the box a cell offset a of a
 * side of b cells lies in.  A scan looks at most one box away, so a is almost always in
 * [-b, 2b) and the answer is -1, 0 or 1 without a division (an integer division costs as
 * much as a row of the scan). */
static inline int64_t rs_floor_div(int64_t a, int64_t b){
    if (a >= -b && a < 2 * b){
        return (int64_t)(a >= b) - (int64_t)(a < 0);
    }
    const int64_t q = a / b;
    return (a % b != 0 && a < 0) ? q - 1 : q;
}

static int rs_report(struct rs_pair_list* out, size_t p1, size_t p2, struct reb_vec6d gb){
    if (!rs_grow((void**)&out->items, &out->capacity, out->n + 1,
                 sizeof(struct reb_collision))){
        return 0;
    }
    struct reb_collision* c = &out->items[out->n++];
    c->p1 = p1;
    c->p2 = p2;
    c->gb = gb;
    c->ri = 0;
    return 1;
}

/* ---------------------------------------------------------------------------------- */
/* Contacts in time order (Method 5-8).                                               */

/* A pair's relative path over one straight piece: dr(s) = dr - s dv [m, m/s]. */
struct rs_piece {
    double dx, dy, dz;
    double dvx, dvy, dvz;
};

/* Method 1a: the piece before the kick of the piece after it (p1, p2: the pair, for their
 * accelerations; dt [s] the step, kick_time [s] the kick's back time), in the back time
 * s - kick_time: it starts at dr(kick_time), its velocity lacks the kick difference. */
static inline struct rs_piece rs_before_kick(const struct rs_piece after,
                                             const struct reb_particle* p1,
                                             const struct reb_particle* p2, double dt,
                                             double kick_time){
    const struct rs_piece before = {
        after.dx - kick_time * after.dvx, after.dy - kick_time * after.dvy,
        after.dz - kick_time * after.dvz,
        after.dvx - (p1->ax - p2->ax) * dt, after.dvy - (p1->ay - p2->ay) * dt,
        after.dvz - (p1->az - p2->az) * dt};
    return before;
}

/* Back time [s] of the next contact of a pair on the straight relative path dr(s) = dr -
 * s dv within the last `window` of it: the entry into contact if it is in (0, window],
 * `window` itself if the pair touches then and approaches; 0 if none. */
static double rs_line_contact(double dx, double dy, double dz, double dvx, double dvy,
                              double dvz, double sum_radii, double window){
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

/* Back time [s] of pair c's next contact on the current paths within the last `window` of
 * the step (rs_line_contact's rule).  With a kick (Method 1a) the path is two straight
 * pieces: dr - s dv after the kick (s <= kick_time), dr(kick_time) - (s - kick_time)
 * (dv - dk) before it; the earlier piece is searched first. */
static double rs_contact_back_time(const struct reb_simulation* const r,
                                   const struct reb_collision c, double window,
                                   double kick_time){
    const struct reb_particle* const p1 = &r->particles[c.p1];
    const struct reb_particle* const p2 = &r->particles[c.p2];
    const double dx = p1->x + c.gb.x - p2->x;
    const double dy = p1->y + c.gb.y - p2->y;
    const double dz = p1->z + c.gb.z - p2->z;
    const double dvx = p1->vx + c.gb.vx - p2->vx;
    const double dvy = p1->vy + c.gb.vy - p2->vy;
    const double dvz = p1->vz + c.gb.vz - p2->vz;
    const double sum_radii = p1->r + p2->r;
    if (kick_time > 0.0 && window > kick_time){
        const struct rs_piece b = rs_before_kick(
            (struct rs_piece){dx, dy, dz, dvx, dvy, dvz}, p1, p2, r->dt_last_done, kick_time);
        const double before = rs_line_contact(b.dx, b.dy, b.dz, b.dvx, b.dvy, b.dvz,
                                              sum_radii, window - kick_time);
        if (before > 0.0){
            return kick_time + before;
        }
        window = kick_time;
    }
    return rs_line_contact(dx, dy, dz, dvx, dvy, dvz, sum_radii, window);
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
    const double back_time = rs_contact_back_time(r, c, window, d->grid.kick_time);
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
 * their last collisions are the one between them (Method 8; unless that collision came
 * before the step's kick, which may turn them back towards each other: Method 1a), or
 * either has its fill of contacts. */
static int rs_recheck_pair(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                           int64_t i, int64_t j, struct reb_vec6d gb, double window){
    const struct rs_sheet_track* ti = &d->track[i];
    const struct rs_sheet_track* tj = &d->track[j];
    const int kicked_since = d->grid.kick_time > 0.0 && window > d->grid.kick_time;
    if ((ti->last == tj->last && ti->last != 0 && !kicked_since)
        || ti->contacts >= RS_MAX_CONTACTS || tj->contacts >= RS_MAX_CONTACTS){
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

/* How many box widths L [m] position x [m] lies beyond the primary box, [-L/2, L/2),
 * floor((x + L / 2) / L): rs_wrap, rs_state and rs_image_of use it, so the wraps they find
 * are the same to the bit.  Inside the box and the next one on either side, well away
 * from their edges, the quotient cannot round across a whole number, and the answer is
 * found without the division. */
static inline double rs_box_count(double x, double L){
    const double t = x + 0.5 * L;
    if (t > 0.0 && t <= 0.99 * L){
        return 0.0;
    }
    if (t >= L && t <= 1.99 * L){
        return 1.0;
    }
    if (t >= -0.99 * L && t <= -1e-9 * L){
        return -1.0;
    }
    return floor(t / L);
}

/* The image of particle pi in the frame of the box of index box_x (0: the primary box) in x:
 * its x, y offsets [m] and vy offset [m/s] (y wrapped back into the primary box's range:
 * y), and the y cell of the image. */
struct rs_image {
    double x, y, vy;
    int64_t cell_y;
};

static inline struct rs_image rs_image_at(const struct rs_sheet_grid* g, double yw,
                                         int64_t box_x, double* yq_out){
    struct rs_image im;
    im.x = -(double)box_x * g->Lx;
    im.vy = (double)box_x * g->box_speed;
    double image_y = (double)box_x * g->slide;
    double yq = yw + image_y;
    const double wrap_y = rs_box_count(yq, g->Ly);
    yq -= wrap_y * g->Ly;
    im.y = image_y - wrap_y * g->Ly;
    im.cell_y = 0;
    *yq_out = yq;   /* the image's y, wrapped into the primary box's range [m] */
    return im;
}

static struct rs_image rs_image_of(const struct rs_sheet_grid* g, const struct rs_cell_grid* c,
                                   double yw, int64_t box_x){
    double yq;
    struct rs_image im = rs_image_at(g, yw, box_x, &yq);
    im.cell_y = rs_cell_coordinate(yq, -0.5 * g->Ly, c->iy, c->ny);
    return im;
}

/* Cells a search over `distance` [m] looks at on each side along an axis of cells of
 * 1 / inverse [m], at least 1 and at most n (one box either side). */
static inline int64_t rs_span_of(double distance, double inverse, int64_t n){
    const double cells = ceil(distance * inverse);
    return cells >= 1.0 ? (cells < (double)n ? (int64_t)cells : n) : 1;
}

/* Particle i's state as rs_wrap found it: from d->particles (unchanged until the particle
 * first collides in the step) and its wrapped point, with the same operations as rs_wrap's
 * (the same bits). */
static inline struct rs_sheet_particle rs_state(const struct rs_sheet_detector* d, int64_t i){
    const struct reb_particle* const p = &d->particles[i];
    const struct rs_sheet_point* const w = &d->wrapped[i];
    const double mx = rs_box_count(p->x, d->grid.Lx);
    return (struct rs_sheet_particle){
        .xw = w->xw, .yw = w->yw, .z = p->z, .reach = w->reach, .index = i,
        .x = p->x, .y = p->y, .vx = p->vx, .vy = p->vy, .vz = p->vz, .radius = p->r,
        .ox = w->xw - p->x, .oy = w->yw - p->y, .ovy = mx * d->grid.box_speed};
}

/* Particle i's state before the resolution: saved if it has collided in this step. */
static inline struct rs_sheet_particle rs_before(const struct rs_sheet_detector* d, int64_t i){
    const int64_t saved = d->track[i].saved;
    return saved > 0 ? d->saved[saved - 1] : rs_state(d, i);
}

/* Saves particle i's state before the resolution changes it (once a step).  Returns 0 if
 * memory ran out. */
static int rs_save(struct rs_sheet_detector* d, int64_t i){
    if (d->track[i].saved > 0){
        return 1;
    }
    if (!rs_grow((void**)&d->saved, &d->saved_capacity, d->n_saved + 1,
                 sizeof(struct rs_sheet_particle))){
        return 0;
    }
    d->saved[d->n_saved++] = rs_state(d, i);
    d->track[i].saved = d->n_saved;
    return 1;
}

/* The ghost-box offset REBOUND's collision record carries for the pair (pi, pj) seen
 * through the image (image_x, gy_i, image_vy): the image plus the wraps of both particles. */
static inline struct reb_vec6d rs_image_offset(const struct rs_sheet_particle* pi,
                                               const struct rs_sheet_particle* pj,
                                               double image_x, double gy_i, double image_vy){
    struct reb_vec6d gb;
    gb.x = pi->ox + image_x - pj->ox;
    gb.y = pi->oy + gy_i - pj->oy;
    gb.z = 0.0;
    gb.vx = 0.0;
    gb.vy = pi->ovy + image_vy - pj->ovy;
    gb.vz = 0.0;
    return gb;
}

/* Closest approach of the straight relative path dr(s) = dr - s dv, 0 <= s <= duration,
 * within sum_radii: REBOUND's linetree criterion. */
static inline int rs_line_touches(double dx, double dy, double dz, double dvx, double dvy,
                                  double dvz, double sum_radii, double duration){
    const double dv2 = dvx * dvx + dvy * dvy + dvz * dvz;
    double s_closest = dv2 > 0.0 ? (dx * dvx + dy * dvy + dz * dvz) / dv2 : 0.0;
    s_closest = s_closest < 0.0 ? 0.0 : (s_closest > duration ? duration : s_closest);
    const double ex = dx - s_closest * dvx;
    const double ey = dy - s_closest * dvy;
    const double ez = dz - s_closest * dvz;
    return ex * ex + ey * ey + ez * ez <= sum_radii * sum_radii;
}

/* Method 4 on the step's paths: straight over dt without a kick; with one (Method 1a), the
 * piece after the kick (s <= kick_time) and the piece before it, whose relative velocity
 * lacks the kick difference (p1, p2: the particles, for their accelerations). */
static int rs_path_touches(double dx, double dy, double dz, double dvx, double dvy,
                           double dvz, double sum_radii, double dt, double kick_time,
                           const struct reb_particle* p1, const struct reb_particle* p2){
    if (!(kick_time > 0.0)){
        return rs_line_touches(dx, dy, dz, dvx, dvy, dvz, sum_radii, dt);
    }
    if (rs_line_touches(dx, dy, dz, dvx, dvy, dvz, sum_radii, kick_time)){
        return 1;
    }
    const struct rs_piece b = rs_before_kick((struct rs_piece){dx, dy, dz, dvx, dvy, dvz},
                                             p1, p2, dt, kick_time);
    return rs_line_touches(b.dx, b.dy, b.dz, b.dvx, b.dvy, b.dvz, sum_radii, dt - kick_time);
}

/* The ghost-box offset of the pair (lo, hi), lo of lower index, as the search from lo
 * computes it (rs_scan, rs_cell_report) when hi has found the pair through the box box_x
 * [boxes in x] (Method 2a: a pair across the radial boundary is looked for from its
 * particle of the smaller class, which may have the higher index).  lo looks through the
 * box -box_x; its y box is the one that brings hi nearest, the only one within reach in a
 * box wider than two spans of the widest search (yw_lo, yw_hi [m]: wrapped y). */
static struct reb_vec6d rs_offset_of_lower(const struct rs_sheet_grid* g,
                                           const struct rs_cell_grid* c,
                                           const struct rs_sheet_particle* lo,
                                           const struct rs_sheet_particle* hi, int64_t box_x){
    const struct rs_image im = rs_image_of(g, c, lo->yw, -box_x);
    const double box_y = nearbyint((lo->yw + im.y - hi->yw) / g->Ly);
    const double gy = im.y - box_y * g->Ly;
    return rs_image_offset(lo, hi, im.x, gy, im.vy);
}

/* Method 4 for the pair (pi, pj), pi of lower index, seen through the ghost-box offset gb
 * of pi: reported to `out` if it is within the bound of Method 1 and its straight relative
 * path touched within the step.  Returns 0 if memory ran out. */
static int rs_test_pair(const struct rs_sheet_grid* g, const struct rs_sheet_detector* d,
                        const struct rs_sheet_particle* pi, const struct rs_sheet_particle* pj,
                        struct reb_vec6d gb, struct rs_pair_list* out){
    const double dx = pi->x + gb.x - pj->x;
    const double dy = pi->y + gb.y - pj->y;
    const double dz = pi->z - pj->z;
    const double bound = pi->reach + pj->reach + g->shear_step * fabs(dx);
    if (dx * dx + dy * dy + dz * dz > bound * bound){
        return 1;
    }
    out->candidates++;
    const double dvx = pi->vx - pj->vx;
    const double dvy = pi->vy + gb.vy - pj->vy;
    const double dvz = pi->vz - pj->vz;
    const double sum_radii = pi->radius + pj->radius;
    if (!rs_path_touches(dx, dy, dz, dvx, dvy, dvz, sum_radii, g->dt, g->kick_time,
                         &d->particles[pi->index], &d->particles[pj->index])){
        return 1;
    }
    return rs_report(out, (size_t)pi->index, (size_t)pj->index, gb);
}

/* Method 3-4 in the cells [first, end) of the sorted particles (a run of cells of one
 * row) for particle pi (image
 * offsets image_x, gy_i, image_vy of the box box_x): every partner j > i (every partner j
 * with `all`) within the bound of Method 1 whose straight relative path touched pi's
 * within the step goes to `out`, as the search from the particle of lower index sees it.
 *
 * The bound is first tested on the compact points in wrapped coordinates, widened by
 * g->slack (1e-9 of the box) so that it passes every pair the exact test below passes:
 * the wrapped and the unwrapped differences agree to round-off of the box size.  The exact
 * test, and everything reported, is computed from the unwrapped coordinates as before, so
 * the pre-test changes the cost only.  Its branch is taken rarely and predictably (the
 * j > i condition joins it without a branch of its own).  Returns 0 if memory ran out. */
static int rs_cell_report(const struct rs_sheet_grid* g, const struct rs_sheet_detector* d,
                          const struct rs_sheet_point* p, int64_t first, int64_t end,
                          const struct rs_cell_grid* c, int64_t box_x,
                          double image_x, double gy_i, double image_vy,
                          struct rs_pair_list* out, int all){
    const struct rs_sheet_point* const points = d->points;
    const double xi = p->xw + image_x;
    const double yi = p->yw + gy_i;
    const double reach_i = p->reach + g->slack;
    for (int64_t b = first; b < end; b++){
        const struct rs_sheet_point* q = &points[b];
        const double dxw = xi - q->xw;
        const double dyw = yi - q->yw;
        const double dzw = p->z - q->z;
        const double wide = reach_i + q->reach + g->shear_step * fabs(dxw);
        const int near = dxw * dxw + dyw * dyw + dzw * dzw <= wide * wide;
        const int later = q->index > p->index;
        if (!(near & (later | all))){
            continue;
        }
        /* the pair as the search from its particle of lower index sees it: p1 < p2, gb of
         * p1; in the primary box the other side's y offset is -gy_i, exactly (gy_i is a
         * whole number of box lengths there), with the sign of a zero kept; across the
         * radial boundary the other side's image is found again (rs_offset_of_lower) */
        const struct rs_sheet_particle si = rs_state(d, later ? p->index : q->index);
        const struct rs_sheet_particle sj = rs_state(d, later ? q->index : p->index);
        const struct rs_sheet_particle* const pi = &si;
        const struct rs_sheet_particle* const pj = &sj;
        const double gy = later || gy_i == 0.0 ? gy_i : -gy_i;
        const struct reb_vec6d gb = later || box_x == 0
            ? rs_image_offset(pi, pj, image_x, gy, image_vy)
            : rs_offset_of_lower(g, c, pi, pj, box_x);
        if (!rs_test_pair(g, d, pi, pj, gb, out)){
            return 0;
        }
    }
    return 1;
}

/* Method 6-7 for particle pi and partner pj (states before the resolution) seen through
 * pi's image (image_x, gy_i [m], image_vy [m/s]): the pair's next contact within the last
 * `window` of the step is queued if it is within the bound of Method 7.  Returns 0 if
 * memory ran out. */
static int rs_recheck_partner(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                              const struct rs_sheet_particle* pi,
                              const struct rs_sheet_particle* pj, double image_x, double gy_i,
                              double image_vy, double window){
    const struct reb_vec6d gb = rs_image_offset(pi, pj, image_x, gy_i, image_vy);
    const double dx = pi->x + gb.x - pj->x;
    const double dy = pi->y + gb.y - pj->y;
    const double dz = pi->z - pj->z;
    const double bound = (pi->reach + pj->reach + d->grid.shear_step * fabs(dx))
                         + (d->track[pi->index].deviation + d->track[pj->index].deviation);
    if (dx * dx + dy * dy + dz * dz > bound * bound){
        return 1;
    }
    return rs_recheck_pair(r, d, pi->index, pj->index, gb, window);
}

/* Method 6-7 in the cells [first, end) of one row for particle pi: partners j != i within
 * the bound of Method 7 get their contacts within the last `window` of the step queued.
 * Returns 0 if memory ran out. */
static int rs_cell_recheck(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                           const struct rs_sheet_point* p, int64_t first, int64_t end,
                           double image_x, double gy_i, double image_vy, double window){
    const struct rs_sheet_point* const points = d->points;
    const struct rs_sheet_particle si = rs_before(d, p->index);
    const struct rs_sheet_particle* const pi = &si;
    const double deviation_i = d->track[pi->index].deviation;
    const double shear_step = d->grid.shear_step;
    const double xi = p->xw + image_x;
    const double yi = p->yw + gy_i;
    /* the pre-test of rs_cell_report, widened by the largest deviations */
    const double reach_i = p->reach + d->grid.slack + deviation_i + d->deviation_max;
    for (int64_t b = first; b < end; b++){
        const struct rs_sheet_point* q = &points[b];
        const double dxw = xi - q->xw;
        const double dyw = yi - q->yw;
        const double dzw = p->z - q->z;
        const double wide = reach_i + q->reach + shear_step * fabs(dxw);
        const int near = dxw * dxw + dyw * dyw + dzw * dzw <= wide * wide;
        if (!(near & (q->index != p->index))){
            continue;
        }
        const struct rs_sheet_particle sj = rs_before(d, q->index);
        if (!rs_recheck_partner(r, d, pi, &sj, image_x, gy_i, image_vy, window)){
            return 0;
        }
    }
    return 1;
}

/* Method 9 in the cells [first, end) of one row for particle p seen through its image
 * (image_x, gy_i [m]): every partner j > i (every partner with `all`) within the sum of
 * their list reaches (1 + a) rho + b, which the build keeps in the points' reach, goes to
 * `out` as (lower index, higher index).  The distance is taken in wrapped coordinates and
 * widened by g->slack, so that every pair within the reach in unwrapped coordinates is
 * listed.  Returns 0 if memory ran out. */
static int rs_cell_list(const struct rs_sheet_detector* d, const struct rs_sheet_point* p,
                        int64_t first, int64_t end, double image_x, double gy_i,
                        struct rs_index_pairs* out, int all){
    const struct rs_sheet_point* const points = d->points;
    const double slack = d->grid.slack;
    const double xi = p->xw + image_x;
    const double yi = p->yw + gy_i;
    for (int64_t b = first; b < end; b++){
        const struct rs_sheet_point* q = &points[b];
        const double dxw = xi - q->xw;
        const double dyw = yi - q->yw;
        const double dzw = p->z - q->z;
        const double cutoff = p->reach + q->reach + slack;     /* list reaches here */
        const int near = dxw * dxw + dyw * dyw + dzw * dzw <= cutoff * cutoff;
        const int later = q->index > p->index;
        if (!(near & (later | all))){
            continue;
        }
        if (!rs_grow((void**)&out->items, &out->capacity, 2 * (out->n + 1), sizeof(int32_t))){
            return 0;
        }
        out->items[2 * out->n] = (int32_t)(later ? p->index : q->index);
        out->items[2 * out->n + 1] = (int32_t)(later ? q->index : p->index);
        out->n++;
    }
    return 1;
}

enum RS_SCAN {
    RS_SCAN_REPORT = 0,     /* Method 3-4: partners j > i, report swept contacts (to out) */
    RS_SCAN_RECHECK = 1,    /* Method 6-7: partners j != i, queue their next contacts */
    RS_SCAN_LARGER = 2,     /* Method 2a: all partners of a class of larger reaches, report */
    RS_SCAN_LIST = 3,       /* Method 9: partners j > i within the list's reach, list them */
    RS_SCAN_LIST_LARGER = 4,        /* Method 9 in a class of larger reaches: all partners */
};

/* Looks at every cell of the grid c within `distance` [m] of particle pi (state before the
 * resolution) in x, y and z, each image of the shear-periodic box once.  The cells of one
 * row (same y, z) that belong to one box are consecutive in the sorted particles, so a row
 * is one run: the cost is per particle looked at, hardly per cell.  REPORT and LARGER
 * read the detector only and write to `out` (threads may scan different particles at
 * once); RECHECK queues contacts within the last `window` of the step.  Returns 0 if
 * memory ran out. */
static int rs_scan(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                   const struct rs_cell_grid* c, const struct rs_sheet_point* pi,
                   double distance, int mode, double window, struct rs_pair_list* out,
                   struct rs_index_pairs* listed){
    const struct rs_sheet_grid* const g = &d->grid;
    const int32_t* const start = d->cell_start + c->cell_base;
    /* at most one box on each side (a box narrower than 2 s is outside the validity
     * limits: images further away are not looked at, as before the cells were split) */
    const int64_t span_x = rs_span_of(distance, c->ix, c->nx);
    const int64_t span_y = rs_span_of(distance, c->iy, c->ny);
    const int64_t span_z = c->nz > 1 ? rs_span_of(distance, c->iz, c->nz) : 0;
    const int64_t cx = rs_cell_coordinate(pi->xw, -0.5 * g->Lx, c->ix, c->nx);
    const int64_t cz = c->nz > 1 ? rs_cell_coordinate(pi->z, c->z_min, c->iz, c->nz) : 0;
    const int64_t layer_low = cz - span_z < 0 ? 0 : cz - span_z;
    const int64_t layer_high = cz + span_z >= c->nz ? c->nz - 1 : cz + span_z;
    /* Method 3's half shell: in the primary box each pair is looked at from one side only,
     * the particle whose row (y cell of the grid, then layer) comes first, or within a row
     * the earlier slot; across the radial boundary, from the particle of lower index */
    const int half = (mode == RS_SCAN_REPORT && c->half_shell)
                     || (mode == RS_SCAN_LIST && d->list_half_shell[c - d->cells]);
    const int64_t cy = half ? rs_cell_coordinate(pi->yw, -0.5 * g->Ly, c->iy, c->ny) : 0;
    const int64_t slot = half ? (int64_t)(pi - d->points) : 0;
    for (int64_t kx = -span_x; kx <= span_x;){
        /* the run of columns from cx + kx to the box's last column or cx + span_x */
        const int64_t box_x = rs_floor_div(cx + kx, c->nx);
        const int64_t first_x = cx + kx - box_x * c->nx;
        const int64_t count = span_x - kx + 1 < c->nx - first_x ? span_x - kx + 1
                                                               : c->nx - first_x;
        const struct rs_image im = rs_image_of(g, c, pi->yw, box_x);
        for (int64_t ky = -span_y; ky <= span_y; ky++){
            const int64_t box_y = rs_floor_div(im.cell_y + ky, c->ny);
            const int64_t column_y = im.cell_y + ky - box_y * c->ny;
            const double gy_i = im.y - (double)box_y * g->Ly;
            for (int64_t layer = layer_low; layer <= layer_high; layer++){
                const int64_t row = (layer * c->ny + column_y) * c->nx;
                int64_t first = start[row + first_x];
                const int64_t end = start[row + first_x + count];
                const int shell = half && box_x == 0;
                if (shell){
                    /* rows of the grid from pi's (antisymmetric: the row is at -row_y
                     * from the partner's, as the box is wider than two spans) */
                    int64_t row_y = column_y - cy;
                    row_y += 2 * row_y < -c->ny ? c->ny : (2 * row_y > c->ny ? -c->ny : 0);
                    if (row_y < 0 || (row_y == 0 && layer < cz)){
                        continue;   /* the partners there look at pi */
                    }
                    if (row_y == 0 && layer == cz){
                        first = slot + 1;   /* pi's row: the slots after pi's */
                    }
                }
                int ok;
                if (mode == RS_SCAN_RECHECK){
                    ok = rs_cell_recheck(r, d, pi, first, end, im.x, gy_i, im.vy, window);
                }else if (mode >= RS_SCAN_LIST){
                    ok = rs_cell_list(d, pi, first, end, im.x, gy_i, listed,
                                      shell || mode == RS_SCAN_LIST_LARGER);
                }else{
                    ok = rs_cell_report(g, d, pi, first, end, c, box_x, im.x, gy_i, im.vy,
                                        out, shell || mode == RS_SCAN_LARGER);
                }
                if (!ok){
                    return 0;
                }
            }
        }
        kx += count;
    }
    return 1;
}

/* Method 9: the squared distance [m^2] of a particle at the wrapped position (xw, yw, z)
 * from the point its anchor a would have reached moving with the shear flow since the list
 * was built (shear_T = 1.5 Omega T [1], T the time since then): |Delta|^2 of Method 9.  The
 * particle's continuous position is its wrapped one in the box (k in x) nearest the anchor
 * (the ghost box k has slid by -k a in y, as in rs_wrap); the y difference is taken in the
 * nearest periodic image.  A drift over a quarter of the box is ambiguous: infinite (the
 * list is then built again). */
static inline double rs_anchor_drift2(const struct rs_sheet_grid* g,
                                      const struct rs_sheet_anchor* a, double xw, double yw,
                                      double z, double shear_T){
    const double half_x = 0.5 * g->Lx;
    const double half_y = 0.5 * g->Ly;
    const double k = a->x - xw > half_x ? 1.0 : (a->x - xw < -half_x ? -1.0 : 0.0);
    const double ex = xw + k * g->Lx - a->x;
    double ey = (yw - k * g->slide) - (a->y - shear_T * a->x);
    ey -= ey > half_y ? g->Ly : (ey < -half_y ? -g->Ly : 0.0);
    ey -= ey > half_y ? g->Ly : (ey < -half_y ? -g->Ly : 0.0);
    if (!(fabs(ey) <= half_y)){
        ey -= g->Ly * nearbyint(ey / g->Ly);    /* a box much wider than long */
    }
    const double ez = z - a->z;
    if (!(fabs(ex) < 0.25 * g->Lx && fabs(ey) < 0.25 * g->Ly && fabs(ez) < INFINITY)){
        return INFINITY;    /* also NaN */
    }
    return ex * ex + ey * ey + ez * ez;
}

/* Method 1: every particle's wrapped position and reach (d->wrapped), and
 * the grid's reach_max and vertical range.  Particles are independent: split over the
 * threads; the maxima and minima do not depend on the order they are taken in.  Returns 0
 * if the state is not finite. */
static int rs_wrap(const struct reb_simulation* const r, struct rs_sheet_detector* d){
    struct rs_sheet_grid* const g = &d->grid;
    const int64_t n = (int64_t)r->N;
    const double Lx = g->Lx;
    const double Ly = g->Ly;
    const double Omega = r->boundary == REB_BOUNDARY_SHEAR ? r->OMEGA : 0.0;
    double reach_max = 0.0;
    double kick_max = 0.0;
    double z_min = INFINITY;
    double z_max = -INFINITY;
    const double kick_time = 0.5 * g->dt;
    double reach_min = INFINITY;
    double excess_sum = 0.0;        /* [m^2] sum of (reach - radius)^2 */
    double budget_min = INFINITY;
    /* a list holds for the box and the flow it was built in (a changed box, Omega or
     * boundary: built again) */
    const int anchored = d->list_ready && d->list_n == n && d->list_Lx == Lx
                         && d->list_Ly == Ly && d->list_shear_rate == g->shear_rate;
    const double shear_T = g->shear_rate * (r->t - d->list_time);
    const double keep_T = (1.0 - fabs(shear_T)) * (1.0 - g->shear_step);
    const double drift_weight = 1.0 - g->shear_step;
#pragma omp parallel for schedule(static) num_threads(rs_team_size(d, n)) \
        reduction(max:reach_max, kick_max, z_max) reduction(+:excess_sum) \
        reduction(min:z_min, reach_min, budget_min)
    for (int64_t i = 0; i < n; i++){
        const struct reb_particle* const p = &r->particles[i];
        const double mx = rs_box_count(p->x, Lx);
        double yw = p->y + mx * g->slide;
        yw -= Ly * floor((yw + 0.5 * Ly) / Ly);
        const double wy = p->vy + 1.5 * Omega * p->x;
        double reach = p->r + g->dt * sqrt(p->vx * p->vx + wy * wy + p->vz * p->vz);
        const double a2 = p->ax * p->ax + p->ay * p->ay + p->az * p->az;
        if (a2 > 0.0){
            /* Method 1a: the piece before the kick leaves the straight line by at most
             * |a| dt (dt - kick_time) */
            const double kick = sqrt(a2) * g->dt;
            reach += kick_time > 0.0 ? kick * (g->dt - kick_time) : 0.0;
            kick_max = fmax(kick_max, kick);
        }
        d->wrapped[i] = (struct rs_sheet_point){p->x - mx * Lx, yw, p->z, reach, i};
        /* fmax/fmin skip NaN, as the comparisons did before */
        reach_max = fmax(reach_max, reach);
        z_min = fmin(z_min, p->z);
        z_max = fmax(z_max, p->z);
        /* comparisons, not fmax/fmin (library calls here): a NaN reach fails above */
        reach_min = reach < reach_min ? reach : reach_min;
        excess_sum += (reach - p->r) * (reach - p->r);
        if (anchored){
            /* m_i = b_i keep - |Delta_i| (1 - 1.5 Omega dt) - (rho_i - rho0_i) */
            const struct rs_sheet_anchor* const a = &d->anchors[i];
            const double drift = sqrt(rs_anchor_drift2(g, a, d->wrapped[i].xw, yw, p->z,
                                                       shear_T));
            const double budget = a->skin * keep_T - drift * drift_weight
                                  - (reach - a->reach);
            budget_min = budget < budget_min ? budget : budget_min;
        }
    }
    if (!isfinite(reach_max) || !isfinite(z_min) || !isfinite(z_max) || !isfinite(kick_max)){
        return 0;
    }
    g->kick_time = kick_max > 0.0 ? kick_time : 0.0;
    g->reach_max = reach_max;
    g->reach_min = reach_min;
    g->excess_rms = sqrt(excess_sum / (double)n);
    g->budget_min = anchored && budget_min > -INFINITY ? budget_min : -INFINITY;
    g->z_min = z_min;
    g->z_range = z_max - z_min;
    return 1;
}

/* Method 2's counting sort of the particles into the cells of d->cells (d->points, and
 * d->cell_start: each cell's first slot, n_cells + 1 entries; rs_sheet_classes.c).
 * Returns 0 if memory ran out. */
static int rs_counting_sort(struct rs_sheet_detector* d, int64_t n, int64_t n_cells){
    const int asked = rs_team_size(d, n);
    int64_t capacity = d->count_capacity;
    if (n_cells >= INT32_MAX || n >= INT32_MAX
        || !rs_grow((void**)&d->counts, &capacity, (int64_t)asked * (n_cells + 1),
                    sizeof(int32_t))){
        return 0;
    }
    d->count_capacity = capacity;
    rs_sheet_counting_sort(d->wrapped, d->points, n, asked, d->cells,
                           d->n_classes > 1 ? d->class_of : NULL, d->grid.Lx, d->grid.Ly,
                           d->counts, d->cell_of, d->cell_start, n_cells);
    return 1;
}

/* Method 2a: a grid per reach class (d->cells, classes > 1), each cell of all classes one
 * index of d->cell_start (rs_sheet_classes.c).  Returns the number of cells, 0 if the
 * classes are not used (then the search uses one grid).  Returns 0 also if memory for the
 * classes ran out: one grid needs none. */
static int64_t rs_class_layout(struct rs_sheet_detector* d, int64_t n){
    const int classes = d->class_limit < RS_MAX_CLASSES ? d->class_limit : RS_MAX_CLASSES;
    if (d->one_grid_steps > 0){
        d->one_grid_steps--;
        return 0;
    }
    if (classes < 2 || !rs_grow((void**)&d->class_of, &d->class_capacity, n, sizeof(uint8_t))){
        return 0;
    }
    const struct rs_sheet_grid* const g = &d->grid;
    const int used = rs_sheet_classify(d->wrapped, n, rs_team_size(d, n), g->reach_max,
                                       classes, d->class_of, d->cells);
    /* the one grid rs_grid_layout would lay out, for the comparison of their costs */
    struct rs_cell_grid one = {.z_min = g->z_min, .z_range = g->z_range,
                               .reach_max = g->reach_max, .n = n};
    const int64_t n_cells = used < 2 ? 0
        : rs_sheet_class_layout(d->cells, classes, g->Lx, g->Ly, g->slack, g->shear_step,
                                g->reach_max, &one, g->pair_reach / RS_CELL_DIVISIONS);
    if (n_cells > 0){
        d->n_classes = classes;
        d->classes_used = used;
    }else{
        /* the size distribution changes slowly: look again in RS_CLASS_RETRY steps */
        d->one_grid_steps = RS_CLASS_RETRY;
    }
    return n_cells;
}

/* Method 2: the cells (one grid, or a grid per reach class: Method 2a), laid out every
 * step, whether or not the particles are sorted into them (rs_grid_sorted), so that the
 * classes' state (d->one_grid_steps) is the same as if they were.  Returns 0 if memory ran
 * out. */
static int rs_grid_layout(struct rs_sheet_detector* d, int64_t n){
    struct rs_sheet_grid* const g = &d->grid;
    /* s: the largest distance at which two particles can touch within the step */
    const double s = rs_sheet_pair_reach(g->reach_max, g->shear_step);
    g->pair_reach = s;
    /* round-off of coordinates of the box's size, far below any reach (rs_cell_report) */
    g->slack = 1e-9 * (g->Lx + g->Ly + fabs(g->z_min) + g->z_range);
    d->n_classes = 1;
    d->classes_used = 1;
    int64_t n_cells = rs_class_layout(d, n);
    if (n_cells == 0){
        struct rs_cell_grid* const c = &d->cells[0];
        *c = (struct rs_cell_grid){.z_min = g->z_min, .z_range = g->z_range,
                                   .reach_max = g->reach_max, .n = n};
        d->n_classes = 1;
        d->classes_used = 1;
        n_cells = rs_sheet_cell_layout(c, g->Lx, g->Ly, g->slack, s, s / RS_CELL_DIVISIONS);
    }
    g->half_shell = d->cells[0].half_shell;
    int64_t capacity = d->cell_capacity;
    if (!rs_grow((void**)&d->cell_start, &capacity, n_cells + 1, sizeof(int32_t))){
        return 0;
    }
    d->cell_capacity = capacity;
    d->cells_last = n_cells;
    d->cell_size_last = d->cells[0].side;
    d->n_cells_step = n_cells;
    d->grid_sorted = 0;
    return 1;
}

/* Method 2's counting sort of this step's particles into its grid (stable: a cell holds
 * its particles in index order) into d->points, once a step.  Returns 0 if memory ran
 * out. */
static int rs_grid_sorted(struct rs_sheet_detector* d, int64_t n){
    if (d->grid_sorted){
        return 1;
    }
    d->grid_sorted = rs_counting_sort(d, n, d->n_cells_step);
    return d->grid_sorted;
}

/* Method 3-4 for particle pi: the grid of its class (Method 3's pairs), and with classes
 * (Method 2a) the grids of the classes of larger reaches (all their partners), each over
 * the distance (rho_i + largest rho of the grid) / (1 - 1.5 Omega dt).  Returns 0 if
 * memory ran out. */
static int rs_search_from(struct rs_sheet_detector* d, const struct rs_sheet_point* pi,
                          struct rs_pair_list* out){
    const struct rs_sheet_grid* const g = &d->grid;
    if (d->n_classes == 1){
        const double distance = (pi->reach + g->reach_max) / (1.0 - g->shear_step)
                                * (1.0 + 1e-12) + g->slack;
        return rs_scan(NULL, d, &d->cells[0], pi, distance,
                       RS_SCAN_REPORT, 0.0, out, NULL);
    }
    const int own = d->class_of[pi->index];
    for (int k = 0; k <= own; k++){
        const struct rs_cell_grid* c = &d->cells[k];
        if (c->n == 0){
            continue;
        }
        const double distance = (pi->reach + c->reach_max) / (1.0 - g->shear_step)
                                * (1.0 + 1e-12) + g->slack;
        if (!rs_scan(NULL, d, c, pi, distance,
                     k == own ? RS_SCAN_REPORT : RS_SCAN_LARGER, 0.0, out, NULL)){
            return 0;
        }
    }
    return 1;
}

/* Thread `id`'s share [first, end) of the n sorted points of Method 3a, one of `team`
 * contiguous runs (joined in thread order they are the order of a serial search, wherever
 * the runs end).  Their ends balance the work: with reach classes (Method 2a), whose
 * particles are sorted class after class, a particle of class k weighs as many as the
 * grids it looks into (its own and those of the larger classes that hold particles), so
 * that the runs of the small particles, which look into several grids, are shorter; with
 * one grid every particle weighs 1. */
static void rs_search_share(const struct rs_sheet_detector* d, int64_t n, int team, int id,
                            int64_t* first, int64_t* end){
    int64_t start[RS_MAX_CLASSES + 1];
    int64_t weight[RS_MAX_CLASSES];
    int classes = d->n_classes > 1 ? d->n_classes : 1;
    int64_t total = 0;
    if (classes == 1){
        start[0] = 0;
        start[1] = n;
        weight[0] = 1;
        total = n;
    }else{
        int grids = 0;
        for (int k = 0; k < classes; k++){
            const struct rs_cell_grid* c = &d->cells[k];
            start[k] = d->cell_start[c->cell_base];
            grids += c->n > 0;
            weight[k] = grids;
            total += weight[k] * c->n;
        }
        start[classes] = n;
    }
    /* the point at which a run's weight reaches `part` of the total */
    int64_t bound[2];
    for (int side = 0; side < 2; side++){
        const int part = id + side;
        if (part <= 0 || part >= team){
            bound[side] = part <= 0 ? 0 : n;
            continue;
        }
        /* the weight before the bound: total x part / team, without overflow for any n */
        const double target = (double)total * (double)part / (double)team;
        double before = 0.0;
        int64_t at = n;
        for (int k = 0; k < classes; k++){
            const double here = (double)weight[k] * (double)(start[k + 1] - start[k]);
            if (before + here >= target && weight[k] > 0){
                const int64_t step = (int64_t)ceil((target - before) / (double)weight[k]);
                at = start[k] + (step < start[k + 1] - start[k] ? step
                                                                 : start[k + 1] - start[k]);
                break;
            }
            before += here;
        }
        bound[side] = at;
    }
    *first = bound[0];
    *end = bound[1] > bound[0] ? bound[1] : bound[0];
}

/* Method 3-4 for all particles.  The particles are split over d->threads OpenMP threads in
 * contiguous shares (rs_search_share), each thread filling its own list; the lists are
 * joined in thread order, which is the order of a serial search.  The result would not
 * depend on the order anyway: the contacts are resolved in the total order of
 * rs_event_before.  Returns 0 if memory ran out. */
static int rs_reports_start(struct rs_sheet_detector* d, int threads);
static int rs_reports_join(struct rs_sheet_detector* d, int threads);

static int rs_search(struct rs_sheet_detector* d, int64_t n){
    const int threads = rs_team_size(d, n);
    if (!rs_reports_start(d, threads)){
        return 0;
    }
#pragma omp parallel num_threads(threads)
    {
#pragma omp single nowait
        {
            d->team_last = rs_team_threads();
        }
        /* a copy on this thread's stack: no false sharing of the counters */
        struct rs_pair_list list = d->lists[rs_thread_id()];
        int64_t first, end;
        rs_search_share(d, n, rs_team_threads(), rs_thread_id(), &first, &end);
        for (int64_t a = first; a < end; a++){
            if (list.ok && !rs_search_from(d, &d->points[a], &list)){
                list.ok = 0;
            }
        }
        d->lists[rs_thread_id()] = list;
    }
    return rs_reports_join(d, threads);
}

/* The threads' lists of reports, emptied, for a search on `threads` threads.  Returns 0
 * if memory ran out. */
static int rs_reports_start(struct rs_sheet_detector* d, int threads){
    if (!rs_grow_cleared((void**)&d->lists, &d->list_capacity, threads,
                         sizeof(struct rs_pair_list))){
        return 0;
    }
    for (int k = 0; k < threads; k++){
        d->lists[k].n = 0;
        d->lists[k].candidates = 0;
        d->lists[k].ok = 1;
    }
    d->team_last = 1;
    return 1;
}

/* The threads' lists of reports joined in thread order into d->collisions.  Returns 0 if
 * memory ran out. */
static int rs_reports_join(struct rs_sheet_detector* d, int threads){
    int64_t total = 0;
    int ok = 1;
    for (int k = 0; k < threads; k++){
        total += d->lists[k].n;
        d->candidates += d->lists[k].candidates;
        ok &= d->lists[k].ok;
    }
    if (!ok || !rs_grow((void**)&d->collisions, &d->collision_capacity, total,
                        sizeof(struct reb_collision))){
        return 0;
    }
    d->n_collisions = 0;
    for (int k = 0; k < threads; k++){
        memcpy(&d->collisions[d->n_collisions], d->lists[k].items,
               (size_t)d->lists[k].n * sizeof(struct reb_collision));
        d->n_collisions += d->lists[k].n;
    }
    return 1;
}

/* ---------------------------------------------------------------------------------- */
/* Method 9: the neighbour list.                                                      */

/* The image of particle a (wrapped xw_a, yw_a [m]) nearest particle b (xw_b, yw_b): the
 * image_x, gy and image_vy the search from a computes when it finds b (rs_scan: the box
 * box_x in x, then the y box), the only image within reach in a box wider than 2 s. */
static inline struct rs_image rs_pair_image(const struct rs_sheet_grid* g, double xw_a,
                                            double yw_a, double xw_b, double yw_b){
    const double dx = xw_a - xw_b;
    const int64_t box_x = dx > 0.5 * g->Lx ? 1 : (dx < -0.5 * g->Lx ? -1 : 0);
    double yq;
    struct rs_image im = rs_image_at(g, yw_a, box_x, &yq);
    const double dy = yq - yw_b;
    const int64_t box_y = dy > 0.5 * g->Ly ? 1 : (dy < -0.5 * g->Ly ? -1 : 0);
    im.y -= (double)box_y * g->Ly;
    return im;
}

/* M of Method 9 at this step [m]: how much the list's reach exceeds the bound of Method 7
 * (without the deviations) for every pair, whatever its reaches, after the particles have
 * used their skins down to the least budget g->budget_min.  With T the time since the build
 * and s_T = 1.5 |Omega| T, a pair not listed had |dr_0| > (1 + a)(rho0_i + rho0_j) + b_i +
 * b_j, and now |dr| >= |dr_0| (1 - s_T) - |Delta_i| - |Delta_j|; it is within the bound
 * only if |dr| <= (rho_i + rho_j + D_i + D_j) / (1 - 1.5 Omega dt).  With keep = (1 - s_T)
 * (1 - 1.5 Omega dt), f = (1 + a) keep and m_i = b_i keep - |Delta_i| (1 - 1.5 Omega dt) -
 * (rho_i - rho0_i) (rs_wrap), that is (f - 1)(rho0_i + rho0_j) + m_i + m_j < D_i + D_j.
 * So no unlisted pair is within it while D_i + D_j < M = 2 (f - 1) rho0 + 2 min m, rho0
 * the least reach at the build if f >= 1, else the largest.  Negative: the list must be
 * built again. */
static double rs_list_margin(const struct rs_sheet_detector* d, double T){
    const struct rs_sheet_grid* const g = &d->grid;
    const double s_T = fabs(g->shear_rate * T);
    if (!(s_T < 0.5) || !(g->budget_min > -INFINITY)){
        return -1.0;
    }
    const double keep = (1.0 - s_T) * (1.0 - g->shear_step);
    const double f = (1.0 + d->list_a) * keep;
    const double pairs = 2.0 * (f - 1.0) * (f >= 1.0 ? d->list_reach_min : d->list_reach_max);
    return pairs + 2.0 * g->budget_min - 16.0 * g->slack;
}

/* Grows d's arrays of the list (beside the anchors) to n particles and `pairs` pairs.
 * Returns 0 if memory ran out. */
static int rs_list_room(struct rs_sheet_detector* d, int64_t n, int64_t pairs){
    return rs_grow_cleared((void**)&d->stamp, &d->stamp_capacity, n, sizeof(int64_t))
        && rs_grow((void**)&d->partner_start, &d->partner_start_capacity, n + 1,
                   sizeof(int32_t))
        && rs_grow((void**)&d->list_pairs, &d->list_pair_capacity, 2 * pairs + 2,
                   sizeof(int32_t))
        && rs_grow((void**)&d->partners, &d->partner_capacity, 2 * pairs + 2,
                   sizeof(int32_t));
}

/* Each particle's listed partners (d->partner_start, d->partners) from the pairs. */
static void rs_list_partners(struct rs_sheet_detector* d, int64_t n){
    int32_t* const start = d->partner_start;
    memset(start, 0, (size_t)(n + 1) * sizeof(int32_t));
    for (int64_t k = 0; k < d->list_pair_n; k++){
        start[d->list_pairs[2 * k] + 1]++;
        start[d->list_pairs[2 * k + 1] + 1]++;
    }
    for (int64_t i = 0; i < n; i++){
        start[i + 1] += start[i];
    }
    for (int64_t k = 0; k < d->list_pair_n; k++){
        const int32_t lo = d->list_pairs[2 * k];
        const int32_t hi = d->list_pairs[2 * k + 1];
        d->partners[start[lo]++] = hi;
        d->partners[start[hi]++] = lo;
    }
    for (int64_t i = n; i > 0; i--){
        start[i] = start[i - 1];
    }
    start[0] = 0;
}

/* Particle pi's partners of Method 9 in the grid of its class and of the classes of
 * larger reaches (as rs_search_from), to `out`.  Returns 0 if memory ran out. */
static int rs_list_from(struct rs_sheet_detector* d, const struct rs_sheet_point* pi,
                        struct rs_index_pairs* out){
    const struct rs_sheet_grid* const g = &d->grid;
    const int own = d->n_classes == 1 ? 0 : d->class_of[pi->index];
    for (int k = 0; k <= own; k++){
        const struct rs_cell_grid* c = &d->cells[k];
        if (c->n == 0){
            continue;
        }
        const double distance = (pi->reach + d->list_reach_of[k]) * (1.0 + 1e-12)
                                + 2.0 * g->slack;
        if (!rs_scan(NULL, d, c, pi, distance, k == own ? RS_SCAN_LIST : RS_SCAN_LIST_LARGER,
                     0.0, NULL, out)){
            return 0;
        }
    }
    return 1;
}

/* Method 9's anchors: each particle's position, reach and skin b_i = (steps + 1) e_i /
 * keep with e_i = rho_i - R_i (what it moves in a step) kept between the skin floor and
 * RS_LIST_FAST times it; and its list reach (1 + a) rho_i + b_i in the sorted points'
 * reach (restored after the build), with the largest of each class. */
static void rs_list_anchor(struct rs_sheet_detector* d, int64_t n){
    const double floor_e = d->list_skin_floor / d->list_skin_scale;
    const int team = rs_team_size(d, n);
#pragma omp parallel for schedule(static) num_threads(team)
    for (int64_t i = 0; i < n; i++){
        const struct rs_sheet_point* w = &d->wrapped[i];
        double e = w->reach - d->particles[i].r;
        e = e > floor_e ? (e < RS_LIST_FAST * floor_e ? e : RS_LIST_FAST * floor_e) : floor_e;
        d->anchors[i] = (struct rs_sheet_anchor){w->xw, w->yw, w->z, w->reach,
                                                 d->list_skin_scale * e};
    }
    for (int k = 0; k < d->n_classes; k++){
        const struct rs_cell_grid* c = &d->cells[k];
        const int64_t first = d->cell_start[c->cell_base];
        const int64_t end = first + c->n;
        double largest = 0.0;
#pragma omp parallel for schedule(static) num_threads(team) reduction(max:largest)
        for (int64_t a = first; a < end; a++){
            const struct rs_sheet_anchor* an = &d->anchors[d->points[a].index];
            const double reach = (1.0 + d->list_a) * an->reach + an->skin;
            d->points[a].reach = reach;
            largest = reach > largest ? reach : largest;
        }
        d->list_reach_of[k] = largest;
    }
}

/* Method 9's build: every pair within the list's reach, from this step's sorted grid, on
 * the search's threads (shares as rs_search_share; joined in thread order, the order of a
 * serial build), the particles' anchors and their partners.  Returns 0 if memory ran out. */
static int rs_list_build(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                         int64_t n){
    const int threads = rs_team_size(d, n);
    if (!rs_grow_cleared((void**)&d->builders, &d->builder_capacity, threads,
                         sizeof(struct rs_index_pairs))){
        return 0;
    }
    for (int k = 0; k < threads; k++){
        d->builders[k].n = 0;
        d->builders[k].ok = 1;
    }
    if (!rs_grow((void**)&d->anchors, &d->anchor_capacity, n, sizeof(struct rs_sheet_anchor))){
        return 0;
    }
    rs_list_anchor(d, n);
    /* Method 3's half shell where the grid is wider than two spans of the widest build */
    for (int k = 0; k < d->n_classes; k++){
        const struct rs_cell_grid* c = &d->cells[k];
        const double widest = 2.0 * d->list_reach_of[k] * (1.0 + 1e-12)
                              + 2.0 * d->grid.slack;
        const int64_t span_x = rs_span_of(widest, c->ix, c->nx);
        const int64_t span_y = rs_span_of(widest, c->iy, c->ny);
        const int64_t span = span_x > span_y ? span_x : span_y;
        d->list_half_shell[k] = c->nx >= 2 * span + 1 && c->ny >= 2 * span + 1;
    }
#pragma omp parallel num_threads(threads)
    {
        struct rs_index_pairs list = d->builders[rs_thread_id()];
        int64_t first, end;
        rs_search_share(d, n, rs_team_threads(), rs_thread_id(), &first, &end);
        for (int64_t a = first; a < end; a++){
            if (list.ok && !rs_list_from(d, &d->points[a], &list)){
                list.ok = 0;
            }
        }
        d->builders[rs_thread_id()] = list;
    }
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int64_t a = 0; a < n; a++){
        d->points[a].reach = d->wrapped[d->points[a].index].reach;
    }
    int64_t total = 0;
    int ok = 1;
    for (int k = 0; k < threads; k++){
        total += d->builders[k].n;
        ok &= d->builders[k].ok;
    }
    if (!ok || total >= INT32_MAX / 2 || !rs_list_room(d, n, total)){
        return 0;
    }
    d->list_pair_n = 0;
    for (int k = 0; k < threads; k++){
        memcpy(&d->list_pairs[2 * d->list_pair_n], d->builders[k].items,
               (size_t)(2 * d->builders[k].n) * sizeof(int32_t));
        d->list_pair_n += d->builders[k].n;
    }
    rs_list_partners(d, n);
    d->list_time = r->t;
    d->list_n = n;
    d->list_ready = 1;
    d->list_Lx = d->grid.Lx;
    d->list_Ly = d->grid.Ly;
    d->list_shear_rate = d->grid.shear_rate;
    d->list_reach_min = d->grid.reach_min;
    d->list_reach_max = d->grid.reach_max;
    d->list_builds++;
    return 1;
}

/* Whether this step searches through the list (Method 9), building it first if it must
 * and may (d->list_on).  The list is used when the box is wider than 2 s, so that a pair
 * is in reach through its nearest image only.  It is built again when M (rs_list_margin)
 * is no longer positive, with the widening a = 1 / keep - 1 (keep = (1 - steps 1.5 Omega
 * dt)(1 - 1.5 Omega dt)), which covers the shear of d->list_steps steps, and skins b_i
 * that cover steps + 1 steps of each particle's own motion (rs_list_anchor), at least
 * RS_LIST_FLOOR times the rms motion, unless the least pair skin exceeds
 * RS_LIST_SKIN_RATIO smallest reaches (then the cells search this step and the next
 * RS_CLASS_RETRY).  Returns 0 if memory ran out. */
static int rs_list_choose(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                          int64_t n){
    struct rs_sheet_grid* const g = &d->grid;
    d->list_on = 0;
    const double box = fmin(g->Lx, g->Ly);
    if (d->list_steps <= 0 || n >= INT32_MAX / 2 || !(2.0 * g->pair_reach < box)){
        return 1;
    }
    if (d->list_ready && g->budget_min > -INFINITY){     /* anchored in rs_wrap */
        const double margin = rs_list_margin(d, r->t - d->list_time);
        if (margin > 0.0){
            d->list_margin = margin;
            d->list_on = 1;
            return 1;
        }
    }
    d->list_ready = 0;
    if (d->list_retry > 0){
        d->list_retry--;
        return 1;
    }
    const double s_K = (double)d->list_steps * g->shear_step;
    const double keep = (1.0 - s_K) * (1.0 - g->shear_step);
    const double scale = (double)(d->list_steps + 1) / keep;
    const double skin_floor = scale * RS_LIST_FLOOR * g->excess_rms;
    const double a = 1.0 / keep - 1.0;
    const double widest = (1.0 + a) * 2.0 * g->reach_max + 2.0 * RS_LIST_FAST * skin_floor;
    if (!(s_K < 0.5) || !(2.0 * skin_floor <= RS_LIST_SKIN_RATIO * g->reach_min)
        || !(2.0 * widest * (1.0 + 1e-9) + 4.0 * g->slack < box)){
        d->list_retry = RS_CLASS_RETRY;
        return 1;
    }
    d->list_a = a;
    d->list_skin_scale = scale;
    d->list_skin_floor = skin_floor;
    if (!rs_grid_sorted(d, n) || !rs_list_build(r, d, n)){
        return 0;
    }
    /* at the build: Delta = 0, rho = rho0, so m_i = b_i (1 - 1.5 Omega dt) */
    g->budget_min = skin_floor * (1.0 - g->shear_step);
    d->list_margin = rs_list_margin(d, 0.0);
    d->list_on = d->list_margin > 0.0;
    if (!d->list_on){
        d->list_ready = 0;      /* no margin even at the build (particles at rest) */
        d->list_retry = RS_CLASS_RETRY;
    }
    return 1;
}

/* Method 3-4 through the list: each listed pair tested as the search from its particle of
 * lower index would test it (through the nearest image; a first test on the wrapped
 * points, widened by g->slack, as rs_cell_report's), on the search's threads (the pairs in
 * contiguous shares, joined in thread order).  Returns 0 if memory ran out. */
static int rs_list_search(struct rs_sheet_detector* d, int64_t n){
    const int threads = rs_team_size(d, n);
    if (!rs_reports_start(d, threads)){
        return 0;
    }
    const struct rs_sheet_grid* const g = &d->grid;
    const int64_t pairs = d->list_pair_n;
#pragma omp parallel num_threads(threads)
    {
#pragma omp single nowait
        {
            d->team_last = rs_team_threads();
        }
        struct rs_pair_list list = d->lists[rs_thread_id()];
        const int team = rs_team_threads();
        const int id = rs_thread_id();
        const int64_t first = pairs * id / team;
        const int64_t end = pairs * (id + 1) / team;
        for (int64_t k = first; k < end && list.ok; k++){
            const struct rs_sheet_point* a = &d->wrapped[d->list_pairs[2 * k]];
            const struct rs_sheet_point* b = &d->wrapped[d->list_pairs[2 * k + 1]];
            const struct rs_image im = rs_pair_image(g, a->xw, a->yw, b->xw, b->yw);
            const double dxw = a->xw + im.x - b->xw;
            const double dyw = a->yw + im.y - b->yw;
            const double dzw = a->z - b->z;
            const double wide = a->reach + g->slack + b->reach + g->shear_step * fabs(dxw);
            if (dxw * dxw + dyw * dyw + dzw * dzw > wide * wide){
                continue;
            }
            const struct rs_sheet_particle si = rs_state(d, a->index);
            const struct rs_sheet_particle sj = rs_state(d, b->index);
            const struct reb_vec6d gb = rs_image_offset(&si, &sj, im.x, im.y, im.vy);
            list.ok = rs_test_pair(g, d, &si, &sj, gb, &list);
        }
        d->lists[id] = list;
    }
    d->list_steps_used++;
    return rs_reports_join(d, threads);
}

/* Method 6-7 through the list for particle pi (its state before the resolution): every
 * listed partner, through the nearest image as pi's search would see it.  Returns 0 if
 * memory ran out. */
static int rs_list_recheck(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                           const struct rs_sheet_particle* pi, double window){
    const struct rs_sheet_grid* const g = &d->grid;
    const int32_t* const start = d->partner_start;
    const int64_t serial = ++d->stamp_serial;
    d->stamp[pi->index] = serial;
    for (int32_t k = start[pi->index]; k < start[pi->index + 1]; k++){
        d->stamp[d->partners[k]] = serial;
        const struct rs_sheet_particle sj = rs_before(d, d->partners[k]);
        const struct rs_image im = rs_pair_image(g, pi->xw, pi->yw, sj.xw, sj.yw);
        if (!rs_recheck_partner(r, d, pi, &sj, im.x, im.y, im.vy, window)){
            return 0;
        }
    }
    /* the particles whose deviation the list's margin does not cover, unless listed (or
     * pi itself: stamped with this re-check's serial) */
    for (int64_t w = 0; w < d->n_wide; w++){
        const int64_t j = d->wide[w];
        if (d->stamp[j] == serial){
            continue;
        }
        d->list_wide_checks++;
        const struct rs_sheet_particle sj = rs_before(d, j);
        const struct rs_image im = rs_pair_image(g, pi->xw, pi->yw, sj.xw, sj.yw);
        if (!rs_recheck_partner(r, d, pi, &sj, im.x, im.y, im.vy, window)){
            return 0;
        }
    }
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
    g->shear_rate = 1.5 * Omega;
    g->dt = fabs(r->dt_last_done);
    g->shear_step = 1.5 * fabs(Omega) * g->dt;  /* relative shear drift per metre of dx */
    if (!(g->shear_step < RS_MAX_SHEAR_STEP) || !(Lx > 0.0) || !(Ly > 0.0)){
        return RS_DETECT_STEP_TOO_LONG;
    }
    /* The ghost box at x + Lx has slid by -a in y (REBOUND: reb_boundary_get_ghostbox). */
    g->slide = shear ? fmod(1.5 * Omega * Lx * r->t, Ly) : 0.0;     /* a [m] */
    g->box_speed = 1.5 * Omega * Lx;                                 /* [m/s] */

    int64_t capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->wrapped, &capacity, n, sizeof(struct rs_sheet_point))){
        return RS_DETECT_NO_MEMORY;
    }
    capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->points, &capacity, n, sizeof(struct rs_sheet_point))){
        return RS_DETECT_NO_MEMORY;
    }
    capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->track, &capacity, n, sizeof(struct rs_sheet_track))){
        return RS_DETECT_NO_MEMORY;
    }
    capacity = d->particle_capacity;
    if (!rs_grow((void**)&d->cell_of, &capacity, n, sizeof(int32_t))){
        return RS_DETECT_NO_MEMORY;
    }
    d->particle_capacity = capacity;

    /* 1. Wrap, reach, vertical range (rs_wrap); 2. grid (rs_grid_layout) and counting
     * sort (rs_grid_sorted); 3-4. neighbour cells, images, exact path test (rs_search), or
     * 9. the neighbour list (rs_list_choose, rs_list_search). */
    d->particles = r->particles;
    if (!rs_wrap(r, d)){
        return RS_DETECT_STEP_TOO_LONG;     /* non-finite state: nothing sensible to do */
    }
    if (!rs_grid_layout(d, n) || !rs_list_choose(r, d, n)){
        return RS_DETECT_NO_MEMORY;
    }
    const int found = d->list_on ? rs_list_search(d, n)
                                 : rs_grid_sorted(d, n) && rs_search(d, n);
    if (!found){
        return RS_DETECT_NO_MEMORY;
    }
    d->reports += d->n_collisions;
    return RS_DETECT_OK;
}

/* Every particle's track to zero before a resolution.  Only the particles saved by the
 * last resolution (rs_save: every particle whose track it wrote) can hold anything else,
 * so only theirs are cleared, unless the number of particles has changed (the track may
 * then be new memory): then all of it. */
static void rs_clear_track(struct rs_sheet_detector* d, int64_t n){
    if (d->track_n != n){
        memset(d->track, 0, (size_t)n * sizeof(struct rs_sheet_track));
        d->track_n = n;
        return;
    }
    for (int64_t k = 0; k < d->n_saved; k++){
        memset(&d->track[d->saved[k].index], 0, sizeof(struct rs_sheet_track));
    }
}

/* Method 6-7 after a collision of particle q with `partner`: its deviation, its count of
 * deflecting contacts (Method 8), then its new contacts within the last `window` of the
 * step.  Returns 0 if memory ran out. */
static int rs_after_collision(const struct reb_simulation* const r, struct rs_sheet_detector* d,
                              int64_t q, int64_t partner, double window){
    struct rs_sheet_track* t = &d->track[q];
    const struct rs_sheet_particle state = rs_before(d, q);
    const struct rs_sheet_particle* const before = &state;
    const struct reb_particle* const p = &r->particles[q];
    const double ex = p->x - before->x;
    const double ey = p->y - before->y;
    const double ez = p->z - before->z;
    const double deviation = sqrt(ex * ex + ey * ey + ez * ez);
    t->deviation = fmax(t->deviation, deviation);
    d->deviation_max = fmax(d->deviation_max, t->deviation);
    if (d->list_on && !t->wide && !(t->deviation < 0.5 * d->list_margin)){
        if (!rs_grow((void**)&d->wide, &d->wide_capacity, d->n_wide + 1, sizeof(int64_t))){
            return 0;
        }
        d->wide[d->n_wide++] = q;
        t->wide = 1;
    }
    t->last = d->serial;
    const int deflected = rs_deflects(r->particles[q].m, r->particles[partner].m);
    t->contacts += deflected;
    if (t->contacts >= RS_MAX_CONTACTS){
        d->saturated += deflected && t->contacts == RS_MAX_CONTACTS;
        return 1;
    }
    const struct rs_sheet_grid* g = &d->grid;
    const double needed = (before->reach + t->deviation + g->reach_max + d->deviation_max)
                          / (1.0 - g->shear_step);
    if (!(needed <= g->pair_reach)){
        d->wide_rechecks++;
        d->span_limited += !(needed <= RS_MAX_SPAN * g->pair_reach);
    }
    d->rechecks++;
    /* Method 9: with D_i < M / 2, the list holds every partner within the bound but those
     * with D_j >= M / 2 (d->wide); a re-check cut at RS_MAX_SPAN s or wider than half the
     * box looks at whole cells */
    if (d->list_on && needed <= RS_MAX_SPAN * g->pair_reach
        && 2.0 * needed * (1.0 + 1e-9) < fmin(g->Lx, g->Ly) && !t->wide){
        return rs_list_recheck(r, d, before, window);
    }
    d->list_fallbacks += d->list_on;
    if (!rs_grid_sorted(d, (int64_t)r->N)){
        return 0;
    }
    const struct rs_sheet_point point = {before->xw, before->yw, before->z, before->reach,
                                         before->index};
    if (d->n_classes == 1){
        const double distance = fmin(needed, RS_MAX_SPAN * g->pair_reach) * (1.0 + 1e-12)
                                + g->slack;
        return rs_scan(r, d, &d->cells[0], &point, distance, RS_SCAN_RECHECK, window, NULL,
                       NULL);
    }
    /* every class (Method 2a), each over the bound with its own largest reach */
    for (int k = 0; k < d->n_classes; k++){
        const struct rs_cell_grid* c = &d->cells[k];
        if (c->n == 0){
            continue;
        }
        const double reach = (before->reach + t->deviation + c->reach_max + d->deviation_max)
                             / (1.0 - g->shear_step);
        const double distance = fmin(reach, RS_MAX_SPAN * g->pair_reach) * (1.0 + 1e-12)
                                + g->slack;
        if (!rs_scan(r, d, c, &point, distance, RS_SCAN_RECHECK, window, NULL, NULL)){
            return 0;
        }
    }
    return 1;
}

static struct rs_sheet_detector* rs_detector_of(struct rs_resolver* res){
    if (res->detector == NULL){
        struct rs_sheet_detector* d = calloc(1, sizeof(struct rs_sheet_detector));
        if (d == NULL){
            return NULL;
        }
        d->threads = 1;
        d->class_limit = RS_MAX_CLASSES;
        d->list_steps = RS_LIST_STEPS;
        res->detector = d;
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
    rs_clear_track(d, (int64_t)r->N);
    d->n_events = 0;
    d->serial = 0;
    d->deviation_max = 0.0;
    d->n_saved = 0;
    d->n_wide = 0;
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
        if (!rs_save(d, p1) || !rs_save(d, p2)){
            d->error = RS_DETECT_NO_MEMORY;
            break;
        }
        if (!rs_resolve_contact(r, res, e.c, e.back_time, d->grid.kick_time)){
            continue;   /* receding, or a normal speed below round-off */
        }
        d->serial++;
        d->resolved++;
        d->rescheduled += e.last1 != 0 || e.last2 != 0;
        if (!rs_after_collision(r, d, p1, p2, e.back_time)
            || !rs_after_collision(r, d, p2, p1, e.back_time)){
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
 * was tested, out[2] pairs reported, out[3] cells of the last grid (of all its classes),
 * out[4] last error, out[5] 1 if the last search used Method 3's half shell, out[6] reach
 * classes that held particles in the last search (1: one grid; Method 2a); *cell_size [m] the least cell side
 * of the last grid (of its class of the largest reaches).  Returns 0 if the detector has
 * not run yet. */
int rs_sheet_detector_counters(const struct rs_resolver* res, int64_t* out,
                               double* cell_size){
    const struct rs_sheet_detector* d = res->detector;
    if (d == NULL){
        memset(out, 0, 7 * sizeof(int64_t));
        *cell_size = 0.0;
        return 0;
    }
    out[0] = d->steps;
    out[1] = d->candidates;
    out[2] = d->reports;
    out[3] = d->cells_last;
    out[4] = d->error;
    out[5] = d->grid.half_shell;
    out[6] = d->classes_used;
    *cell_size = d->cell_size_last;
    return 1;
}

/* Counters of the time-ordered resolution since the detector was created: out[0] contacts
 * resolved, out[1] of which timed on a path changed earlier in the same step, out[2]
 * re-checks (one per particle and collision), out[3] of which over more than s,
 * out[4] of which cut at RS_MAX_SPAN s, out[5] particles that reached RS_MAX_CONTACTS
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

/* Sets the number of OpenMP threads of the search (ringsim's integration.threads), at
 * least 1; more than 1 has an effect only if the library was compiled with OpenMP.  The
 * contacts found and their resolution do not depend on it (rs_search).  Returns the
 * number of threads the search will ask for, or 0 if memory ran out. */
int rs_sheet_set_threads(struct rs_resolver* res, int threads){
    struct rs_sheet_detector* const d = rs_detector_of(res);
    if (d == NULL){
        return 0;
    }
    d->threads = threads >= 1 ? threads : 1;
    return d->threads;
}

/* Sets the most reach classes of the search (Method 2a), 1 to RS_MAX_CLASSES (outside:
 * clipped); 1 searches all particles in one grid.  The contacts found and their resolution
 * do not depend on it.  Returns the number set, or 0 if memory ran out. */
int rs_sheet_set_classes(struct rs_resolver* res, int classes){
    struct rs_sheet_detector* const d = rs_detector_of(res);
    if (d == NULL){
        return 0;
    }
    d->class_limit = classes < 1 ? 1 : (classes > RS_MAX_CLASSES ? RS_MAX_CLASSES : classes);
    d->one_grid_steps = 0;
    return d->class_limit;
}

/* Sets the steps a neighbour list is built to last (Method 9), 0 for no lists (every step
 * searches the cells).  Neither changes any result.  Returns the number set, or -1 if
 * memory ran out. */
int rs_sheet_set_lists(struct rs_resolver* res, int steps){
    struct rs_sheet_detector* const d = rs_detector_of(res);
    if (d == NULL){
        return -1;
    }
    d->list_steps = steps < 0 ? 0 : (steps > 1000 ? 1000 : steps);
    d->list_ready = 0;
    d->list_retry = 0;
    return d->list_steps;
}

/* Counters of Method 9 since the detector was created: out[0] lists built, out[1] steps
 * searched through a list, out[2] re-checks through the cells while a list was on, out[3]
 * pairs in the last list, out[4] the steps a list is built to last, out[5] unlisted
 * partners of deviation D >= M / 2 re-checked through the list.  Returns 0 (and zeros) if
 * the detector has not run yet. */
int rs_sheet_list_counters(const struct rs_resolver* res, int64_t* out){
    const struct rs_sheet_detector* d = res->detector;
    if (d == NULL){
        memset(out, 0, 6 * sizeof(int64_t));
        return 0;
    }
    out[0] = d->list_builds;
    out[1] = d->list_steps_used;
    out[2] = d->list_fallbacks;
    out[3] = d->list_pair_n;
    out[4] = d->list_steps;
    out[5] = d->list_wide_checks;
    return 1;
}

/* Threads the last search of the resolver's detector ran on (0 before the first). */
int rs_sheet_threads_used(const struct rs_resolver* res){
    const struct rs_sheet_detector* d = res->detector;
    return d == NULL ? 0 : d->team_last;
}

/* RS_PARTICLES_PER_THREAD: particles per thread at least before the search is split. */
int64_t rs_sheet_particles_per_thread(void){
    return RS_PARTICLES_PER_THREAD;
}

/* 1 if the library was compiled with OpenMP (threads > 1 split the search), else 0. */
int rs_sheet_openmp(void){
#ifdef _OPENMP
    return 1;
#else
    return 0;
#endif
}

/* Largest 1.5 Omega dt the detector accepts (exclusive), for ringsim's scenario validation:
 * a fixed integration.dt in line mode must satisfy 1.5 |Omega| dt < this value. */
double rs_sheet_max_shear_step(void){
    return RS_MAX_SHEAR_STEP;
}
