/*
 * controller_path.h - the path-following controller FMU's own part (controller_path.c).
 */
#ifndef CONTROLLER_PATH_H
#define CONTROLLER_PATH_H

#include <stddef.h>

#include "ballbot_controller_cg.h"
#include "fmu_casadi.h"

/* Check the path table, its obstacles and path_s0 in the Real values r; 1 (message in
 * msg) if one is bad. */
int ctrl_path_check(const double *r, char *msg, size_t len);
/* Write the state at power-on into r: CTRL_INITIAL's (computed into the scratch c0 of
 * CTRL_C_N entries) around the guidance state started by CTRL_GUIDE_INITIAL; nonzero if
 * a call fails. */
int ctrl_path_start(fmu_casadi_work *cg, double *r, double *c0);
/* Set the embedded software's guidance argument k_guid and result v_ref_used. */
void ctrl_path_args(const double **arg, double **res, double *r);

#endif
