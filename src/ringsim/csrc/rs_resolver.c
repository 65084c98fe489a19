/**
 * @file    rs_resolver.c
 * @brief   Hard-sphere collision resolver for REBOUND with size-, mass- and
 *          speed-dependent coefficients of restitution (ringsim).
 *
 * Effect          inelastic normal impulse between two colliding spheres
 * Implementation  ringsim developers
 * Compiled for    REBOUND 5.2.2 (struct reb_simulation as in its rebound.h)
 * Papers          Dilley, J. P. 1993, Icarus 105, 225-234 (eqs 3.2, 3.4, 4.3, 4.10,
 *                 5.9, 5.14-5.16); Bridges, F. G., Hatzes, A. & Lin, D. N. C. 1984,
 *                 Nature 309, 333-335.
 *
 * Physics
 * -------
 * For a pair (1, 2) with separation dr = x1 + gb - x2 and relative velocity
 * dv = v1 + gb_v - v2 (gb is REBOUND's ghost-box offset of particle 1; in the
 * shearing sheet gb.vy carries the shear velocity across the box) the normal impact
 * speed is v = -dv.dr/|dr| > 0.  The pair receives the normal impulse
 *
 *     J = max((1 + eps) v, v_min) M_bar   along dr/|dr|,
 *
 * so that the normal relative velocity after the collision is -eps v (eq. 1.1 of the
 * paper) and total momentum is conserved exactly (to round-off).  The kinetic energy
 * lost is (1 - eps^2) M_bar v^2 / 2.  Reduced radius and mass of the pair:
 *
 *     R_bar = R1 R2 / (R1 + R2)                   (3.4)
 *     M_bar = M1 M2 / (M1 + M2)                   (3.2)
 *
 * Restitution laws (u = v / v_c):
 *
 *   dilley    xi  = xi0 (R_bar/0.025 m)^-0.2 (M_bar/M_ref)^-kappa (v/0.01 m/s)^p,
 *             M_ref = 0.060 kg by default
 *                                                  (5.14)-(5.16)
 *             eps = exp(-pi xi / sqrt(1 - xi^2)) for xi < 1, else 0      (5.9)
 *   bridges   eps = min(1, u^-exponent)            (Bridges et al. 1984)
 *   constant  eps = epsilon
 *   andrews   eps^2 = [-2 + sqrt(30 u^2 - 5)] / (3 u^2) for u > 1, else 1   (4.3)
 *   tabor     eps = u^-(1-2q) ((1 - q eps^2)/(1 - q))^q for u > 1, else 1  (4.10)
 *             (implicit; solved by the rule stated at rs_tabor_epsilon, the same
 *             as ringsim.physics.restitution._solve_tabor)
 *
 * Parameters (struct rs_resolver, one per simulation, reached through sim->extras)
 * -------------------------------------------------------------------------------
 * Declared once, with units, defaults, ranges, slots and sources, in
 * ringsim/physics/restitution.py (RESTITUTION); this table and rs_parameters_valid
 * repeat it for C readers, and tests/test_parameters.py checks that they agree.
 * Name          C type    Model            Meaning                          Unit
 * model         int32_t   all              RS_MODEL_* (dilley=0, bridges=1,  -
 *                                          constant=2, andrews=3, tabor=4)
 * param[0]      double    dilley           xi0, damping ratio at reference   -
 * param[1]      double    dilley           p, speed exponent                 -
 * param[2]      double    dilley           kappa, reduced-mass exponent      -
 * param[3]      double    dilley           M_ref, reference reduced mass     kg
 * param[0]      double    bridges          v_c, elastic below this speed     m/s
 * param[1]      double    bridges          exponent of the power law         -
 * param[0]      double    constant         epsilon                           -
 * param[0]      double    andrews          v_c, speed of first yield         m/s
 * param[0]      double    tabor            v_c, speed where eps = 1          m/s
 * param[1]      double    tabor            q, hardness exponent, 0<q<1/2     -
 * log_capacity  int64_t   all              ring-buffer length of the log     -
 * measured[4]   double    all              v_min, v_max, R_min, R_max the    m/s, m
 *                                          law was measured over (0, inf:
 *                                          not stated)
 * measured_masses[2] double all            M_min, M_max it was measured at   kg
 * friction_model int32_t  -                RS_FRICTION_* (none=0, constant=1, -
 *                                          coulomb=2; ringsim.physics.friction.FRICTION)
 * friction[0]   double    constant         beta, tangential restitution      -
 * friction[0]   double    coulomb          mu, Coulomb friction coefficient  -
 * friction[1]   double    coulomb          beta0, sticking restitution       -
 * inertia_factor double   friction         k in I = k m R^2, (0, 2/3]        -
 * spin          double*   friction         3 per particle; x, y in the axes   rad/s
 *                                          the rotating frame had at t = 0
 *                                          (rs_spin_to_rotating), z as is
 * log_every     int64_t   all              log every n-th collision          -
 * REBOUND's own field used: minimum_collision_velocity [1/s], see below.
 *
 * Statistics (struct rs_stats, read by ringsim/engine/statistics.py without callbacks)
 * -------------------------------------------------------------------------
 * count, n_floored (impulse raised by minimum_collision_velocity), sum of eps and of
 * v [m/s]; histogram of v [m/s] in RS_VN_NBINS log bins from 1e-7 to 1e2 m/s
 * (10 per decade) plus under/overflow; histogram of the dissipation 1 - eps in
 * RS_EPS_NBINS log bins from 1e-4 to 1 (10 per decade; 1 - eps < 1e-4, including
 * eps = 1, goes to the underflow; eps = 0 to the last bin); a ring buffer of sampled
 * collisions (t [s], v [m/s], R_bar [m], M_bar [kg], eps); multi_encounters (see below);
 * collisions outside the speeds [m/s], reduced radii [m] and reduced masses [kg] the law
 * was measured over (measured, measured_masses), each below and above the range;
 * critically_damped, the collisions whose law gives eps = 0 because xi >= 1 (dilley).
 * The eps recorded is that of the law, also when minimum_collision_velocity raises the
 * impulse.
 *
 * REBOUND bookkeeping, as its reb_collision_resolve_hardsphere does
 * -------------------------------------------------------------------
 * minimum_collision_velocity w: the separation speed after the impulse is at least
 *     v_min = min(R_min w (1 - (|dr| - R_max)/R_min), R_max w)
 *           = min(w (R1 + R2 - |dr|), w R_max),
 * i.e. w [1/s] times the overlap depth, at most w times the larger radius.
 * collisions_plog grows by -|dx| (vy_old - vy_new) m of the particle on the outer
 * (larger x) side (dx at the contact in the line modes), and collisions_log_n by one,
 * per resolved collision.
 *
 * Collision search modes
 * ----------------------
 * tree, direct: REBOUND reports pairs overlapping at the end of a step.  The resolver
 *   re-checks overlap (|dr| < R1 + R2) and approach (dv.dr < 0) and does nothing
 *   otherwise: each pair is reported twice, (i, j) and (j, i, -gb), and the second
 *   report finds it receding.  Normal speeds below the round-off of the velocities
 *   (64 DBL_EPSILON times the summed |components|) count as not approaching, so that
 *   eps = 0 collisions are not resolved twice.
 * line, linetree: REBOUND reports pairs whose straight paths over the last step came
 *   within R1 + R2.  The resolver finds the first contact on the relative path
 *   dr(s) = dr - s dv (s = time before the end of the step, 0 < s <= dt_last_done),
 *   applies the impulse along the normal at contact and moves both particles by
 *   s x (their velocity change), i.e. as if they had moved on from the contact with
 *   their new velocities.  Pairs overlapping since before the step are resolved at the
 *   end as in tree mode.  A pair resolved once is ignored for the rest of the step (a
 *   per-simulation set of pairs, cleared when steps_done changes).
 * sheet (rs_sheet_detect.c): ringsim's own swept-sphere search for shearing sheets reports
 *   the same pairs as REBOUND's line search, each once, finds their contact times and
 *   resolves them in time order through rs_resolve_contact (the same impulse and moves as
 *   the line modes, at the contact time the detector gives); after each collision the
 *   detector re-checks the paths of both particles, and it, not the pair memory, decides
 *   which pairs may collide again in the step (see its header).
 *
 * multi_encounters counts resolved collisions in which one partner had already been
 * deflected earlier in the same step, a particle counting as deflected by a partner that
 * carries at least RS_DEFLECTING_MASS_SHARE = 0.1 of the pair's mass.  In line and
 * linetree modes such a second contact is found on a straight path the particle no longer
 * follows (in REBOUND's shuffled order); the sheet detector resolves it in time order on
 * the particle's new path, so there the count measures how often it happens, not an error.
 *
 * Validity limits
 * ---------------
 * - tree/direct find collisions only as overlaps at the end of a step; this is accurate
 *   only if dt << R / v_rel for all pairs.  Faster pairs tunnel through each other or
 *   sink deep into contact.
 * - line/linetree/sheet take paths as straight lines with the end-of-step velocities:
 *   valid for Omega dt << 1.  line/linetree: several contacts of one particle within a
 *   step are resolved one after another in REBOUND's shuffled order, each on the straight
 *   path of the velocities at that moment, and each pair at most once per step
 *   (multi_encounters measures how often).  sheet: in time order (rs_sheet_detect.c).
 * - Without friction (friction_model = RS_FRICTION_NONE, the default) the normal impulse
 *   only: no spin.  With friction, rough spheres as in ringsim/physics/friction.py
 *   (rs_tangential_impulse below): spins [rad/s] relative to the rotating frame.  A
 *   torque-free spin is constant in inertial space, so between collisions its x, y
 *   components in the rotating frame's axes turn at -Omega (w_z is unchanged): exactly
 *   followed by keeping x, y in the axes the frame had at t = 0 and turning them by
 *   the frame angle Omega t at each collision (t = the contact time) and at each read
 *   (rs_spin_to_rotating).  Omega is REBOUND's OMEGA (0 by default: an inertial box).
 *   No adhesion, no rolling resistance.
 * - eps depends on the normal speed only through the laws above; the Dilley law is a
 *   fit to 2.5-20 cm ice spheres at 0.01-5 cm/s and its size/mass scaling is a model.
 * - Returns 0 (keep both particles) always.  If sim->extras does not point to a
 *   resolver created here, the integration is stopped with REB_STATUS_GENERIC_ERROR.
 *
 * No global mutable state: every parameter and statistic lives in the per-simulation
 * struct, so simulations with different laws can run side by side in one process.
 */
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "rebound.h"
#include "rs_resolver.h"

#define RS_MAGIC 0x564c4f5345525352ULL  /* "RSRESOLV" in little-endian bytes */

enum RS_MODEL {
    RS_MODEL_DILLEY = 0,
    RS_MODEL_BRIDGES = 1,
    RS_MODEL_CONSTANT = 2,
    RS_MODEL_ANDREWS = 3,
    RS_MODEL_TABOR = 4,
};

/* Reference scales of the Dilley law (eq 5.14 and the speed unit of 5.8); the reference mass
 * of eq 5.16 is the law's parameter param[3]. */
#define RS_DILLEY_R_REF 0.025   /* [m] */
#define RS_DILLEY_V_REF 0.01    /* [m/s] */
#define RS_DILLEY_RADIUS_EXPONENT 0.2
#define RS_PI 3.14159265358979323846   /* M_PI is not part of C99 */

/* Histogram layout (RS_VN_NBINS and RS_EPS_NBINS are in rs_resolver.h). */
#define RS_VN_LOG10_MIN (-7.0)
#define RS_EPS_LOG10_MIN (-4.0)
#define RS_BINS_PER_DECADE 10.0

/* Round-off floor of the approach test, in units of the summed |velocity components|. */
#define RS_ROUNDOFF_SPEED (64.0 * DBL_EPSILON)

/* ---------------------------------------------------------------------------------- */
/* Layout checks for the Python side.                                                */

size_t rs_simulation_struct_size(void){
    return sizeof(struct reb_simulation);
}

size_t rs_resolver_struct_size(void){
    return sizeof(struct rs_resolver);
}

size_t rs_log_entry_size(void){
    return sizeof(struct rs_log_entry);
}

int rs_histogram_bins(int which){
    return which == 0 ? RS_VN_NBINS : RS_EPS_NBINS;
}

/* ---------------------------------------------------------------------------------- */
/* Restitution laws (the Python twin in ringsim/testing/twins.py calls these through     */
/* rs_epsilon_array; ringsim/physics/restitution.py holds the numpy versions).           */

static double rs_dilley_xi(double v, double R_bar, double M_bar, const double* param){
    return param[0] * pow(R_bar / RS_DILLEY_R_REF, -RS_DILLEY_RADIUS_EXPONENT)
           * pow(M_bar / param[3], -param[2]) * pow(v / RS_DILLEY_V_REF, param[1]);
}

static double rs_dilley_epsilon(double v, double R_bar, double M_bar, const double* param){
    const double xi = rs_dilley_xi(v, R_bar, M_bar, param);
    if (!(xi < 1.0)){
        return 0.0;     /* critically damped or overdamped: no rebound */
    }
    return exp(-RS_PI * xi / sqrt(1.0 - xi * xi));
}

static double rs_bridges_epsilon(double v, double v_c, double exponent){
    const double u = v / v_c;
    return u > 1.0 ? pow(u, -exponent) : 1.0;
}

static double rs_andrews_epsilon(double v, double v_c){
    const double u = v / v_c;
    if (!(u > 1.0)){
        return 1.0;     /* elastic below the first-yield speed */
    }
    /* eq. (4.3) divided through by u^2, in w = 1/u: finite up to u = inf (eps -> 0) */
    const double w = 1.0 / u;
    return sqrt((w * sqrt(30.0 - 5.0 * w * w) - 2.0 * w * w) / 3.0);
}

/* The Tabor solver rule, shared with ringsim.physics.restitution._solve_tabor: write
 * e = A (1 + s), A = u^-(1-2q).  g(s) = log1p(s) - q log1p(q (1 - e^2)/(1 - q)) (eq. 4.10
 * divided by A, in logarithms; no cancellation for large u) increases with s and changes
 * sign on the bracket [lo, hi] = [0, min(1/A, (1-q)^-q) - 1]; start at its midpoint.  Each
 * iteration: evaluate g; g < 0 sets lo = s, g > 0 sets hi = s, anything else (an exact
 * root) stops.  Newton step d = -g/g' (g' = 1/(1 + s) + 2 q^2 A e / (1 - q e^2)): if
 * |d| <= RS_TABOR_TOLERANCE (1 + s), take it and stop (converged: round-off may put s + d
 * on the edge of the bracket); else take s + d if it lies strictly inside (lo, hi), the
 * midpoint otherwise, and stop if the bracket is now no wider than RS_TABOR_TOLERANCE
 * (1 + s).  At most RS_TABOR_MAX_ITERATIONS iterations; return A (1 + s). */
#define RS_TABOR_TOLERANCE 1e-15
#define RS_TABOR_MAX_ITERATIONS 200

static double rs_tabor_epsilon(double v, double v_c, double q){
    const double u = v / v_c;
    if (!(u > 1.0)){
        return 1.0;
    }
    const double amplitude = pow(u, -(1.0 - 2.0 * q));
    double lo = 0.0;
    double hi = pow(1.0 - q, -q);
    if (1.0 / amplitude < hi){     /* amplitude = 0 gives inf: the other bound holds */
        hi = 1.0 / amplitude;
    }
    hi -= 1.0;
    double s = 0.5 * (lo + hi);
    for (int iteration = 0; iteration < RS_TABOR_MAX_ITERATIONS; iteration++){
        const double e = amplitude * (1.0 + s);
        const double g = log1p(s) - q * log1p(q * (1.0 - e * e) / (1.0 - q));
        if (g < 0.0){
            lo = s;
        }else if (g > 0.0){
            hi = s;
        }else{
            break;
        }
        const double step = -g / (1.0 / (1.0 + s)
                                  + 2.0 * q * q * amplitude * e / (1.0 - q * e * e));
        const double newton = s + step;
        if (fabs(step) <= RS_TABOR_TOLERANCE * (1.0 + s)){
            s = newton;     /* converged */
            break;
        }
        s = (newton > lo && newton < hi) ? newton : 0.5 * (lo + hi);
        if (!(hi - lo > RS_TABOR_TOLERANCE * (1.0 + s))){
            break;
        }
    }
    return amplitude * (1.0 + s);
}

static double rs_law_epsilon(const struct rs_resolver* res, double v, double R_bar,
                             double M_bar){
    switch (res->model){
        case RS_MODEL_DILLEY:
            return rs_dilley_epsilon(v, R_bar, M_bar, res->param);
        case RS_MODEL_BRIDGES:
            return rs_bridges_epsilon(v, res->param[0], res->param[1]);
        case RS_MODEL_CONSTANT:
            return res->param[0];
        case RS_MODEL_ANDREWS:
            return rs_andrews_epsilon(v, res->param[0]);
        case RS_MODEL_TABOR:
            return rs_tabor_epsilon(v, res->param[0], res->param[1]);
        default:
            return 1.0;
    }
}

/* Vectorised evaluation of the law for checks from Python: out[i] = eps(v[i], ...). */
void rs_epsilon_array(const struct rs_resolver* res, int64_t n, const double* v,
                      const double* R_bar, const double* M_bar, double* out){
    for (int64_t i = 0; i < n; i++){
        out[i] = rs_law_epsilon(res, fabs(v[i]), R_bar[i], M_bar[i]);
    }
}

/* ---------------------------------------------------------------------------------- */
/* Creation, statistics, destruction.                                                 */

/* A guard repeating the ranges declared in ringsim/physics/restitution.py (RESTITUTION);
 * tests/test_parameters.py checks both accept and refuse exactly at every bound. */
static int rs_parameters_valid(int32_t model, const double* param){
    for (int i = 0; i < RS_LAW_PARAMS; i++){
        if (!isfinite(param[i])){
            return 0;
        }
    }
    switch (model){
        case RS_MODEL_DILLEY:
            return param[0] > 0.0 && param[1] > 0.0 && param[3] > 0.0;
        case RS_MODEL_BRIDGES:
            return param[0] > 0.0 && param[1] > 0.0;
        case RS_MODEL_CONSTANT:
            return param[0] >= 0.0 && param[0] <= 1.0;
        case RS_MODEL_ANDREWS:
            return param[0] > 0.0;
        case RS_MODEL_TABOR:
            return param[0] > 0.0 && param[1] > 0.0 && param[1] < 0.5;
        default:
            return 0;
    }
}

/* Returns a new resolver, or NULL for invalid parameters or failed allocation. */
struct rs_resolver* rs_resolver_create(int32_t model, double param0, double param1,
                                       double param2, double param3, int64_t log_capacity,
                                       int64_t log_every){
    const double param[RS_LAW_PARAMS] = {param0, param1, param2, param3};
    if (!rs_parameters_valid(model, param) || log_capacity < 0 || log_every < 1){
        return NULL;
    }
    struct rs_resolver* res = calloc(1, sizeof(struct rs_resolver));
    if (res == NULL){
        return NULL;
    }
    if (log_capacity > 0){
        res->log = calloc((size_t)log_capacity, sizeof(struct rs_log_entry));
        if (res->log == NULL){
            free(res);
            return NULL;
        }
    }
    res->magic = RS_MAGIC;
    res->model = model;
    memcpy(res->param, param, sizeof(param));
    res->log_capacity = log_capacity;
    res->log_every = log_every;
    const double unknown[4] = {0.0, INFINITY, 0.0, INFINITY};
    memcpy(res->measured, unknown, sizeof(unknown));
    res->measured_masses[0] = 0.0;
    res->measured_masses[1] = INFINITY;
    res->friction_model = RS_FRICTION_NONE;
    res->inertia_factor = 0.4;     /* solid sphere; used only with friction */
    return res;
}

/* A guard repeating the ranges declared in ringsim/physics/friction.py (FRICTION) and of
 * the scenario's particles.inertia_factor; tests/test_friction_resolver.py checks that it
 * accepts and refuses exactly at every bound. */
static int rs_friction_valid(int32_t model, const double* param, double inertia_factor){
    for (int i = 0; i < 3; i++){
        if (!isfinite(param[i])){
            return 0;
        }
    }
    if (!(inertia_factor > 0.0 && inertia_factor <= 2.0 / 3.0)){
        return 0;
    }
    switch (model){
        case RS_FRICTION_NONE:
            return 1;
        case RS_FRICTION_CONSTANT:
            return param[0] >= -1.0 && param[0] <= 1.0;
        case RS_FRICTION_COULOMB:
            return param[0] >= 0.0 && param[1] >= -1.0 && param[1] <= 1.0;
        default:
            return 0;
    }
}

/* Sets the friction model (RS_FRICTION_*), its parameters (constant: beta; coulomb: mu,
 * beta0) and the inertia factor k; returns 0 (and changes nothing) if they are outside
 * their declared ranges. */
int rs_resolver_set_friction(struct rs_resolver* res, int32_t model, double param0,
                             double param1, double param2, double inertia_factor){
    const double param[3] = {param0, param1, param2};
    if (!rs_friction_valid(model, param, inertia_factor)){
        return 0;
    }
    res->friction_model = model;
    memcpy(res->friction, param, sizeof(param));
    res->inertia_factor = inertia_factor;
    return 1;
}

void rs_resolver_reset_stats(struct rs_resolver* res){
    memset(&res->stats, 0, sizeof(struct rs_stats));
}

void rs_resolver_free(struct rs_resolver* res){
    if (res == NULL){
        return;
    }
    res->magic = 0;     /* a stale sim->extras now fails the magic check */
    if (res->detector_free != NULL){
        res->detector_free(res->detector);     /* rs_sheet_detect.c's work space */
    }
    free(res->memory.keys);
    free(res->memory.last_step);
    free(res->spin);
    free(res->log);
    free(res);
}

struct rs_resolver* rs_resolver_of(const struct reb_simulation* r){
    struct rs_resolver* res = (struct rs_resolver*)r->extras;
    if (res == NULL || res->magic != RS_MAGIC){
        return NULL;
    }
    return res;
}

/* A coefficient_of_restitution callback for REBOUND's own hard-sphere resolver that
 * returns this simulation's constant epsilon (1 for other laws).  Used in tests to
 * give the built-in resolver the same eps. */
double rs_constant_epsilon_cor(const struct reb_simulation* const r, double v){
    (void)v;
    const struct rs_resolver* res = rs_resolver_of(r);
    if (res == NULL || res->model != RS_MODEL_CONSTANT){
        return 1.0;
    }
    return res->param[0];
}

static void rs_record(struct rs_resolver* res, double t, double v_n, double R_bar,
                      double M_bar, double eps, int floored){
    struct rs_stats* s = &res->stats;
    const int64_t index = s->count;
    s->count++;
    s->n_floored += floored;
    s->sum_epsilon += eps;
    s->sum_vn += v_n;
    s->outside_speeds += (v_n < res->measured[0] || v_n > res->measured[1]);
    s->outside_sizes += (R_bar < res->measured[2] || R_bar > res->measured[3]);
    s->speeds_below += (v_n < res->measured[0]);
    s->speeds_above += (v_n > res->measured[1]);
    s->sizes_below += (R_bar < res->measured[2]);
    s->sizes_above += (R_bar > res->measured[3]);
    s->masses_below += (M_bar < res->measured_masses[0]);
    s->masses_above += (M_bar > res->measured_masses[1]);
    s->inside_all += (v_n >= res->measured[0] && v_n <= res->measured[1]
                      && R_bar >= res->measured[2] && R_bar <= res->measured[3]
                      && M_bar >= res->measured_masses[0] && M_bar <= res->measured_masses[1]);
    if (eps == 0.0 && res->model == RS_MODEL_DILLEY
        && !(rs_dilley_xi(v_n, R_bar, M_bar, res->param) < 1.0)){
        s->critically_damped++;     /* xi >= 1: critically damped or overdamped */
    }

    if (v_n > 0.0){
        const double bin = floor((log10(v_n) - RS_VN_LOG10_MIN) * RS_BINS_PER_DECADE);
        if (bin < 0.0){
            s->vn_underflow++;
        }else if (bin >= RS_VN_NBINS){
            s->vn_overflow++;
        }else{
            s->vn_hist[(int)bin]++;
        }
    }else{
        s->vn_underflow++;
    }

    const double dissipation = 1.0 - eps;
    if (!(dissipation >= 1e-4)){
        s->eps_underflow++;
    }else{
        double bin = floor((log10(dissipation) - RS_EPS_LOG10_MIN) * RS_BINS_PER_DECADE);
        if (bin >= RS_EPS_NBINS){
            bin = RS_EPS_NBINS - 1;     /* eps = 0 sits on the upper edge */
        }
        if (bin < 0.0){
            bin = 0.0;                  /* 1 - eps = 1e-4 up to round-off of log10 */
        }
        s->eps_hist[(int)bin]++;
    }

    if (res->log_capacity > 0 && index % res->log_every == 0){
        struct rs_log_entry* e = &res->log[s->log_written % res->log_capacity];
        e->t = t;
        e->v_n = v_n;
        e->R_bar = R_bar;
        e->M_bar = M_bar;
        e->epsilon = eps;
        s->log_written++;
    }
}

/* ---------------------------------------------------------------------------------- */
/* Pairs resolved in the current step (swept-path modes only).                        */

static uint64_t rs_pair_key(size_t i, size_t j){
    const uint64_t lo = (uint64_t)(i < j ? i : j);
    const uint64_t hi = (uint64_t)(i < j ? j : i);
    return ((hi << 32) | lo) + 1;   /* 0 marks an empty slot */
}

static size_t rs_pair_slot(const struct rs_pair_memory* m, uint64_t key){
    /* Fibonacci hashing into a power-of-two table, linear probing. */
    size_t slot = (size_t)((key * 0x9E3779B97F4A7C15ULL) >> 32) & (size_t)(m->capacity - 1);
    while (m->keys[slot] != 0 && m->keys[slot] != key){
        slot = (slot + 1) & (size_t)(m->capacity - 1);
    }
    return slot;
}

/* Forget the pairs of earlier steps, and everything of another simulation. */
static void rs_pair_memory_sync(struct rs_pair_memory* m, const struct reb_simulation* r){
    if (m->sim != r && m->n_stamps > 0){
        memset(m->last_step, 0, (size_t)m->n_stamps * sizeof(uint64_t));
    }
    if (m->sim != r || m->step != r->steps_done){
        if (m->n > 0){
            memset(m->keys, 0, (size_t)m->capacity * sizeof(uint64_t));
        }
        m->n = 0;
        m->sim = r;
        m->step = r->steps_done;
    }
}

/* Records that particles i and j collided in this step; returns 1 if either had already
 * been deflected earlier in the same step, 0 if not, -1 if memory ran out.  A particle
 * counts as deflected when its partner carried at least RS_DEFLECTING_MASS_SHARE of the
 * pair's mass (its velocity changed by that share of the pair's relative-velocity change):
 * a 5 m boulder struck by several 0.5 m grains in one step keeps its straight path. */
static int rs_pair_memory_stamp(struct rs_pair_memory* m, const struct reb_simulation* r,
                                size_t i, size_t j, int i_deflected, int j_deflected){
    const size_t needed = (i > j ? i : j) + 1;
    if ((size_t)m->n_stamps < needed){
        size_t n = m->n_stamps ? (size_t)m->n_stamps : 64;
        while (n < needed || n < r->N){
            n *= 2;
        }
        uint64_t* grown = realloc(m->last_step, n * sizeof(uint64_t));
        if (grown == NULL){
            return -1;
        }
        memset(grown + m->n_stamps, 0, (n - (size_t)m->n_stamps) * sizeof(uint64_t));
        m->last_step = grown;
        m->n_stamps = (int64_t)n;
    }
    const uint64_t stamp = r->steps_done + 1;   /* 0 means never */
    const int repeated = m->last_step[i] == stamp || m->last_step[j] == stamp;
    if (i_deflected){
        m->last_step[i] = stamp;
    }
    if (j_deflected){
        m->last_step[j] = stamp;
    }
    return repeated;
}

static int rs_pair_memory_contains(const struct rs_pair_memory* m, uint64_t key){
    return m->capacity > 0 && m->keys[rs_pair_slot(m, key)] == key;
}

/* Returns 0 if memory ran out. */
static int rs_pair_memory_insert(struct rs_pair_memory* m, uint64_t key){
    if (2 * (m->n + 1) > m->capacity){
        const int64_t capacity = m->capacity ? 2 * m->capacity : 64;
        uint64_t* keys = calloc((size_t)capacity, sizeof(uint64_t));
        if (keys == NULL){
            return 0;
        }
        uint64_t* old = m->keys;
        const int64_t old_capacity = m->capacity;
        m->keys = keys;
        m->capacity = capacity;
        for (int64_t k = 0; k < old_capacity; k++){
            if (old[k] != 0){
                m->keys[rs_pair_slot(m, old[k])] = old[k];
            }
        }
        free(old);
    }
    m->keys[rs_pair_slot(m, key)] = key;
    m->n++;
    return 1;
}

/* ---------------------------------------------------------------------------------- */
/* The resolver.                                                                      */

/* Room for the spins of n particles (new ones at rest in the rotating frame); 0 if
 * memory ran out. */
int rs_spin_reserve(struct rs_resolver* res, int64_t n){
    if (n <= res->spin_capacity){
        return 1;
    }
    int64_t capacity = res->spin_capacity ? res->spin_capacity : 64;
    while (capacity < n){
        capacity *= 2;
    }
    double* grown = realloc(res->spin, (size_t)capacity * 3 * sizeof(double));
    if (grown == NULL){
        return 0;
    }
    memset(grown + 3 * res->spin_capacity, 0,
           (size_t)(capacity - res->spin_capacity) * 3 * sizeof(double));
    res->spin = grown;
    res->spin_capacity = capacity;
    return 1;
}

/* Frame angle [rad] of the rotating frame at time t [s]: REBOUND's OMEGA t (the frame of
 * Hill's equations that the SEI integrator and the shear boundary use; OMEGA = 0, its
 * default, is an inertial frame). */
double rs_spin_frame_angle(const struct reb_simulation* const r, double t){
    return r->OMEGA * t;
}

/* Stored spin s (x, y in the axes of the frame at t = 0) -> spin w in the rotating frame's
 * axes at frame angle theta, given c = cos(theta), sn = sin(theta): (w_x + i w_y) =
 * (s_x + i s_y) exp(-i theta), w_z = s_z.  rs_spin_from_rotating is its inverse. */
static void rs_spin_to_rotating(const double* const s, double c, double sn, double* const w){
    w[0] = c * s[0] + sn * s[1];
    w[1] = c * s[1] - sn * s[0];
    w[2] = s[2];
}

static void rs_spin_from_rotating(const double* const w, double c, double sn, double* const s){
    s[0] = c * w[0] - sn * w[1];
    s[1] = c * w[1] + sn * w[0];
    s[2] = w[2];
}

/* Spins of particles 0..n-1 in the rotating frame at frame angle theta [rad] into out
 * (3 n doubles, [rad/s]; zero where never set). */
void rs_spins_read(const struct rs_resolver* const res, double theta, int64_t n,
                   double* const out){
    const double c = cos(theta);
    const double sn = sin(theta);
    for (int64_t i = 0; i < n; i++){
        if (i < res->spin_capacity){
            rs_spin_to_rotating(&res->spin[3 * i], c, sn, &out[3 * i]);
        }else{
            out[3 * i] = out[3 * i + 1] = out[3 * i + 2] = 0.0;
        }
    }
}

/* Set the spins of particles 0..n-1 from values in the rotating frame at frame angle
 * theta [rad] (3 n doubles [rad/s]); the rest of the array is zeroed.  0 if memory ran
 * out. */
int rs_spins_write(struct rs_resolver* const res, double theta, int64_t n,
                   const double* const values){
    if (!rs_spin_reserve(res, n > 0 ? n : 1)){
        return 0;
    }
    const double c = cos(theta);
    const double sn = sin(theta);
    for (int64_t i = 0; i < n; i++){
        rs_spin_from_rotating(&values[3 * i], c, sn, &res->spin[3 * i]);
    }
    memset(res->spin + 3 * n, 0, (size_t)(res->spin_capacity - n) * 3 * sizeof(double));
    return 1;
}

/* The tangential impulse of rough spheres per reduced mass, jt [m/s], and the spin changes
 * it causes (applied to w1, w2 [rad/s]), in the order of operations of
 * ringsim/physics/friction.py::collision_impulse (the tested reference):
 *   n = dr/|dr|, lever = |dr|/(R1 + R2), arms a_i = R_i lever, s = a1 w1 + a2 w2,
 *   g = dv - s x n, g_t = g - (g.n) n, f_t = 1/(1 + lever^2 (share1/k + share2/k)),
 *   constant: c = (1 + beta) f_t; coulomb: c = min((1 + beta0) f_t, mu J_n/(M_bar |g_t|)),
 *   jt = -c g_t, w_i -= lever share_i/(k R_i) (n x jt).
 * No torque from the normal impulse (n x n = 0).  Adds the energy it dissipates,
 * 1/2 M_bar c (2 - c/f_t) |g_t|^2 [J], and sliding contacts to the statistics. */
static void rs_tangential_impulse(struct rs_resolver* const res, double* const w1,
                                  double* const w2, double R1, double R2, double share1,
                                  double share2, double M_bar, double separation_change,
                                  double dx, double dy, double dz, double distance,
                                  double dvx, double dvy, double dvz, double* const jt){
    const double k = res->inertia_factor;
    const double nx = dx / distance;
    const double ny = dy / distance;
    const double nz = dz / distance;
    const double lever = distance / (R1 + R2);
    const double a1 = R1 * lever;
    const double a2 = R2 * lever;
    const double sx = a1 * w1[0] + a2 * w2[0];
    const double sy = a1 * w1[1] + a2 * w2[1];
    const double sz = a1 * w1[2] + a2 * w2[2];
    const double gx = dvx - (sy * nz - sz * ny);
    const double gy = dvy - (sz * nx - sx * nz);
    const double gz = dvz - (sx * ny - sy * nx);
    const double gn = gx * nx + gy * ny + gz * nz;
    const double gtx = gx - gn * nx;
    const double gty = gy - gn * ny;
    const double gtz = gz - gn * nz;
    const double f_t = 1.0 / (1.0 + lever * lever * (share1 / k + share2 / k));
    const double gt2 = gtx * gtx + gty * gty + gtz * gtz;
    double c;
    if (res->friction_model == RS_FRICTION_CONSTANT){
        c = (1.0 + res->friction[0]) * f_t;
    }else{
        const double stick = (1.0 + res->friction[1]) * f_t;
        const double gt = sqrt(gt2);
        const double limit = res->friction[0] * separation_change;
        if (stick * gt > limit){
            c = limit / gt;
            res->stats.n_sliding++;
        }else{
            c = stick;
        }
    }
    jt[0] = -(c * gtx);
    jt[1] = -(c * gty);
    jt[2] = -(c * gtz);
    const double cx = ny * jt[2] - nz * jt[1];
    const double cy = nz * jt[0] - nx * jt[2];
    const double cz = nx * jt[1] - ny * jt[0];
    const double f1 = lever * share1 / (k * R1);
    const double f2 = lever * share2 / (k * R2);
    w1[0] -= f1 * cx;
    w1[1] -= f1 * cy;
    w1[2] -= f1 * cz;
    w2[0] -= f2 * cx;
    w2[1] -= f2 * cy;
    w2[2] -= f2 * cz;
    res->stats.tangential_dissipation += 0.5 * M_bar * c * (2.0 - c / f_t) * gt2;
}

/* Contact found: dx, dy, dz and distance are the separation at the contact (end of the
 * step, or back_time earlier on the straight relative path), dv the relative velocity.
 * Applies the impulse; for back_time > 0 moves both particles to where the new
 * velocities take them in the rest of the step.  Returns 1 if resolved. */
static int rs_apply_impulse(struct reb_simulation* const r, struct rs_resolver* const res,
                            struct reb_particle* const p1, struct reb_particle* const p2,
                            const struct reb_vec6d gb, double dx, double dy, double dz,
                            double distance, double dvx, double dvy, double dvz,
                            double back_time){
    const double v_n = (dvx * dx + dvy * dy + dvz * dz) / distance;   /* < 0: approaching */
    const double speed_scale = fabs(p1->vx) + fabs(p1->vy) + fabs(p1->vz)
                               + fabs(gb.vx) + fabs(gb.vy) + fabs(gb.vz)
                               + fabs(p2->vx) + fabs(p2->vy) + fabs(p2->vz);
    if (!(-v_n > RS_ROUNDOFF_SPEED * speed_scale)){
        return 0;   /* receding, or a normal speed below round-off */
    }
    const double m1 = p1->m;
    const double m2 = p2->m;
    const double total_mass = m1 + m2;
    if (!(total_mass > 0.0)){
        return 0;   /* two massless particles: no momentum to exchange */
    }
    const double R_bar = p1->r * p2->r / (p1->r + p2->r);
    const double M_bar = m1 * m2 / total_mass;
    const double impact_speed = -v_n;
    const double eps = rs_law_epsilon(res, impact_speed, R_bar, M_bar);

    /* Separation speed after the collision, raised to REBOUND's minimum if needed. */
    double separation_change = (1.0 + eps) * impact_speed;
    const double r_min = (p1->r > p2->r) ? p2->r : p1->r;
    const double r_max = (p1->r < p2->r) ? p2->r : p1->r;
    double v_floor = r_min * r->minimum_collision_velocity;
    v_floor *= 1.0 - (distance - r_max) / r_min;
    if (v_floor > r_max * r->minimum_collision_velocity){
        v_floor = r_max * r->minimum_collision_velocity;
    }
    int floored = 0;
    if (separation_change < v_floor){
        separation_change = v_floor;
        floored = 1;
    }
    res->stats.normal_dissipation += 0.5 * M_bar * separation_change
                                     * (2.0 * impact_speed - separation_change);

    const double old_vy_outer = dx > 0.0 ? p1->vy : p2->vy;
    double jx = separation_change * (dx / distance);
    double jy = separation_change * (dy / distance);
    double jz = separation_change * (dz / distance);
    const double share2 = m1 / total_mass;
    const double share1 = m2 / total_mass;
    if (res->friction_model != RS_FRICTION_NONE){
        /* Rough spheres: add the tangential impulse, turn the spins (no friction: the
         * smooth path above is untouched, bit for bit). */
        const size_t i1 = (size_t)(p1 - r->particles);
        const size_t i2 = (size_t)(p2 - r->particles);
        if (!rs_spin_reserve(res, (int64_t)r->N)){
            r->status = REB_STATUS_GENERIC_ERROR;   /* out of memory */
            return 0;
        }
        /* The spins in the rotating frame's axes at the contact time (they precess at
         * -Omega there between collisions), turned, and stored back. */
        const double theta = rs_spin_frame_angle(r, r->t - back_time);
        const double c = cos(theta);
        const double sn = sin(theta);
        double w1[3], w2[3], jt[3];
        rs_spin_to_rotating(&res->spin[3 * i1], c, sn, w1);
        rs_spin_to_rotating(&res->spin[3 * i2], c, sn, w2);
        rs_tangential_impulse(res, w1, w2, p1->r, p2->r, share1, share2, M_bar,
                              separation_change, dx, dy, dz, distance, dvx, dvy, dvz, jt);
        rs_spin_from_rotating(w1, c, sn, &res->spin[3 * i1]);
        rs_spin_from_rotating(w2, c, sn, &res->spin[3 * i2]);
        jx += jt[0];
        jy += jt[1];
        jz += jt[2];
    }
    p2->vx -= share2 * jx;
    p2->vy -= share2 * jy;
    p2->vz -= share2 * jz;
    p1->vx += share1 * jx;
    p1->vy += share1 * jy;
    p1->vz += share1 * jz;
    if (back_time > 0.0){
        /* The new velocities act for the back_time left after the contact. */
        p2->x -= back_time * (share2 * jx);
        p2->y -= back_time * (share2 * jy);
        p2->z -= back_time * (share2 * jz);
        p1->x += back_time * (share1 * jx);
        p1->y += back_time * (share1 * jy);
        p1->z += back_time * (share1 * jz);
    }

    /* y-momentum flux through x (REBOUND's ring-simulation bookkeeping). */
    if (dx > 0.0){
        r->collisions_plog += -fabs(dx) * (old_vy_outer - p1->vy) * m1;
    }else{
        r->collisions_plog += -fabs(dx) * (old_vy_outer - p2->vy) * m2;
    }
    r->collisions_log_n++;

    rs_record(res, r->t, impact_speed, R_bar, M_bar, eps, floored);
    return 1;
}

/* After an impulse between c.p1 and c.p2: stamps both particles' deflections and counts
 * the collision in multi_encounters if either had been deflected earlier in this step.
 * Returns 0 if memory ran out. */
static int rs_count_deflections(const struct reb_simulation* const r,
                                struct rs_resolver* const res, const struct reb_collision c){
    const double m1 = r->particles[c.p1].m;
    const double m2 = r->particles[c.p2].m;
    const int repeated = rs_pair_memory_stamp(&res->memory, r, c.p1, c.p2,
                                              rs_deflects(m1, m2), rs_deflects(m2, m1));
    if (repeated < 0){
        return 0;
    }
    res->stats.multi_encounters += repeated;
    return 1;
}

int rs_resolve_pair(struct reb_simulation* const r, struct rs_resolver* const res,
                    struct reb_collision c, int swept){
    struct reb_particle* const p1 = &r->particles[c.p1];
    struct reb_particle* const p2 = &r->particles[c.p2];
    const struct reb_vec6d gb = c.gb;

    const double dx = p1->x + gb.x - p2->x;
    const double dy = p1->y + gb.y - p2->y;
    const double dz = p1->z + gb.z - p2->z;
    const double sum_radii = p1->r + p2->r;
    const double distance2 = dx * dx + dy * dy + dz * dz;
    const double dvx = p1->vx + gb.vx - p2->vx;
    const double dvy = p1->vy + gb.vy - p2->vy;
    const double dvz = p1->vz + gb.vz - p2->vz;
    const int overlapping = distance2 < sum_radii * sum_radii;
    struct rs_pair_memory* const memory = &res->memory;
    rs_pair_memory_sync(memory, r);

    int resolved = 0;
    uint64_t key = 0;
    if (!swept){
        /* Overlap at the end of the step (tree and direct search). */
        if (overlapping){
            resolved = rs_apply_impulse(r, res, p1, p2, gb, dx, dy, dz, sqrt(distance2), dvx,
                                        dvy, dvz, 0.0);
        }
    }else{
        /* Swept paths: the contact on the straight relative path dr(s) = dr - s dv, s the
         * time before the end of the step, is where the pair first touched. */
        key = rs_pair_key(c.p1, c.p2);
        if (rs_pair_memory_contains(memory, key)){
            return 0;   /* resolved earlier in this step: the report is of the old path */
        }
        const double a = dvx * dvx + dvy * dvy + dvz * dvz;
        const double b = dx * dvx + dy * dvy + dz * dvz;
        const double gap = distance2 - sum_radii * sum_radii;
        const double discriminant = b * b - a * gap;
        double back_time = 0.0;
        if (a > 0.0 && discriminant >= 0.0){
            back_time = (b + sqrt(discriminant)) / a;
        }
        if (back_time > 0.0 && back_time <= r->dt_last_done){
            const double cx = dx - back_time * dvx;
            const double cy = dy - back_time * dvy;
            const double cz = dz - back_time * dvz;
            const double contact = sqrt(cx * cx + cy * cy + cz * cz);
            resolved = rs_apply_impulse(r, res, p1, p2, gb, cx, cy, cz, contact, dvx, dvy,
                                        dvz, back_time);
        }else if (overlapping){
            /* Touching since before this step: resolve at the end, as in tree mode. */
            resolved = rs_apply_impulse(r, res, p1, p2, gb, dx, dy, dz, sqrt(distance2),
                                        dvx, dvy, dvz, 0.0);
        }
    }
    if (!resolved){
        return 0;
    }
    if (!rs_count_deflections(r, res, c) || (swept && !rs_pair_memory_insert(memory, key))){
        r->status = REB_STATUS_GENERIC_ERROR;   /* out of memory */
    }
    return 1;
}

int rs_resolve_contact(struct reb_simulation* const r, struct rs_resolver* const res,
                       struct reb_collision c, double back_time, double kick_time){
    struct reb_particle* const p1 = &r->particles[c.p1];
    struct reb_particle* const p2 = &r->particles[c.p2];
    const struct reb_vec6d gb = c.gb;
    double dvx = p1->vx + gb.vx - p2->vx;
    double dvy = p1->vy + gb.vy - p2->vy;
    double dvz = p1->vz + gb.vz - p2->vz;
    double cx = p1->x + gb.x - p2->x - back_time * dvx;
    double cy = p1->y + gb.y - p2->y - back_time * dvy;
    double cz = p1->z + gb.z - p2->z - back_time * dvz;
    if (kick_time > 0.0 && back_time > kick_time){
        /* before the kick: dr(s) = dr - s dv + (s - kick_time) dk, velocity dv - dk */
        const double dt = r->dt_last_done;
        const double dkx = (p1->ax - p2->ax) * dt;
        const double dky = (p1->ay - p2->ay) * dt;
        const double dkz = (p1->az - p2->az) * dt;
        const double before = back_time - kick_time;
        cx += before * dkx;
        cy += before * dky;
        cz += before * dkz;
        dvx -= dkx;
        dvy -= dky;
        dvz -= dkz;
    }
    const double contact = sqrt(cx * cx + cy * cy + cz * cz);
    rs_pair_memory_sync(&res->memory, r);
    if (!rs_apply_impulse(r, res, p1, p2, gb, cx, cy, cz, contact, dvx, dvy, dvz, back_time)){
        return 0;
    }
    if (!rs_count_deflections(r, res, c)){
        r->status = REB_STATUS_GENERIC_ERROR;   /* out of memory */
    }
    return 1;
}

/* REBOUND's collision_resolve callback: tree and direct search report overlaps at the
 * end of the step, line and linetree swept paths. */
int rs_resolve(struct reb_simulation* const r, struct reb_collision c){
    struct rs_resolver* const res = rs_resolver_of(r);
    if (res == NULL){
        r->status = REB_STATUS_GENERIC_ERROR;   /* installed without its parameters */
        return 0;
    }
    const int swept = r->collision == REB_COLLISION_LINE
                      || r->collision == REB_COLLISION_LINETREE;
    rs_resolve_pair(r, res, c, swept);
    return 0;
}

/* Resolve a list of collisions in order, as REBOUND's collision loop would (without
 * its shuffle); returns how many were resolved.  Lets benchmarks time the resolver
 * without a Python call per collision. */
int64_t rs_resolve_batch(struct reb_simulation* const r, const struct reb_collision* collisions,
                         int64_t n){
    const int64_t before = rs_resolver_of(r) ? rs_resolver_of(r)->stats.count : 0;
    for (int64_t i = 0; i < n; i++){
        rs_resolve(r, collisions[i]);
    }
    const struct rs_resolver* res = rs_resolver_of(r);
    return res ? res->stats.count - before : 0;
}
