/**
 * @file    rs_gravity.c
 * @brief   The field of the shearing sheet beyond REBOUND's ghost boxes (ringsim).
 *
 * | effect     | ghost-box truncation field of a self-gravitating shearing sheet          |
 * |------------|--------------------------------------------------------------------------|
 * | installed  | as REBOUND's additional_forces, by ringsim.gravity.tree.install_ghost_field |
 * | parameters | none of its own: Omega, G, the box (root_size, N_root_x/y), the ghost-box  |
 * |            | rings N_ghost_x/y, the boundary and t are read from the simulation        |
 * | Python twin| ringsim.physics.ghost_field.ghost_truncation_field (same formulae, numpy) |
 *
 * Physics.  REBOUND's tree gravity in a shear-periodic box sums the box and its
 * (2 N_ghost_x + 1)(2 N_ghost_y + 1) ghost copies and nothing beyond them, with no
 * background term: the missing sheet pulls every particle towards the hole's edge and the
 * vertical field lacks its distant part (13-77 % rms force error at N_ghost = 1-2,
 * docs/gravity.md).  This function adds the missing part, modelling the sheet beyond the
 * ghost boxes as uniform, of surface density Sigma = M / (Lx Ly), in the plane z = z_cm of
 * the centre of mass and with the ghost boxes' union shifted by its horizontal position:
 *
 *     g_missing(r) = g_infinite_sheet(r) - sum_rows g_rectangle_i(r)
 *
 * g_infinite_sheet = (0, 0, -2 pi G Sigma sign(z - z_cm)); row i = -N_ghost_x..N_ghost_x of
 * the ghost boxes is the uniform rectangle [x_cm + (i - 1/2) Lx, x_cm + (i + 1/2) Lx] x
 * [y_cm + o_i - (N_ghost_y + 1/2) Ly, y_cm + o_i + (N_ghost_y + 1/2) Ly] whose field is
 * closed-form (asinh and atan2 terms, as ringsim.physics.selfgravity._rectangle_field).
 * o_i is the azimuthal offset of REBOUND 5.2.2's ghost row i at the simulation time r->t
 * (reb_boundary_get_ghostbox: -1.5 Omega i Lx t wrapped into REBOUND's range), and r->t is
 * the time of REBOUND's own gravity evaluation, since REBOUND calls additional_forces right
 * after the tree gravity in reb_simulation_update_acceleration (SEI: at mid-step).
 *
 * Validity.  Exact for a uniform sheet; for a granular one the neglected part is the
 * quadrupole of point images minus uniform rows, which falls as N_ghost^-2 beyond the ghost
 * boxes, plus terms of order ((z - z_cm) / Lx)^2.  With one ghost ring and opening angle 0.3
 * the total rms force error is 0.5-0.7 % on a tau = 0.5 sheet (tests/test_gravwire.py,
 * benchmarks/gravity.py).  Assumes: boundary "shear" (or "periodic": offsets 0), no
 * vertical ghost boxes (N_ghost_z = 0), the particles inside the box (REBOUND wraps them
 * before the gravity evaluation), all particles massive and real (N_var = 0), and total
 * mass > 0 (else it does nothing).  Other boundaries: it does nothing.  Cost: O(N (2
 * N_ghost_x + 1)) with ~13 transcendental functions per particle and row.  The field is not
 * velocity dependent.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include "rebound.h"

/* asinh(a / b) with b >= 0, b = 0 treated as the smallest positive double. */
static double rs_asinh_ratio(double a, double b){
    return asinh(a / (b > 1e-300 ? b : 1e-300));
}

/* Field per G Sigma [m] of the uniform rectangle [u1, u2] x [v1, v2] (coordinates relative to
 * the target) lying a height Z below the target (Z = z_target - z_plane). */
static void rs_rectangle_field(double u1, double u2, double v1, double v2, double Z,
                               double* gx, double* gy, double* gz){
    const double rho1 = hypot(u1, Z), rho2 = hypot(u2, Z);
    *gx = rs_asinh_ratio(v2, rho1) - rs_asinh_ratio(v2, rho2)
        - rs_asinh_ratio(v1, rho1) + rs_asinh_ratio(v1, rho2);
    const double sig1 = hypot(v1, Z), sig2 = hypot(v2, Z);
    *gy = rs_asinh_ratio(u2, sig1) - rs_asinh_ratio(u2, sig2)
        - rs_asinh_ratio(u1, sig1) + rs_asinh_ratio(u1, sig2);
    const double absz = fabs(Z);
    const double c22 = atan2(u2 * v2, absz * sqrt(u2 * u2 + v2 * v2 + Z * Z));
    const double c12 = atan2(u1 * v2, absz * sqrt(u1 * u1 + v2 * v2 + Z * Z));
    const double c21 = atan2(u2 * v1, absz * sqrt(u2 * u2 + v1 * v1 + Z * Z));
    const double c11 = atan2(u1 * v1, absz * sqrt(u1 * u1 + v1 * v1 + Z * Z));
    const double sign = (Z > 0.0) - (Z < 0.0);
    *gz = -sign * (c22 - c12 - c21 + c11);
}

/* Azimuthal offset [m] of REBOUND 5.2.2's ghost row i at time t (reb_boundary_get_ghostbox,
 * boundary "shear"). */
static double rs_row_offset(int i, double Omega, double Lx, double Ly, double t){
    const double shiftvy = -1.5 * (double)i * Omega * Lx;
    double shift;
    if (i == 0){
        shift = -fmod(shiftvy * t, Ly);
    }else if (i > 0){
        shift = -fmod(shiftvy * t - 0.5 * Ly, Ly) - 0.5 * Ly;
    }else{
        shift = -fmod(shiftvy * t + 0.5 * Ly, Ly) + 0.5 * Ly;
    }
    return -shift;
}

/* Largest N_ghost_x the function handles (row offsets kept on the stack). */
#define RS_GHOST_ROWS_MAX 64

/* REBOUND's additional_forces: add the ghost-box truncation field to every particle's
 * acceleration (see the file header). */
void rs_ghost_field(struct reb_simulation* const r){
    const int periodic = r->boundary == REB_BOUNDARY_PERIODIC;
    if ((r->boundary != REB_BOUNDARY_SHEAR && !periodic) || r->N_ghost_x > RS_GHOST_ROWS_MAX){
        return;
    }
    const size_t n = r->N - r->N_var;
    struct reb_particle* const ps = r->particles;
    double M = 0.0, xm = 0.0, ym = 0.0, zm = 0.0;
    for (size_t k = 0; k < n; k++){
        M += ps[k].m;
        xm += ps[k].m * ps[k].x;
        ym += ps[k].m * ps[k].y;
        zm += ps[k].m * ps[k].z;
    }
    if (!(M > 0.0)){
        return;
    }
    xm /= M;
    ym /= M;
    zm /= M;
    const double Lx = r->root_size * (double)r->N_root_x;
    const double Ly = r->root_size * (double)r->N_root_y;
    const double G_sigma = r->G * M / (Lx * Ly);
    const int nx = r->N_ghost_x, ny = r->N_ghost_y;
    double offset[2 * RS_GHOST_ROWS_MAX + 1];
    for (int i = -nx; i <= nx; i++){
        offset[i + nx] = periodic ? 0.0 : rs_row_offset(i, r->OMEGA, Lx, Ly, r->t);
    }
    const double half_rows = ((double)ny + 0.5) * Ly;
    const double two_pi = 6.283185307179586;   /* 2 pi (M_PI is not C99) */
    for (size_t k = 0; k < n; k++){
        const double Z = ps[k].z - zm;
        double ax = 0.0, ay = 0.0;
        double az = -two_pi * (double)((Z > 0.0) - (Z < 0.0));
        for (int i = -nx; i <= nx; i++){
            const double u1 = xm + ((double)i - 0.5) * Lx - ps[k].x;
            const double u2 = xm + ((double)i + 0.5) * Lx - ps[k].x;
            const double yc = ym + offset[i + nx] - ps[k].y;
            double gx, gy, gz;
            rs_rectangle_field(u1, u2, yc - half_rows, yc + half_rows, Z, &gx, &gy, &gz);
            ax -= gx;
            ay -= gy;
            az -= gz;
        }
        ps[k].ax += G_sigma * ax;
        ps[k].ay += G_sigma * ay;
        ps[k].az += G_sigma * az;
    }
}

/* ------------------------------------------------------------------------------------ */
/* The slab solver (sheet.gravity_solver: slab): the field of the sheet's horizontally
 * averaged layer only.
 *
 * | effect     | vertical field of the plane-parallel layer (the k = 0 mode of self-gravity) |
 * | installed  | as REBOUND's additional_forces, by ringsim.gravity.slab.install            |
 * | parameters | none of its own: G and the box (root_size, N_root_x/y) from the simulation |
 * | Python twin| ringsim.physics.selfgravity.slab_field (same formula, numpy)              |
 *
 * Each particle j, spread uniformly over the box's area A = Lx Ly and its periodic images,
 * is an infinite sheet of surface density m_j / A, whose field is 2 pi G m_j / A towards
 * it on either side, whatever the distance:
 *
 *     a_z,i = -(2 pi G / A) (M_below,i - M_above,i)
 *
 * with M_below,i (M_above,i) the mass of the other particles below (above) particle i.  No
 * horizontal force.  It is exact for the mean density of the sheet, and leaves out every
 * mode with k != 0: the pull between neighbours, wakes, gravitational encounters.  So it is
 * the right approximation where those are negligible (Toomre Q >> 2, encounter speeds far
 * below the velocity dispersion) and wrong elsewhere; docs/gravity.md ("Slab") compares
 * it with the tree.  Cost: a sort by z, O(N log N).  Ties in z (equal heights) are ordered
 * by index.  Momentum: the forces are antisymmetric pair by pair (sum m a_z = 0 up to
 * round-off of the prefix sums). */

struct rs_height {
    double z;
    int64_t index;
};

static int rs_height_order(const void* a, const void* b){
    const struct rs_height* p = a;
    const struct rs_height* q = b;
    if (p->z != q->z){
        return p->z < q->z ? -1 : 1;
    }
    return (p->index > q->index) - (p->index < q->index);
}

/* REBOUND's additional_forces: add the slab field to every particle's acceleration (see
 * above).  Out of memory: REB_STATUS_GENERIC_ERROR (the run loop stops with an error). */
void rs_slab_field(struct reb_simulation* const r){
    const size_t n = r->N - r->N_var;
    if (n < 2){
        return;
    }
    struct reb_particle* const ps = r->particles;
    struct rs_height* order = malloc(n * sizeof(struct rs_height));
    if (order == NULL){
        r->status = REB_STATUS_GENERIC_ERROR;
        return;
    }
    double total = 0.0;
    for (size_t k = 0; k < n; k++){
        order[k] = (struct rs_height){ps[k].z, (int64_t)k};
        total += ps[k].m;
    }
    qsort(order, n, sizeof(struct rs_height), rs_height_order);
    const double Lx = r->root_size * (double)r->N_root_x;
    const double Ly = r->root_size * (double)r->N_root_y;
    const double c = 6.283185307179586 * r->G / (Lx * Ly);   /* 2 pi G / A */
    double below = 0.0;
    for (size_t k = 0; k < n; k++){
        struct reb_particle* const p = &ps[order[k].index];
        const double above = total - below - p->m;
        p->az -= c * (below - above);
        below += p->m;
    }
    free(order);
}
