/**
 * @file    rs_p3m.c
 * @brief   Shear-periodic P3M self-gravity: mesh assignment/interpolation and the
 *          short-range pair sum (ringsim).
 *
 * | effect     | self-gravity of a shear-periodic sheet, particle-particle particle-mesh  |
 * |------------|--------------------------------------------------------------------------|
 * | installed  | ringsim.gravity.p3m.install_p3m: a Python additional_forces that calls     |
 * |            | rs_p3m_height_span (rs_p3m_heights), rs_p3m_prepare(_core), rs_p3m_assign, |
 * |            | (numpy FFT), rs_p3m_interpolate, rs_p3m_short; REBOUND's gravity "none"  |
 * | parameters | struct rs_p3m: split scale r_s [m], cutoff r_c [m], Plummer softening b   |
 * |            | [m], mesh nx x ny, layer spacing dz [m]; G, Omega, box and t from the sim |
 * | Python twin| ringsim.physics.p3m_mesh.long_range_fraction, P3MMesh (numpy)         |
 *
 * Physics.  Force split of Hockney & Eastwood / GADGET-2 (Springel 2005, eq. 21-22): the
 * Newtonian pair force is cut into a long-range part, the force between Gaussian clouds
 * (the potential multiplied by exp(-k^2 r_s^2) in Fourier space), solved on the mesh by
 * numpy FFTs, and the short-range rest, summed here over pairs closer than r_c:
 *
 *     a_i += -G m_j d [ (|d|^2 + b^2)^(-3/2) - L(|d|) / |d|^3 ],
 *     L(r) = erf(u) - (2 u / sqrt(pi)) exp(-u^2),   u = r / (2 r_s),
 *
 * so that mesh + pair sum is the Plummer force (REBOUND's softening b) within r_c and the
 * Newtonian force beyond it, up to the mesh's error and the neglected short-range rest
 * beyond r_c (1 - L(r_c) = 5.85e-3 at r_c = 5 r_s).  d = r_i - r_j is the nearest
 * shear-periodic image: j's images sit at (x_j + n Lx, y_j - n s + m Ly), s = 1.5 Omega Lx t
 * (REBOUND's ghost-box convention, ringsim.physics.selfgravity.shear_offset).  L(r)/r^3 is
 * tabulated in r^2 (RS_P3M_TABLE nodes, linear interpolation: relative error < 1e-6 of the
 * long-range pair force); the Plummer term is computed exactly.
 *
 * Mesh.  Cloud-in-cell onto nx x ny x nz nodes in sheared coordinates (x, y' = y + alpha x,
 * alpha = s / Lx; the box is doubly periodic there) and horizontal layers z0 + l dz that span
 * the particles' z range (rs_p3m_prepare sets z0 and nz at each call), or only the heights
 * [zlo, zhi] of the ring's dense core (rs_p3m_prepare_core, `sheet.p3m_tail_fraction`):
 * a particle beyond them is on the mesh at the nearer limit, its weights damped as the
 * slowest horizontal mode decays over its distance beyond (rs_p3m_cic); its pair sum and
 * the mean vertical field (rs_p3m_mean_vertical, over all particles) stay exact.
 *
 * Field-only pairs.  Two particles both smaller than pair_min_radius (0: none) interact
 * through the mesh only: the short-range rest of their pair is left out (every other pair
 * is summed from both sides, so momentum is still conserved).  In a size distribution
 * whose small particles carry little of the mass this removes most pairs
 * (`sheet.p3m_pair_min_radius`, docs/gravity.md).
 *
 * Validity.  r_c < min(Lx, Ly) (checked by the Python side), boundary "shear", particles
 * inside the box (REBOUND wraps them before the force evaluation), N_var = 0.  Each pair is
 * evaluated from both sides (gather): the pair forces are antisymmetric to round-off, so
 * the total momentum of the short-range forces vanishes to round-off.  Cost: an O(N) cell
 * list with cells of at least r_c / 2 (an area of about (2.5 r_c)^2 searched per particle;
 * boxes narrower than 2.5 r_c fall back to all pairs and their 3 x 3 nearest images); the
 * sources of a cell run are summed in one loop, or in two passes where enough of them lie
 * within r_c (rs_p3m_pairs: the same bits either way).  In a ring many r_c thick each
 * cell's sources are also indexed by height, and a target scans only the heights within
 * r_c of its own, summing what it finds in the same order (rs_p3m_window: the same bits).
 */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include "rebound.h"

#define RS_P3M_TABLE 4096

/* P3M parameters and per-call mesh geometry; mirrored by ringsim.engine.native.P3MStruct. */
struct rs_p3m {
    double split;          /* r_s [m] */
    double cutoff;         /* r_c [m] */
    double softening;      /* Plummer b [m] */
    double dz;             /* layer spacing [m] */
    int nx, ny;            /* horizontal mesh */
    int nz;                /* layers (set by rs_p3m_prepare) */
    int error;             /* nonzero: allocation failed in the last call */
    int threads;           /* OpenMP threads of interpolation and pair sum (<= 1: one) */
    int two_pass;          /* pair sum in two passes (set by rs_p3m_short from its last call) */
    int zwindow;           /* 1 (rs_p3m_init): a target scans only the height bins within
                              r_c of its own where the ring is thick; 0: whole columns */
    int zbins;             /* height bins of the last call's index of all particles (1: no
                              index; set by rs_p3m_short) */
    double z0;             /* height of layer 0 [m] (set by rs_p3m_prepare) */
    double shift;          /* shear offset s [m] at the call's time (rs_p3m_prepare) */
    double alpha;          /* s / Lx */
    double pair_min_radius;   /* [m]: pairs of two smaller particles are mesh-only */
    double zlo, zhi;       /* heights [m] the mesh spans (set by rs_p3m_prepare*): a particle
                              beyond them is on the mesh at the nearer of the two */
    double table[RS_P3M_TABLE + 2];   /* L(r)/r^3 [1/m^3] at r^2 = k rc^2 / RS_P3M_TABLE */
};

/* L(r)/r^3 [1/m^3] of the Gaussian split (series below u = 0.05, where the difference of
 * erf and its tangent loses digits). */
static double rs_p3m_long_over_r3(double r, double rs){
    const double u = r / (2.0 * rs);
    const double two_over_sqrt_pi = 1.1283791670955126;
    if (u < 0.05){
        const double u2 = u * u;
        /* (2/sqrt(pi)) (2/3 u^3 - 2/5 u^5 + 1/7 u^7) / r^3, r = 2 rs u */
        return two_over_sqrt_pi * (2.0 / 3.0 - 0.4 * u2 + u2 * u2 / 7.0)
               / (8.0 * rs * rs * rs);
    }
    return (erf(u) - two_over_sqrt_pi * u * exp(-u * u)) / (r * r * r);
}

/* Fill the table of L(r)/r^3 for the struct's split and cutoff. */
void rs_p3m_init(struct rs_p3m* p){
    const double rc2 = p->cutoff * p->cutoff;
    for (int k = 0; k < RS_P3M_TABLE + 2; k++){
        const double r = sqrt(rc2 * (double)k / (double)RS_P3M_TABLE);
        p->table[k] = rs_p3m_long_over_r3(r, p->split);
    }
    p->error = 0;
    p->two_pass = 0;
    p->zwindow = 1;
    p->zbins = 1;
}

/* Table lookup of L(r)/r^3 at r^2 = r2 < rc^2. */
static double rs_p3m_lookup(const struct rs_p3m* p, double r2, double inv_step){
    const double f = r2 * inv_step;
    const int k = (int)f;
    const double w = f - (double)k;
    return p->table[k] + w * (p->table[k + 1] - p->table[k]);
}

/* Shear offset s [m] at time t, wrapped into [-Ly/2, Ly/2) (as shear_offset in Python). */
static double rs_p3m_shift(double Omega, double Lx, double Ly, double t){
    double s = fmod(1.5 * Omega * Lx * t, Ly);
    if (s < 0.0){
        s += Ly;
    }
    return s >= 0.5 * Ly ? s - Ly : s;
}

/* Particles per thread below which the loops run on one thread. */
#define RS_P3M_PARTICLES_PER_THREAD 2048

/* Threads of a loop over n particles: p->threads, fewer for small n. */
static int rs_p3m_threads(const struct rs_p3m* p, size_t n){
    const size_t most = n / RS_P3M_PARTICLES_PER_THREAD;
    const int wanted = p->threads > 1 ? p->threads : 1;
    return most < (size_t)wanted ? (most > 1 ? (int)most : 1) : wanted;
}

/* Lowest and highest particle heights [m] (both 0 without particles). */
static void rs_p3m_z_range(const struct reb_simulation* const r, double* zmin, double* zmax){
    const size_t n = r->N - r->N_var;
    const struct reb_particle* const ps = r->particles;
    *zmin = 0.0;
    *zmax = 0.0;
    for (size_t k = 0; k < n; k++){
        if (k == 0 || ps[k].z < *zmin) *zmin = ps[k].z;
        if (k == 0 || ps[k].z > *zmax) *zmax = ps[k].z;
    }
}

/* Height span zmax - zmin [m] of the particles (0 for fewer than two), and their number in
 * *count: what the layers must span, from which ringsim.gravity.p3m chooses the split scale
 * of `sheet.p3m_split: auto` (ringsim.physics.p3m_scales.p3m_auto_split) before
 * rs_p3m_prepare. */
double rs_p3m_height_span(const struct reb_simulation* const r, int* count){
    *count = (int)(r->N - r->N_var);
    double zmin, zmax;
    rs_p3m_z_range(r, &zmin, &zmax);
    return zmax - zmin;
}

/* Set shift, alpha, z0 and nz for a mesh that spans the heights [zlo, zhi] [m] only (the
 * dense core of a ring whose heights have a sparse tail); returns nz.  A particle beyond
 * them is assigned to and interpolated from the mesh at the nearer of zlo and zhi (the same
 * stencil both ways: the mesh forces still sum to zero). */
int rs_p3m_prepare_core(struct reb_simulation* const r, struct rs_p3m* p, double zlo,
                        double zhi){
    const double Lx = r->root_size * (double)r->N_root_x;
    const double Ly = r->root_size * (double)r->N_root_y;
    p->shift = rs_p3m_shift(r->OMEGA, Lx, Ly, r->t);
    p->alpha = p->shift / Lx;
    const double l0 = floor(zlo / p->dz);
    p->z0 = l0 * p->dz;
    p->nz = (int)(floor(zhi / p->dz) - l0) + 2;
    p->zlo = zlo;
    p->zhi = zhi;
    return p->nz;
}

/* Set shift, alpha, z0 and nz for the current state, the layers spanning every particle;
 * returns nz. */
int rs_p3m_prepare(struct reb_simulation* const r, struct rs_p3m* p){
    double zmin, zmax;
    rs_p3m_z_range(r, &zmin, &zmax);
    return rs_p3m_prepare_core(r, p, zmin, zmax);
}

/* The particles' heights z [m] into out (N values, REBOUND's order). */
void rs_p3m_heights(const struct reb_simulation* const r, double* out){
    const size_t n = r->N - r->N_var;
    for (size_t k = 0; k < n; k++){
        out[k] = r->particles[k].z;
    }
}

/* The heights [m] of the particles of radius at least rmin [m] into out, in the order of
 * REBOUND's particles, and in *mass_share the fraction of the sheet's mass they hold;
 * returns their count (the particles whose heights set the mesh's core with
 * `sheet.p3m_core_min_radius`). */
int rs_p3m_heights_from(const struct reb_simulation* const r, double rmin, double* out,
                        double* mass_share){
    const size_t n = r->N - r->N_var;
    int count = 0;
    double all = 0.0, large = 0.0;
    for (size_t k = 0; k < n; k++){
        const struct reb_particle* const p = &r->particles[k];
        all += p->m;
        if (p->r >= rmin){
            out[count++] = p->z;
            large += p->m;
        }
    }
    *mass_share = all > 0.0 ? large / all : 0.0;
    return count;
}

/* The cloud-in-cell stencil of one particle: its two node columns in x and y (periodic),
 * the lower of its two layers, and the weights of both nodes along each axis.  Assignment
 * and interpolation use the same stencil, so the mesh force is the exact adjoint of the
 * mass assignment (no self-force, momentum conserved). */
struct rs_cic {
    size_t is[2], js[2];
    size_t l0;
    double wx[2], wy[2], wz[2];
};

/* The height [m] at which a particle at z is on the mesh, and in *fade the factor of its
 * mesh weights: z and 1 within [zlo, zhi]; beyond, the nearer limit and exp(-k1 d) (d its
 * distance beyond, k1 = 2 pi / max(Lx, Ly) the smallest horizontal wave number): the
 * slowest decay of the horizontal modes over d, applied to its assignment and its
 * interpolation alike, and undone within r_c by the pair sum (rs_p3m_pairs). */
static double rs_p3m_on_mesh(const struct rs_p3m* p, double z, double Lx, double Ly,
                             double* fade){
    *fade = 1.0;
    if (z <= p->zhi && z >= p->zlo){
        return z;
    }
    const double limit = z > p->zhi ? p->zhi : p->zlo;
    *fade = exp(-6.283185307179586 / fmax(Lx, Ly) * fabs(z - limit));
    return limit;
}

static struct rs_cic rs_p3m_cic(const struct rs_p3m* p, const struct reb_particle* q,
                                double Lx, double Ly){
    double gx = (q->x + 0.5 * Lx) / Lx;
    double gy = (q->y + p->alpha * q->x + 0.5 * Ly) / Ly;
    gx = (gx - floor(gx)) * (double)p->nx;
    gy = (gy - floor(gy)) * (double)p->ny;
    double fade;
    const double z = rs_p3m_on_mesh(p, q->z, Lx, Ly, &fade);
    double gz = (z - p->z0) / p->dz;
    int i0 = (int)floor(gx);
    int j0 = (int)floor(gy);
    int l0 = (int)floor(gz);
    if (l0 > p->nz - 2) l0 = p->nz - 2;
    if (l0 < 0) l0 = 0;
    const double fx = gx - (double)i0;
    const double fy = gy - (double)j0;
    const double fz = gz - (double)l0;
    i0 %= p->nx;
    j0 %= p->ny;
    struct rs_cic c;
    c.is[0] = (size_t)i0;
    c.is[1] = (size_t)((i0 + 1) % p->nx);
    c.js[0] = (size_t)j0;
    c.js[1] = (size_t)((j0 + 1) % p->ny);
    c.l0 = (size_t)l0;
    c.wx[0] = 1.0 - fx; c.wx[1] = fx;
    c.wy[0] = 1.0 - fy; c.wy[1] = fy;
    c.wz[0] = (1.0 - fz) * fade; c.wz[1] = fz * fade;
    return c;
}

/* Mass [kg] on the nodes, array (nz, nx, ny) in C order (layers outermost, so that the
 * horizontal FFTs run over contiguous planes), zeroed here. */
void rs_p3m_assign(struct reb_simulation* const r, const struct rs_p3m* p, double* mass){
    const size_t n = r->N - r->N_var;
    const struct reb_particle* const ps = r->particles;
    const double Lx = r->root_size * (double)r->N_root_x;
    const double Ly = r->root_size * (double)r->N_root_y;
    const size_t nz = (size_t)p->nz, ny = (size_t)p->ny, nxs = (size_t)p->nx;
    const size_t plane = nxs * ny, cells = plane * nz;
    for (size_t c = 0; c < cells; c++){
        mass[c] = 0.0;
    }
    for (size_t k = 0; k < n; k++){
        const struct rs_cic st = rs_p3m_cic(p, &ps[k], Lx, Ly);
        for (int a = 0; a < 2; a++){
            for (int b = 0; b < 2; b++){
                const size_t base = (st.l0 * nxs + st.is[a]) * ny + st.js[b];
                const double w = ps[k].m * st.wx[a] * st.wy[b];
                mass[base] += w * st.wz[0];
                mass[base + plane] += w * st.wz[1];
            }
        }
    }
}

/* Add the mesh field [m/s^2] (three arrays (nz, nx, ny), C order) interpolated with the
 * same cloud-in-cell kernel to every particle's acceleration. */
void rs_p3m_interpolate(struct reb_simulation* const r, const struct rs_p3m* p,
                        const double* gx, const double* gy, const double* gz){
    const size_t n = r->N - r->N_var;
    struct reb_particle* const ps = r->particles;
    const double Lx = r->root_size * (double)r->N_root_x;
    const double Ly = r->root_size * (double)r->N_root_y;
    const size_t ny = (size_t)p->ny, nxs = (size_t)p->nx;
    /* a gather per particle: the same sums, in the same order, on any number of threads */
#pragma omp parallel for schedule(static) num_threads(rs_p3m_threads(p, n))
    for (size_t k = 0; k < n; k++){
        const struct rs_cic st = rs_p3m_cic(p, &ps[k], Lx, Ly);
        double ax = 0.0, ay = 0.0, az = 0.0;
        for (int a = 0; a < 2; a++){
            for (int b = 0; b < 2; b++){
                for (int c = 0; c < 2; c++){
                    const size_t node = ((st.l0 + (size_t)c) * nxs + st.is[a]) * ny + st.js[b];
                    const double w = st.wx[a] * st.wy[b] * st.wz[c];
                    ax += w * gx[node];
                    ay += w * gy[node];
                    az += w * gz[node];
                }
            }
        }
        ps[k].ax += ax;
        ps[k].ay += ay;
        ps[k].az += az;
    }
}

/* Fine layers per r_s of the mean (k = 0) vertical field. */
#define RS_P3M_MEAN_LAYERS 16.0
/* Separation [r_s] beyond which erf(d / 2 r_s) is exactly 1 in double (erf(6) = 1). */
#define RS_P3M_MEAN_REACH 12.0

/* Add the horizontally averaged long-range vertical field [m/s^2],
 *     g_z(z) = -(2 pi G / (Lx Ly)) sum_j m_j erf((z - z_j) / (2 r_s)),
 * the k = 0 mode of the mesh, which the coarse layers would smooth (it is the largest part
 * of the vertical field): cloud-in-cell onto fine layers r_s / 16 apart, the exact erf
 * kernel between them, linear interpolation (error ~ (dz_fine / r_s)^2 / 8 of the local
 * field curvature: < 1e-3).  O(N + n_fine x 2 RS_P3M_MEAN_REACH RS_P3M_MEAN_LAYERS). */
void rs_p3m_mean_vertical(struct reb_simulation* const r, struct rs_p3m* p){
    const size_t n = r->N - r->N_var;
    struct reb_particle* const ps = r->particles;
    const double Lx = r->root_size * (double)r->N_root_x;
    const double Ly = r->root_size * (double)r->N_root_y;
    const double h = p->split / RS_P3M_MEAN_LAYERS;
    double zmin = 0.0, zmax = 0.0;
    for (size_t k = 0; k < n; k++){
        if (k == 0 || ps[k].z < zmin) zmin = ps[k].z;
        if (k == 0 || ps[k].z > zmax) zmax = ps[k].z;
    }
    const size_t nf = (size_t)((zmax - zmin) / h) + 2;
    double* mass = calloc(2 * nf + 1, sizeof(double));
    if (mass == NULL){
        p->error = 1;
        return;
    }
    double* field = mass + nf;
    double* kernel = field + nf;   /* unused slot keeps the allocation non-empty */
    (void)kernel;
    for (size_t k = 0; k < n; k++){
        const double f = (ps[k].z - zmin) / h;
        size_t l = (size_t)f;
        if (l > nf - 2) l = nf - 2;
        const double w = f - (double)l;
        mass[l] += ps[k].m * (1.0 - w);
        mass[l + 1] += ps[k].m * w;
    }
    const double c = -6.283185307179586 * r->G / (Lx * Ly);
    /* erf((a - b) h / 2 r_s) is exactly +-1 in double beyond RS_P3M_MEAN_REACH r_s / h
     * layers: those layers enter through the masses below and above the window (prefix
     * sums), so the cost is O(n_fine x window), not O(n_fine^2) (a hot ring is hundreds of
     * r_s thick) */
    const size_t reach = (size_t)ceil(RS_P3M_MEAN_REACH * RS_P3M_MEAN_LAYERS);
    double* erf_of = malloc((2 * reach + 1) * sizeof(double));
    double* below = malloc((nf + 1) * sizeof(double));
    if (erf_of == NULL || below == NULL){
        free(erf_of);
        free(below);
        free(mass);
        p->error = 1;
        return;
    }
    for (size_t d = 0; d <= 2 * reach; d++){
        erf_of[d] = erf(((double)d - (double)reach) * h / (2.0 * p->split));
    }
    below[0] = 0.0;
    for (size_t b = 0; b < nf; b++){
        below[b + 1] = below[b] + mass[b];
    }
    for (size_t a = 0; a < nf; a++){
        const size_t lo = a > reach ? a - reach : 0;
        const size_t hi = a + reach < nf - 1 ? a + reach : nf - 1;
        double g = below[lo] - (below[nf] - below[hi + 1]);   /* erf = +1 below, -1 above */
        for (size_t b = lo; b <= hi; b++){
            if (mass[b] != 0.0){
                g += mass[b] * erf_of[a + reach - b];
            }
        }
        field[a] = c * g;
    }
    free(erf_of);
    free(below);
    /* each particle's field from the layers (independent: on the threads) */
    const int team = rs_p3m_threads(p, n);
    (void)team;
#pragma omp parallel for schedule(static) num_threads(team)
    for (size_t k = 0; k < n; k++){
        const double f = (ps[k].z - zmin) / h;
        size_t l = (size_t)f;
        if (l > nf - 2) l = nf - 2;
        const double w = f - (double)l;
        ps[k].az += (1.0 - w) * field[l] + w * field[l + 1];
    }
    free(mass);
}

/* A cell list of the pair sum: the particles' wrapped positions and masses sorted by cell
 * (x-major), the first slot of each cell in start[0..cells] and each slot's particle; sc
 * and sw are each slot's height on the mesh [m] and the damping of its mesh weights
 * (rs_p3m_on_mesh), and clamped says whether any particle lies beyond the mesh.  In a
 * thick ring (nzb > 1, rs_p3m_zbins_build) each cell's slots are also indexed by height:
 * zslot lists them by (cell, height bin, slot), bin b of cell c in
 * [zstart[c nzb + b], zstart[c nzb + b + 1]), and zx, zy, zz are their positions [m] in
 * that order; bins 1 / inv_hz [m] tall from zb0 [m]. */
struct rs_p3m_list {
    size_t n;
    size_t* start;
    size_t* order;
    double *sx, *sy, *sz, *sm, *sc, *sw;
    int clamped;
    int nzb;
    size_t *zstart, *zslot;
    double *zx, *zy, *zz;
    double zb0, inv_hz;
};

/* Sources per chunk of the pair sum's two passes (rs_p3m_pairs). */
#define RS_P3M_CHUNK 128
/* Fraction of the scanned sources within r_c above which the pair sum takes two passes:
 * one scanned source in eight within r_c (a ring about as thick as r_c) gains from them,
 * one in twenty-five (a ring many r_c thick) loses (docs/performance.md, "P3M: the mesh
 * every k steps in an equilibrium, and what is left"). */
#define RS_P3M_TWO_PASS_FRACTION 0.08

/* Short-range acceleration [m/s^2] on (xi, yi, zi) from the sorted sources [b, e) of src,
 * each at (x_j + offx, y_j + offy, z_j), into acc[0..2]; acc[3] and acc[4] count the
 * sources scanned and those within r_c.  One loop that tests and skips, or (p->two_pass)
 * two passes over chunks of sources: the indices within r_c without branches, then their
 * forces in the same order.  Both give the same sums, bit for bit. */
static void rs_p3m_pairs(const struct rs_p3m* p, const struct rs_p3m_list* src, size_t b,
                         size_t e, double xi, double yi, double zi, double offx, double offy,
                         double inv_step, double* acc){
    const double rc2 = p->cutoff * p->cutoff, b2 = p->softening * p->softening;
    const double xs = xi - offx, ys = yi - offy;
    const double *sx = src->sx, *sy = src->sy, *sz = src->sz, *sm = src->sm;
    size_t hits = 0;
    if (!p->two_pass){
        for (size_t j = b; j < e; j++){
            const double dx = xs - sx[j];
            const double dy = ys - sy[j];
            const double dz = zi - sz[j];
            const double r2 = dx * dx + dy * dy + dz * dz;
            if (r2 >= rc2 || r2 == 0.0){
                continue;
            }
            hits++;
            const double s2 = r2 + b2;
            const double f = sm[j] * (1.0 / (s2 * sqrt(s2)) - rs_p3m_lookup(p, r2, inv_step));
            acc[0] -= f * dx;
            acc[1] -= f * dy;
            acc[2] -= f * dz;
        }
        acc[3] += (double)(e - b);
        acc[4] += (double)hits;
        return;
    }
    size_t near[RS_P3M_CHUNK];
    for (size_t c0 = b; c0 < e; c0 += RS_P3M_CHUNK){
        const size_t c1 = e - c0 < RS_P3M_CHUNK ? e : c0 + RS_P3M_CHUNK;
        size_t m = 0;
        for (size_t j = c0; j < c1; j++){
            const double dx = xs - sx[j];
            const double dy = ys - sy[j];
            const double dz = zi - sz[j];
            const double r2 = dx * dx + dy * dy + dz * dz;
            near[m] = j;
            m += (size_t)((r2 < rc2) & (r2 != 0.0));
        }
        for (size_t q = 0; q < m; q++){
            const size_t j = near[q];
            const double dx = xs - sx[j];
            const double dy = ys - sy[j];
            const double dz = zi - sz[j];
            const double r2 = dx * dx + dy * dy + dz * dz;
            const double s2 = r2 + b2;
            const double f = sm[j] * (1.0 / (s2 * sqrt(s2)) - rs_p3m_lookup(p, r2, inv_step));
            acc[0] -= f * dx;
            acc[1] -= f * dy;
            acc[2] -= f * dz;
        }
        hits += m;
    }
    acc[3] += (double)(e - b);
    acc[4] += (double)hits;
}

/* Words of the longest run (64 sources a word) that rs_p3m_window marks; a longer run is
 * scanned whole by rs_p3m_pairs. */
#define RS_P3M_MASK_WORDS 64

/* The forces of the sources marked in mask (bit k of word w: slot b + 64 w + k) on the
 * target at (xs, ys, zi) in the sources' frame, in slot order, as rs_p3m_pairs sums them,
 * into acc[0..2]. */
static void rs_p3m_marked(const struct rs_p3m* p, const struct rs_p3m_list* src, size_t b,
                          size_t words, const unsigned long long* mask, double xs, double ys,
                          double zi, double inv_step, double* acc){
    const double b2 = p->softening * p->softening;
    const double *sx = src->sx, *sy = src->sy, *sz = src->sz, *sm = src->sm;
    double a0 = acc[0], a1 = acc[1], a2 = acc[2];
    for (size_t w = 0; w < words; w++){
        for (unsigned long long bits = mask[w]; bits != 0; bits &= bits - 1){
            const size_t j = b + 64 * w + (size_t)__builtin_ctzll(bits);
            const double dx = xs - sx[j];
            const double dy = ys - sy[j];
            const double dz = zi - sz[j];
            const double r2 = dx * dx + dy * dy + dz * dz;
            const double s2 = r2 + b2;
            const double f = sm[j] * (1.0 / (s2 * sqrt(s2)) - rs_p3m_lookup(p, r2, inv_step));
            a0 -= f * dx;
            a1 -= f * dy;
            a2 -= f * dz;
        }
    }
    acc[0] = a0;
    acc[1] = a1;
    acc[2] = a2;
}

/* The height bin [0, nzb) of the list's index at height z [m] (clamped: the bins beyond
 * the lowest and highest source are the first and the last). */
static int rs_p3m_zbin(const struct rs_p3m_list* l, double z){
    const double f = (z - l->zb0) * l->inv_hz;
    return f < 0.0 ? 0 : (f >= (double)l->nzb ? l->nzb - 1 : (int)f);
}

/* Margin [r_c] by which the searches by position widen their bounds: a source that the
 * rounded test r^2 < r_c^2 takes always lies within them. */
#define RS_P3M_REACH_MARGIN 1e-6

/* rs_p3m_pairs over the sources of the cells c0..c1 (one run: slots start[c0] to
 * start[c1 + 1]) on the target (x, y, z), sources at (x_j + offx, y_j + offy, z_j),
 * scanning only the height bins [blo, bhi] of each cell: the sources within r_c are
 * marked in a bitmask by their slot and summed in slot order, so the sums are those of
 * rs_p3m_pairs over the whole run, bit for bit.  acc as rs_p3m_pairs' (acc[3] and acc[4]
 * count only the scans of rs_p3m_pairs, for its choice of passes). */
static __attribute__((noinline)) void rs_p3m_window(
        const struct rs_p3m* p, const struct rs_p3m_list* src, size_t c0, size_t c1, int blo,
        int bhi, const double* target, double offx, double offy, double inv_step,
        double* acc){
    const size_t b = src->start[c0], e = src->start[c1 + 1];
    const double xs = target[0] - offx, ys = target[1] - offy, zi = target[2];
    if (e - b > 64 * RS_P3M_MASK_WORDS){
        rs_p3m_pairs(p, src, b, e, target[0], target[1], zi, offx, offy, inv_step, acc);
        return;
    }
    const double rc2 = p->cutoff * p->cutoff;
    const double *zx = src->zx, *zy = src->zy, *zz = src->zz;
    const size_t words = (e - b + 63) / 64, nzb = (size_t)src->nzb;
    unsigned long long mask[RS_P3M_MASK_WORDS];
    for (size_t w = 0; w < words; w++){
        mask[w] = 0;
    }
    for (size_t c = c0; c <= c1; c++){
        const size_t t0 = src->zstart[c * nzb + (size_t)blo];
        const size_t t1 = src->zstart[c * nzb + (size_t)bhi + 1];
        for (size_t t = t0; t < t1; t++){
            const double dx = xs - zx[t];
            const double dy = ys - zy[t];
            const double dz = zi - zz[t];
            const double r2 = dx * dx + dy * dy + dz * dz;
            const size_t k = src->zslot[t] - b;
            mask[k >> 6] |= (unsigned long long)((r2 < rc2) & (r2 != 0.0)) << (k & 63);
        }
    }
    rs_p3m_marked(p, src, b, words, mask, xs, ys, zi, inv_step, acc);
}

/* rs_p3m_cells' pair sum (no fixes) through the list's height index (src->nzb > 1): the
 * columns within r_c of the target, in each only the cells within r_c horizontally, each
 * scanned by rs_p3m_window; the same runs in the same order, so the same sums, bit for
 * bit. */
static void rs_p3m_cells_window(const struct rs_p3m* p, const struct rs_p3m_list* src,
                                int ncx, int ncy, double Lx, double Ly, double s,
                                const double* target, double inv_step, double* acc){
    const double rc = p->cutoff, hx = Lx / ncx, hy = Ly / ncy;
    const double tol = RS_P3M_REACH_MARGIN * rc;
    const double xi = target[0], yi = target[1];
    const int xlo = (int)floor((xi - rc + 0.5 * Lx) / hx);
    const int xhi = (int)floor((xi + rc + 0.5 * Lx) / hx);
    for (int qx = xlo; qx <= xhi; qx++){
        const int nimg = (int)floor((double)qx / (double)ncx);
        const size_t col = (size_t)(qx - nimg * ncx) * (size_t)ncy;
        const double xl = -0.5 * Lx + (double)(qx - nimg * ncx) * hx, xs = xi - nimg * Lx;
        const double dx = fmax(fmax(xl - xs, xs - xl - hx) - tol, 0.0);
        if (dx >= rc){
            continue;
        }
        const double reach = sqrt(rc * rc - dx * dx) + tol;
        const int blo = rs_p3m_zbin(src, target[2] - reach);
        const int bhi = rs_p3m_zbin(src, target[2] + reach);
        const double yc = yi + nimg * s + 0.5 * Ly;
        const int ylo = (int)floor((yc - reach) / hy), yhi = (int)floor((yc + reach) / hy);
        for (int q0 = ylo; q0 <= yhi;){
            const int wy = (int)floor((double)q0 / (double)ncy);
            const int q1 = yhi < (wy + 1) * ncy - 1 ? yhi : (wy + 1) * ncy - 1;
            const size_t c0 = col + (size_t)(q0 - wy * ncy), c1 = col + (size_t)(q1 - wy * ncy);
            rs_p3m_window(p, src, c0, c1, blo, bhi, target, nimg * Lx, -nimg * s + wy * Ly,
                          inv_step, acc);
            q0 = q1 + 1;
        }
    }
}

/* The correction [m/s^2] to rs_p3m_pairs of the pairs with a particle beyond the mesh:
 * the target (xi, yi, zi) is on the mesh at zci with weight wi, source j at sc[j] with
 * sw[j] (rs_p3m_on_mesh).  Such a pair got from the mesh the long-range force of its
 * positions on the mesh times wi sw[j]; where those lie within r_c its force here becomes
 * the Plummer force of the true positions minus exactly that, so that mesh and pair sum
 * give the Plummer force; rs_p3m_pairs' term of the pair is taken back.  Antisymmetric in
 * the pair: momentum is conserved. */
static void rs_p3m_fixes(const struct rs_p3m* p, const struct rs_p3m_list* src, size_t b,
                         size_t e, double xi, double yi, double zi, double zci, double wi,
                         double offx, double offy, double inv_step, double* acc){
    const double rc2 = p->cutoff * p->cutoff, b2 = p->softening * p->softening;
    const double xs = xi - offx, ys = yi - offy;
    const int target_beyond = zci != zi;
    for (size_t j = b; j < e; j++){
        if (!target_beyond && src->sc[j] == src->sz[j]){
            continue;
        }
        const double dx = xs - src->sx[j];
        const double dy = ys - src->sy[j];
        const double dz = zi - src->sz[j];
        const double dzc = zci - src->sc[j];
        const double r2 = dx * dx + dy * dy + dz * dz;
        const double r2c = dx * dx + dy * dy + dzc * dzc;
        if (r2 == 0.0 || (r2c >= rc2 && r2 >= rc2)){
            continue;
        }
        const double s2 = r2 + b2;
        const double plummer = 1.0 / (s2 * sqrt(s2));
        double fn = 0.0, fl = 0.0, fo = 0.0;       /* new Plummer, new mesh part, old */
        if (r2c < rc2){
            fn = plummer;
            fl = wi * src->sw[j] * rs_p3m_lookup(p, r2c, inv_step);
        }
        if (r2 < rc2){
            fo = plummer - rs_p3m_lookup(p, r2, inv_step);
        }
        const double f = src->sm[j] * (fn - fo);
        const double g = src->sm[j] * fl;
        acc[0] -= (f - g) * dx;
        acc[1] -= (f - g) * dy;
        acc[2] -= f * dz - g * dzc;
    }
}

/* One run of sources [b, e) at the offsets: rs_p3m_pairs, or with fixes rs_p3m_fixes. */
static void rs_p3m_run(const struct rs_p3m* p, const struct rs_p3m_list* src, size_t b,
                       size_t e, const double* target, int fixes, double offx, double offy,
                       double inv_step, double* acc){
    if (fixes){
        rs_p3m_fixes(p, src, b, e, target[0], target[1], target[2], target[3], target[4],
                     offx, offy, inv_step, acc);
    }else{
        rs_p3m_pairs(p, src, b, e, target[0], target[1], target[2], offx, offy, inv_step,
                     acc);
    }
}

/* Short-range acceleration [m/s^2] (or with fixes its correction) on the target (x, y, z,
 * height on the mesh, mesh weight) from all sources of src, each at every image within r_c
 * (boxes too small for the cell list; r_c < min(Lx, Ly): 3 x 3 images suffice). */
static void rs_p3m_all_images(const struct rs_p3m* p, const struct rs_p3m_list* src,
                              const double* target, int fixes, double Lx, double Ly,
                              double s, double inv_step, double* acc){
    for (size_t j = 0; j < src->n; j++){
        const double n0 = round((target[0] - src->sx[j]) / Lx);
        for (double nimg = n0 - 1.0; nimg <= n0 + 1.0; nimg += 1.0){
            const double m0 = round((target[1] - src->sy[j] + nimg * s) / Ly);
            for (double m = m0 - 1.0; m <= m0 + 1.0; m += 1.0){
                rs_p3m_run(p, src, j, j + 1, target, fixes, nimg * Lx, -nimg * s + m * Ly,
                           inv_step, acc);
            }
        }
    }
}

/* Cells per cutoff of the pair sum's cell list (cells of at least r_c / 2). */
#define RS_P3M_CELLS_PER_CUTOFF 2

/* Short-range acceleration [m/s^2] (or with fixes its correction) on the target (x, y, z,
 * height on the mesh, mesh weight; wrapped into the box) from the cell list: cells
 * [x-range] x [y-range] within r_c, each with its image offsets; the cells of one column
 * and one y image are contiguous in the sorted arrays (one run each). */
static void rs_p3m_cells(const struct rs_p3m* p, const struct rs_p3m_list* src, int ncx,
                         int ncy, double Lx, double Ly, double s, const double* target,
                         int fixes, double inv_step, double* acc){
    const double rc = p->cutoff, hx = Lx / ncx, hy = Ly / ncy;
    const double xi = target[0], yi = target[1];
    const int xlo = (int)floor((xi - rc + 0.5 * Lx) / hx);
    const int xhi = (int)floor((xi + rc + 0.5 * Lx) / hx);
    for (int qx = xlo; qx <= xhi; qx++){
        /* a column outside [0, ncx) is the image n boxes out: sources at (x + n Lx, y - n s) */
        const int nimg = (int)floor((double)qx / (double)ncx);
        const size_t col = (size_t)(qx - nimg * ncx) * (size_t)ncy;
        const double yc = yi + nimg * s + 0.5 * Ly;
        const int ylo = (int)floor((yc - rc) / hy), yhi = (int)floor((yc + rc) / hy);
        for (int q0 = ylo; q0 <= yhi;){
            const int wy = (int)floor((double)q0 / (double)ncy);   /* y image of this run */
            const int q1 = yhi < (wy + 1) * ncy - 1 ? yhi : (wy + 1) * ncy - 1;
            const size_t c0 = col + (size_t)(q0 - wy * ncy), c1 = col + (size_t)(q1 - wy * ncy);
            rs_p3m_run(p, src, src->start[c0], src->start[c1 + 1], target, fixes, nimg * Lx,
                       -nimg * s + wy * Ly, inv_step, acc);
            q0 = q1 + 1;
        }
    }
}

static void rs_p3m_list_free(struct rs_p3m_list* l){
    free(l->start);
    free(l->order);
    free(l->sx);
    free(l->zstart);
    free(l->zslot);
    free(l->zx);
}

/* Sort the particles of radius >= r_min (all for r_min = 0) into a cell list of ncx x ncy
 * cells, positions wrapped into the box with the shear offset s.  Returns 0 if memory ran
 * out. */
static int rs_p3m_list_build(struct rs_p3m_list* l, const struct rs_p3m* p,
                             const struct reb_particle* ps, size_t n, double r_min, int ncx,
                             int ncy, double Lx, double Ly, double s){
    const size_t cells = (size_t)ncx * (size_t)ncy;
    size_t m = 0;
    for (size_t k = 0; k < n; k++){
        m += ps[k].r >= r_min;
    }
    l->n = m;
    l->start = calloc(cells + 1, sizeof(size_t));
    l->order = malloc((m + 1) * sizeof(size_t));
    l->sx = malloc((6 * m + 1) * sizeof(double));
    size_t* cell_of = malloc((n + 1) * sizeof(size_t));
    double* wrapped = malloc((2 * n + 1) * sizeof(double));
    if (l->start == NULL || l->order == NULL || l->sx == NULL || cell_of == NULL
        || wrapped == NULL){
        free(cell_of);
        free(wrapped);
        return 0;
    }
    l->sy = l->sx + m;
    l->sz = l->sx + 2 * m;
    l->sm = l->sx + 3 * m;
    l->sc = l->sx + 4 * m;
    l->sw = l->sx + 5 * m;
    l->nzb = 1;
    const double hx = Lx / ncx, hy = Ly / ncy;
    const int team = rs_p3m_threads(p, n);
    (void)team;
    /* each particle's wrapped position and cell (independent: on the threads) */
#pragma omp parallel for schedule(static) num_threads(team)
    for (size_t k = 0; k < n; k++){
        if (ps[k].r < r_min){
            cell_of[k] = cells;        /* not in this list */
            continue;
        }
        const double nx_img = floor((ps[k].x + 0.5 * Lx) / Lx);
        const double x = ps[k].x - nx_img * Lx;
        double y = ps[k].y + nx_img * s;
        y -= Ly * floor((y + 0.5 * Ly) / Ly);
        wrapped[2 * k] = x;
        wrapped[2 * k + 1] = y;
        int cx = (int)floor((x + 0.5 * Lx) / hx), cy = (int)floor((y + 0.5 * Ly) / hy);
        cx = cx < 0 ? 0 : (cx >= ncx ? ncx - 1 : cx);
        cy = cy < 0 ? 0 : (cy >= ncy ? ncy - 1 : cy);
        cell_of[k] = (size_t)cx * (size_t)ncy + (size_t)cy;
    }
    /* counting sort into cells (x-major), by index within a cell */
    for (size_t k = 0; k < n; k++){
        if (cell_of[k] != cells){
            l->start[cell_of[k] + 1]++;
        }
    }
    for (size_t c = 0; c < cells; c++){
        l->start[c + 1] += l->start[c];
    }
    for (size_t k = 0; k < n; k++){
        if (cell_of[k] != cells){
            l->order[l->start[cell_of[k]]++] = k;
        }
    }
    for (size_t c = cells; c > 0; c--){   /* restore the starts */
        l->start[c] = l->start[c - 1];
    }
    l->start[0] = 0;
    /* each slot's copies, height on the mesh and damping (independent: on the threads) */
    int clamped = 0;
#pragma omp parallel for schedule(static) num_threads(team) reduction(|:clamped)
    for (size_t slot = 0; slot < m; slot++){
        const size_t k = l->order[slot];
        l->sx[slot] = wrapped[2 * k];
        l->sy[slot] = wrapped[2 * k + 1];
        l->sz[slot] = ps[k].z;
        l->sm[slot] = ps[k].m;
        l->sc[slot] = rs_p3m_on_mesh(p, ps[k].z, Lx, Ly, &l->sw[slot]);
        clamped |= l->sc[slot] != ps[k].z;
    }
    l->clamped = clamped;
    free(cell_of);
    free(wrapped);
    return 1;
}

/* Height bins per cutoff of the index by height (bins of at least r_c / 4). */
#define RS_P3M_ZBINS_PER_CUTOFF 4
/* The height index is built where the sources span more than this many cutoffs (a target
 * then scans at most about 2.25 r_c of the ring's height) ... */
#define RS_P3M_ZWINDOW_MIN_SPAN 4.0
/* ... and a cell holds at least this many sources on average (with fewer, the index's cost
 * per cell exceeds the sources it spares) ... */
#define RS_P3M_ZWINDOW_MIN_PER_CELL 8
/* ... with at most this many bins per source on average (its memory and set-up are O(N)). */
#define RS_P3M_ZBINS_PER_SOURCE 4

/* Index the list's slots by height within each of its cells (struct rs_p3m_list) where
 * the sources span more than RS_P3M_ZWINDOW_MIN_SPAN cutoffs and the cells hold at least
 * RS_P3M_ZWINDOW_MIN_PER_CELL on average; else nzb stays 1 (no index).
 * Returns 0 if memory ran out. */
static int rs_p3m_zbins_build(struct rs_p3m_list* l, const struct rs_p3m* p, size_t cells){
    const double rc = p->cutoff;
    double zmin = 0.0, zmax = 0.0;
    for (size_t j = 0; j < l->n; j++){
        if (j == 0 || l->sz[j] < zmin) zmin = l->sz[j];
        if (j == 0 || l->sz[j] > zmax) zmax = l->sz[j];
    }
    const double span = zmax - zmin;
    const double most = (double)(RS_P3M_ZBINS_PER_SOURCE * l->n / cells);
    const double bins = fmin(floor(span * RS_P3M_ZBINS_PER_CUTOFF / rc) + 1.0, most);
    if (span <= RS_P3M_ZWINDOW_MIN_SPAN * rc || l->n < RS_P3M_ZWINDOW_MIN_PER_CELL * cells
        || bins < 2.0){
        return 1;
    }
    const size_t nzb = (size_t)bins, keys = cells * nzb;
    l->zstart = calloc(keys + 1, sizeof(size_t));
    l->zslot = malloc((l->n + 1) * sizeof(size_t));
    l->zx = malloc((3 * l->n + 1) * sizeof(double));
    if (l->zstart == NULL || l->zslot == NULL || l->zx == NULL){
        return 0;
    }
    l->zy = l->zx + l->n;
    l->zz = l->zx + 2 * l->n;
    l->nzb = (int)nzb;
    l->zb0 = zmin;
    l->inv_hz = bins / span;
    for (size_t c = 0; c < cells; c++){   /* counting sort by (cell, bin), stable in slot */
        for (size_t j = l->start[c]; j < l->start[c + 1]; j++){
            l->zstart[c * nzb + (size_t)rs_p3m_zbin(l, l->sz[j]) + 1]++;
        }
    }
    for (size_t k = 0; k < keys; k++){
        l->zstart[k + 1] += l->zstart[k];
    }
    for (size_t c = 0; c < cells; c++){
        for (size_t j = l->start[c]; j < l->start[c + 1]; j++){
            l->zslot[l->zstart[c * nzb + (size_t)rs_p3m_zbin(l, l->sz[j])]++] = j;
        }
    }
    for (size_t k = keys; k > 0; k--){    /* restore the starts */
        l->zstart[k] = l->zstart[k - 1];
    }
    l->zstart[0] = 0;
    for (size_t t = 0; t < l->n; t++){
        l->zx[t] = l->sx[l->zslot[t]];
        l->zy[t] = l->sy[l->zslot[t]];
        l->zz[t] = l->sz[l->zslot[t]];
    }
    return 1;
}

/* Add the short-range pair forces (see the file header) to every particle.  Positions are
 * first wrapped into the box with the shear (REBOUND evaluates forces at mid-step, before
 * its boundary check), so that every pair is found from both sides with the same image.
 * With field-only particles (pair_min_radius > 0) a second list holds the others: a
 * field-only target sums over it, every other target over all particles, so that each
 * pair but those of two field-only particles is summed from both sides. */
void rs_p3m_short(struct reb_simulation* const r, struct rs_p3m* p){
    const size_t n = r->N - r->N_var;
    struct reb_particle* const ps = r->particles;
    const double Lx = r->root_size * (double)r->N_root_x;
    const double Ly = r->root_size * (double)r->N_root_y;
    const double rc = p->cutoff, s = p->shift, G = r->G;
    const double inv_step = (double)RS_P3M_TABLE / (rc * rc);
    const double r_pair = p->pair_min_radius;
    int ncx = (int)(RS_P3M_CELLS_PER_CUTOFF * Lx / rc);
    int ncy = (int)(RS_P3M_CELLS_PER_CUTOFF * Ly / rc);
    const int all_pairs = ncx < 2 * RS_P3M_CELLS_PER_CUTOFF + 1
                          || ncy < 2 * RS_P3M_CELLS_PER_CUTOFF + 1;
    if (all_pairs){
        ncx = 1;       /* one cell: every pair, at each image within r_c */
        ncy = 1;
    }
    struct rs_p3m_list all = {0}, large = {0};
    int ok = rs_p3m_list_build(&all, p, ps, n, 0.0, ncx, ncy, Lx, Ly, s);
    if (ok && r_pair > 0.0){
        ok = rs_p3m_list_build(&large, p, ps, n, r_pair, ncx, ncy, Lx, Ly, s);
    }
    if (ok && p->zwindow && !all_pairs){
        const size_t cells = (size_t)ncx * (size_t)ncy;
        ok = rs_p3m_zbins_build(&all, p, cells)
             && (r_pair <= 0.0 || rs_p3m_zbins_build(&large, p, cells));
    }
    if (!ok){
        rs_p3m_list_free(&all);
        rs_p3m_list_free(&large);
        p->error = 1;
        return;
    }
    /* targets in cell order (sources cached); each target's sum is its own, in a fixed
     * order: the same bits on any number of threads (and either way of rs_p3m_pairs) */
    double scanned = 0.0, within = 0.0;
    /* the list of all particles leaves out only negative or NaN radii */
    const size_t targets = all.n;
#pragma omp parallel for schedule(dynamic, 256) num_threads(rs_p3m_threads(p, n)) \
    reduction(+:scanned, within)
    for (size_t slot = 0; slot < targets; slot++){
        struct reb_particle* const q = &ps[all.order[slot]];
        if (slot + 1 < targets){
            /* the next target's particle, read and written at the ends of a long pair sum
             * and far from this one in REBOUND's array: asked for now, not waited for */
            const struct reb_particle* const next = &ps[all.order[slot + 1]];
            __builtin_prefetch(&next->r, 0);
            __builtin_prefetch(&next->ax, 1);
        }
        const struct rs_p3m_list* src = q->r < r_pair ? &large : &all;
        double acc[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
        const double target[5] = {all.sx[slot], all.sy[slot], all.sz[slot], all.sc[slot],
                                   all.sw[slot]};
        /* a pair with a particle beyond the mesh has its target beyond the mesh or within
         * r_c of its limits: only those targets take the correction */
        const int fixes = all.clamped && (target[2] > p->zhi - rc || target[2] < p->zlo + rc);
        for (int pass = 0; pass <= fixes; pass++){
            if (all_pairs){
                rs_p3m_all_images(p, src, target, pass, Lx, Ly, s, inv_step, acc);
            }else if (pass == 0 && src->nzb > 1){
                rs_p3m_cells_window(p, src, ncx, ncy, Lx, Ly, s, target, inv_step, acc);
            }else{
                rs_p3m_cells(p, src, ncx, ncy, Lx, Ly, s, target, pass, inv_step, acc);
            }
        }
        q->ax += G * acc[0];
        q->ay += G * acc[1];
        q->az += G * acc[2];
        scanned += acc[3];
        within += acc[4];
    }
    /* the next call's way of summing by columns, from the column scans alone (a cost, not
     * a result: the bits are the same) */
    p->two_pass = within > RS_P3M_TWO_PASS_FRACTION * scanned;
    p->zbins = all.nzb;
    rs_p3m_list_free(&all);
    rs_p3m_list_free(&large);
}
