/* The symplectic epicycle integrator (SEI, Rein & Tremaine 2011, MNRAS 415, 3168) on
 * OpenMP threads, registered with REBOUND as the user integrator "ringsim_sei".
 *
 * REBOUND's pip wheel is built without OpenMP, so its own SEI step (an exact epicycle
 * and vertical-oscillation drift of dt/2, the kick of the accelerations, a second drift)
 * runs on one core.  This integrator does the same arithmetic, operation for operation,
 * with each particle's drift and kick on some thread: the particles do not interact
 * within these loops, so the result is the same bits on any number of threads, and the
 * same bits as REBOUND's "sei" (tests/test_sei.py).
 *
 * The step:
 *   1. drift every particle by dt/2 under Hill's equations without forces (H0): the
 *      vertical oscillation and the epicycle about the guiding centre, each a rotation
 *      by Omega dt/2 written as three shears (x' = x - tan(Omega dt/4) y,
 *      y' = y + sin(Omega dt/2) x', x'' = x' - tan(Omega dt/4) y'), so that round-off
 *      keeps the rotation area-preserving; the guiding centre moves along y by the shear;
 *   2. t += dt/2; the accelerations as REBOUND's reb_simulation_update_acceleration
 *      computes them (gravity, then the additional forces); with REBOUND's gravity off
 *      (ringsim's solvers are additional forces) its serial loop that sets every
 *      acceleration to zero runs here on the threads (rs_sei_accelerations);
 *   3. kick every particle's velocity by a dt and drift again by dt/2; t += dt/2.
 *
 * REBOUND's own functions are reached through pointers handed over by Python
 * (rs_sei_register): the library is loaded without REBOUND's symbols in its scope.
 */
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#include "rebound.h"

/* Particles a thread at least before the loops are split (below, starting the threads
 * costs more than the drift saves; docs/performance.md, "The SEI step on threads"). */
#define RS_SEI_PARTICLES_PER_THREAD 8192

typedef void (*rs_update_acceleration_fn)(struct reb_simulation* r);
typedef void (*rs_register_fn)(const struct reb_integrator integrator, const char* name);

static rs_update_acceleration_fn rs_update_acceleration = NULL;

/* The integrator's state, one per simulation: the number of threads (a speed setting,
 * never a result; saved with the simulation as REBOUND saves any integrator field). */
struct rs_sei_state {
    int threads;
};

/* The rotation of one drift by dt/2 at frequency omega: tan(-omega dt/4), sin(-omega dt/2). */
struct rs_rotation {
    double tan_quarter;
    double sin_half;
};

static struct rs_rotation rs_rotation_for(double omega, double dt){
    struct rs_rotation rot;
    rot.sin_half = sin(omega * (-dt / 2.));
    rot.tan_quarter = tan(omega * (-dt / 4.));
    return rot;
}

/* Drift of one particle by dt/2 under H0 (step 1). */
static inline void rs_drift(struct reb_particle* p, double dt, double omega, double omega_z,
                            struct rs_rotation in_plane, struct rs_rotation vertical){
    /* vertical oscillation: (z omega_z, vz) rotated */
    const double u = p->z * omega_z;
    const double w = p->vz;
    const double u1 = u - vertical.tan_quarter * w;
    const double w1 = vertical.sin_half * u1 + w;
    const double u2 = u1 - vertical.tan_quarter * w1;
    p->z = u2 / omega_z;
    p->vz = w1;

    /* epicycle: guiding centre (a, b) and the epicycle vector (xs, ys) rotated */
    const double a = 2. * p->vy + 4. * p->x * omega;
    const double b = p->y * omega - 2. * p->vx;
    const double ys = (p->y * omega - b) / 2.;
    const double xs = p->x * omega - a;
    const double xs1 = xs - in_plane.tan_quarter * ys;
    const double ys1 = in_plane.sin_half * xs1 + ys;
    const double xs2 = xs1 - in_plane.tan_quarter * ys1;
    p->x = (xs2 + a) / omega;
    p->y = (ys1 * 2. + b) / omega - 3. / 4. * a * dt;
    p->vx = ys1;
    p->vy = -xs2 * 2. - 3. / 2. * a;
}

static int rs_sei_team(const struct rs_sei_state* s, int n){
    const int useful = n / RS_SEI_PARTICLES_PER_THREAD;
    const int team = s->threads < useful ? s->threads : useful;
    return team > 1 ? team : 1;
}

/* Step 2: REBOUND's reb_simulation_update_acceleration.  With gravity off and no
 * variational particles REBOUND sets every acceleration to zero and calls the additional
 * forces; those zeros are set here on the team's threads, the same values.  Every other
 * configuration (REBOUND's gravity, variational particles) is REBOUND's own call. */
static void rs_sei_accelerations(struct reb_simulation* const r, int team){
    if (r->gravity != REB_GRAVITY_NONE || r->N_var != 0){
        rs_update_acceleration(r);
        return;
    }
    struct reb_particle* const particles = r->particles;
    const int n = (int)r->N;
    (void)team;
#pragma omp parallel for schedule(static) num_threads(team)
    for (int i = 0; i < n; i++){
        particles[i].ax = 0.;
        particles[i].ay = 0.;
        particles[i].az = 0.;
    }
    if (r->additional_forces){
        r->additional_forces(r);
    }
}

static void rs_sei_step(struct reb_simulation* const r, void* state){
    const struct rs_sei_state* s = state;
    r->gravity_ignore_terms = REB_GRAVITY_IGNORE_TERMS_NONE;
    if (r->OMEGAZ == -1){
        r->OMEGAZ = r->OMEGA;
    }
    const double dt = r->dt;
    const double omega = r->OMEGA;
    const double omega_z = r->OMEGAZ;
    const struct rs_rotation in_plane = rs_rotation_for(omega, dt);
    const struct rs_rotation vertical = rs_rotation_for(omega_z, dt);
    struct reb_particle* const particles = r->particles;
    const int n = (int)r->N;
    const int team = rs_sei_team(s, n);
    (void)team;

#pragma omp parallel for schedule(static) num_threads(team)
    for (int i = 0; i < n; i++){
        rs_drift(&particles[i], dt, omega, omega_z, in_plane, vertical);
    }
    r->t += dt / 2.;

    rs_sei_accelerations(r, team);

#pragma omp parallel for schedule(static) num_threads(team)
    for (int i = 0; i < n; i++){
        struct reb_particle* const p = &particles[i];
        p->vx += p->ax * dt;
        p->vy += p->ay * dt;
        p->vz += p->az * dt;
        rs_drift(p, dt, omega, omega_z, in_plane, vertical);
    }
    r->t += dt / 2.;
    r->dt_last_done = dt;
}

static void* rs_sei_create(void){
    struct rs_sei_state* s = calloc(1, sizeof(struct rs_sei_state));
    if (s != NULL){
        s->threads = 1;
    }
    return s;
}

static void rs_sei_free(void* state){
    free(state);
}

static const struct reb_binarydata_field_descriptor rs_sei_fields[] = {
    {"OpenMP threads of the drift and kick loops (a speed setting; results do not depend "
     "on it).", REB_INT, "threads", offsetof(struct rs_sei_state, threads), 0, 0, NULL},
    {0},
};

static const struct reb_integrator rs_sei_integrator = {
    .documentation = "ringsim's symplectic epicycle integrator: REBOUND's SEI (Rein & "
                     "Tremaine 2011), the same arithmetic, with the drift and kick loops "
                     "on OpenMP threads.",
    .step = rs_sei_step,
    .synchronize = NULL,
    .create = rs_sei_create,
    .free = rs_sei_free,
    .did_add_particle = NULL,
    .will_remove_particle = NULL,
    .field_descriptor_list = rs_sei_fields,
};

/* Register the integrator under `name` with REBOUND (once per process; Python guards it),
 * given REBOUND's reb_integrator_register and reb_simulation_update_acceleration. */
void rs_sei_register(void* register_fn, void* update_acceleration_fn, const char* name){
    rs_update_acceleration = (rs_update_acceleration_fn)update_acceleration_fn;
    ((rs_register_fn)register_fn)(rs_sei_integrator, name);
}

/* Threads of the integrator state of `r` (the caller checks that r's integrator is
 * ringsim's).  Returns the number set (>= 1), or 0 without a state. */
int rs_sei_set_threads(struct reb_simulation* r, int threads){
    struct rs_sei_state* s = r->integrator.state;
    if (s == NULL){
        return 0;
    }
    s->threads = threads > 1 ? threads : 1;
    return s->threads;
}

/* Particles a thread at least before the loops are split (RS_SEI_PARTICLES_PER_THREAD). */
int rs_sei_particles_per_thread(void){
    return RS_SEI_PARTICLES_PER_THREAD;
}
