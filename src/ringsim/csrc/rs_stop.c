/**
 * @file    rs_stop.c
 * @brief   A clean stop on SIGINT and SIGTERM while REBOUND integrates: a flag set by a
 *          signal handler, read by REBOUND's heartbeat after every step.
 *
 * | effect     | the integration ends after the step in progress when SIGINT or SIGTERM  |
 * |            | arrives; the state is that of a complete step                           |
 * | called by  | ringsim.engine.stop.StopRequest.integrate (ctypes), around each          |
 * |            | sim.integrate of the run loop                                            |
 * | REBOUND    | installs its own SIGINT handler at the start of every integrate and     |
 * |            | leaves it in place; a second SIGINT inside a step makes its collision   |
 * |            | and gravity loops return early (a half step).  The heartbeat replaces   |
 * |            | that handler by this one before the first step, so REBOUND never sees   |
 * |            | a signal once it steps                                                  |
 * | parameters | the simulation; the address of REBOUND's own counter `reb_sigint`       |
 *
 * `rs_stop_arm` installs the handler for both signals and the heartbeat; the caller puts
 * Python's handlers back after integrate returns and then reads the flag with
 * `rs_stop_take`, so a signal that arrives at any moment sets either this flag or
 * Python's: none is lost.
 */
#define _POSIX_C_SOURCE 200809L
#define _DARWIN_C_SOURCE   /* macOS: keep the BSD names its system headers use */

#include <signal.h>
#include <stddef.h>
#include <string.h>

#include "rebound.h"

/** Set by the handler: a stop is requested. */
static volatile sig_atomic_t rs_stop_flag = 0;
/** The heartbeat installs the handler once per integrate, over REBOUND's. */
static volatile sig_atomic_t rs_stop_reinstall = 0;
/** REBOUND's SIGINT counter (a SIGINT between its signal() and the first heartbeat). */
static volatile sig_atomic_t* rs_stop_rebound_sigint = NULL;

static void rs_stop_handler(int signum) {
    (void)signum;
    rs_stop_flag = 1;
}

/** Install rs_stop_handler for SIGINT and SIGTERM; 0 on success, -1 otherwise. */
static int rs_stop_install(void) {
    struct sigaction action;
    memset(&action, 0, sizeof(action));
    action.sa_handler = rs_stop_handler;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;
    if (sigaction(SIGINT, &action, NULL) != 0) return -1;
    if (sigaction(SIGTERM, &action, NULL) != 0) return -1;
    return 0;
}

/** REBOUND's heartbeat: runs before the first step and after every step. */
void rs_stop_heartbeat(struct reb_simulation* r) {
    if (rs_stop_reinstall) {
        rs_stop_install();
        rs_stop_reinstall = 0;
    }
    if (rs_stop_flag || (rs_stop_rebound_sigint != NULL && *rs_stop_rebound_sigint)) {
        r->status = REB_STATUS_USER;   /* what reb_simulation_stop does */
    }
}

/** Before an integrate: the handler for both signals and the heartbeat of r; 0 on
 *  success. */
int rs_stop_arm(struct reb_simulation* r, volatile sig_atomic_t* rebound_sigint) {
    rs_stop_rebound_sigint = rebound_sigint;
    rs_stop_reinstall = 1;
    r->heartbeat = rs_stop_heartbeat;
    return rs_stop_install();
}

/** After an integrate (Python's handlers back in place): the heartbeat removed; returns
 *  1 if a stop was requested since the last call (by either handler), and clears the
 *  flag (REBOUND clears its own at the start of every integrate). */
int rs_stop_take(struct reb_simulation* r) {
    int requested = rs_stop_flag
        || (rs_stop_rebound_sigint != NULL && *rs_stop_rebound_sigint);
    r->heartbeat = NULL;
    rs_stop_flag = 0;
    return requested;
}
