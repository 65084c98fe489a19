/**
 * @file    rs_resolver.h
 * @brief   Shared declarations of ringsim's collision resolver (rs_resolver.c) and its
 *          shearing-sheet swept-sphere detector (rs_sheet_detect.c).
 *
 * Both files are compiled into one extension, ringsim._resolver.  The structs below are
 * mirrored field by field by ctypes in ringsim/engine/native.py, which checks their sizes at
 * import: change both together.
 */
#ifndef RS_RESOLVER_H
#define RS_RESOLVER_H

#include <stddef.h>
#include <stdint.h>
#include "rebound.h"

/* Histogram layout (documented in ringsim/engine/native.py as well). */
#define RS_VN_NBINS 90          /* log10 v from -7 to 2, 10 bins per decade */
#define RS_LAW_PARAMS 4         /* param[] slots of a restitution law (RESTITUTION.n_slots) */
#define RS_EPS_NBINS 40         /* log10(1 - eps) from -4 to 0, 10 bins per decade */
/* A collision deflects a particle when the partner carries at least this share of the
 * pair's mass (multi_encounters; the sheet detector's contacts per step; also
 * MULTI_ENCOUNTER_MASS_SHARE in ringsim/engine/timestep.py). */
#define RS_DEFLECTING_MASS_SHARE 0.1

/* Whether a collision deflects a particle of mass m [kg] struck by one of m_partner [kg]. */
static inline int rs_deflects(double m, double m_partner){
    return m_partner >= RS_DEFLECTING_MASS_SHARE * (m + m_partner);
}

struct rs_log_entry {
    double t;           /* [s] simulation time of the collision */
    double v_n;         /* [m/s] normal impact speed */
    double R_bar;       /* [m] reduced radius */
    double M_bar;       /* [kg] reduced mass */
    double epsilon;     /* coefficient of restitution of the law */
};

struct rs_stats {
    int64_t count;                          /* resolved collisions */
    int64_t n_floored;                      /* of which the minimum velocity raised J */
    double sum_epsilon;
    double sum_vn;                          /* [m/s] */
    int64_t vn_underflow;
    int64_t vn_overflow;
    int64_t vn_hist[RS_VN_NBINS];
    int64_t eps_underflow;                  /* 1 - eps < 1e-4 */
    int64_t eps_hist[RS_EPS_NBINS];
    int64_t log_written;                    /* entries written to the ring buffer */
    int64_t multi_encounters;               /* collisions in which a partner had already
                                               been deflected earlier in the same step */
    int64_t outside_speeds;                 /* impact speed outside the law's measured
                                               range (rs_resolver.measured[0..1]) */
    int64_t outside_sizes;                  /* reduced radius outside its measured range
                                               (rs_resolver.measured[2..3]) */
    double tangential_dissipation;          /* [J] kinetic energy (translation + rotation)
                                               the tangential impulses dissipated */
    int64_t n_sliding;                      /* collisions on which Coulomb's bound acted */
    double normal_dissipation;              /* [J] kinetic energy the normal impulses
                                               dissipated, 1/2 M_bar J (2 v_n - J) with
                                               J the separation-speed change (floor
                                               included) */
    int64_t speeds_below;                   /* of outside_speeds: v_n < measured[0] */
    int64_t speeds_above;                   /* of outside_speeds: v_n > measured[1] */
    int64_t sizes_below;                    /* of outside_sizes: R_bar < measured[2] */
    int64_t sizes_above;                    /* of outside_sizes: R_bar > measured[3] */
    int64_t masses_below;                   /* M_bar < measured_masses[0] */
    int64_t masses_above;                   /* M_bar > measured_masses[1] */
    int64_t critically_damped;              /* collisions whose law gives eps = 0 because
                                               its damping ratio xi >= 1 (dilley) */
    int64_t inside_all;                     /* collisions inside the measured speeds,
                                               reduced radii and reduced masses at once */
};

/* Pairs resolved in the current step of the swept-path modes (open-addressing set), and
 * per particle the step of its last collision (for multi_encounters). */
struct rs_pair_memory {
    const struct reb_simulation* sim;
    uint64_t step;              /* sim->steps_done when the pairs were resolved */
    int64_t n;
    int64_t capacity;           /* power of two, or 0 */
    uint64_t* keys;
    int64_t n_stamps;           /* length of last_step */
    uint64_t* last_step;        /* steps_done + 1 of each particle's last deflection */
};

struct rs_sheet_detector;       /* rs_sheet_detect.c */

struct rs_resolver {
    uint64_t magic;
    int32_t model;
    int32_t reserved;
    double param[RS_LAW_PARAMS];   /* the law's parameters by slot (restitution.py) */
    int64_t log_capacity;
    int64_t log_every;
    struct rs_log_entry* log;
    struct rs_stats stats;
    struct rs_pair_memory memory;
    struct rs_sheet_detector* detector;     /* NULL unless the sheet detector is used */
    void (*detector_free)(struct rs_sheet_detector*);   /* set with detector */
    double measured[4];     /* [m/s] speeds, [m] reduced radii the law's parameters were
                               measured over: v_min, v_max, R_min, R_max (0, inf: unknown) */
    int32_t friction_model; /* RS_FRICTION_NONE / _CONSTANT / _COULOMB */
    int32_t reserved2;
    double friction[3];     /* constant: beta; coulomb: mu, beta0 (slots of
                               ringsim.physics.friction.FRICTION) */
    double inertia_factor;  /* k in I = k m R^2 (0 < k <= 2/3) */
    double* spin;           /* [rad/s] 3 per particle, by particle index, relative to the
                               rotating frame of the sheet; x, y in the axes the frame
                               had at t = 0 (a torque-free spin is constant in inertial
                               space, so in the frame's axes it turns at -Omega): read
                               with rs_spins_read, set with rs_spins_write at the frame
                               angle rs_spin_frame_angle; NULL until needed */
    int64_t spin_capacity;  /* particles spin has room for */
    double measured_masses[2];  /* [kg] reduced masses the law's parameters were measured
                                   at: M_min, M_max (0, inf: unknown) */
};

/* Friction models (struct rs_resolver.friction_model). */
#define RS_FRICTION_NONE 0
#define RS_FRICTION_CONSTANT 1
#define RS_FRICTION_COULOMB 2

/* Room for the spins of n particles (zeros for new ones); 0 if memory ran out. */
int rs_spin_reserve(struct rs_resolver* res, int64_t n);

/* Frame angle [rad] at time t [s]: REBOUND's OMEGA t (0 by default: an inertial frame). */
double rs_spin_frame_angle(const struct reb_simulation* r, double t);

/* Spins of particles 0..n-1 in the rotating frame's axes at frame angle theta [rad]
 * (w_x + i w_y = (s_x + i s_y) exp(-i theta)), 3 n doubles [rad/s], zero where never set;
 * rs_spins_write sets them from such values (rest zeroed; 0 if memory ran out). */
void rs_spins_read(const struct rs_resolver* res, double theta, int64_t n, double* out);
int rs_spins_write(struct rs_resolver* res, double theta, int64_t n, const double* values);

/* The resolver installed in r (through r->extras), or NULL. */
struct rs_resolver* rs_resolver_of(const struct reb_simulation* r);

/* Resolve one reported pair.  swept = 1: the pair's straight paths over the last step
 * came within R1 + R2 (resolved at first contact); swept = 0: it overlaps at the end of
 * the step (resolved there).  Returns 1 if an impulse was applied. */
int rs_resolve_pair(struct reb_simulation* r, struct rs_resolver* res, struct reb_collision c,
                    int swept);

/* Resolve pair c at a contact found by the caller: back_time [s] before the end of the
 * step on the pair's current relative path (0 <= back_time <= dt_last_done).  The path is
 * straight if kick_time = 0; with kick_time > 0 [s] it is kinked there by the kick of the
 * step's accelerations (v changed by a dt_last_done at kick_time before the end, as SEI
 * kicks at mid-step), so a contact earlier than the kick is met with the velocities before
 * it.  Impulse along the separation there, both particles moved on with their new
 * velocities for back_time (the kick is the same on either path), multi_encounters
 * counted; no per-step pair memory (the caller decides which pairs may collide again).
 * Returns 1 if an impulse was applied (0: receding or below round-off at that point). */
int rs_resolve_contact(struct reb_simulation* r, struct rs_resolver* res, struct reb_collision c,
                       double back_time, double kick_time);


#endif /* RS_RESOLVER_H */
