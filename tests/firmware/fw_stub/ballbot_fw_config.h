/* ballbot_fw_config.h - a hand-written stand-in for the generated config (tests only).
 * State c (8): c[0] the period count, c[1] the guidance counter (BALLBOT_FW_GUIDE_OFFSET),
 * c[2..3] the sample state (first, x), c[4] due, c[5..6] snap, c[7] a constant of the loop. */
#ifndef BALLBOT_FW_CONFIG_H
#define BALLBOT_FW_CONFIG_H

#include "ballbot_fw_cg.h"

#ifndef STUB_GUIDANCE
#define STUB_GUIDANCE 0
#endif
#ifndef STUB_SPLIT
#define STUB_SPLIT 0
#endif

typedef double ballbot_fw_real;
#define BALLBOT_FW_PRECISION_DOUBLE 1
#define BALLBOT_FW_EMBEDDED stub_period
#define BALLBOT_FW_NC 8
#define BALLBOT_FW_N_READINGS 5
#define BALLBOT_FW_READING_GYRO 0
#define BALLBOT_FW_READING_ENC 2
#define BALLBOT_FW_N_ENC 3
#define BALLBOT_FW_SZ_ARG 11
#define BALLBOT_FW_SZ_RES 4
#define BALLBOT_FW_SZ_IW 1
#define BALLBOT_FW_SZ_W 1
#define BALLBOT_FW_ARG_c 0
#define BALLBOT_FW_ARG_meas 1
#define BALLBOT_FW_ARG_q_ref 2
#define BALLBOT_FW_ARG_dq_ref 3
#define BALLBOT_FW_ARG_ddq_ref 4
#define BALLBOT_FW_ARG_v_ref 5
#define BALLBOT_FW_ARG_cascade 6
#define BALLBOT_FW_ARG_Ts 7
#define BALLBOT_FW_ARG_Qa 8
#define BALLBOT_FW_ARG_k 9
#define BALLBOT_FW_ARG_k_guid 10
#define BALLBOT_FW_GUIDANCE STUB_GUIDANCE
#define BALLBOT_FW_N_GUIDANCE (STUB_GUIDANCE ? 3 : 0)
#define BALLBOT_FW_GUIDANCE_EVERY (STUB_GUIDANCE ? 4 : 0)
#define BALLBOT_FW_GUIDANCE_SPLIT STUB_SPLIT
#define BALLBOT_FW_GUIDANCE_SAMPLE_NEXT stub_sample_next
#define BALLBOT_FW_GUIDANCE_SAMPLE_FIRST stub_sample_first
#define BALLBOT_FW_GUIDE_FIRST 0
#define BALLBOT_FW_GUIDANCE_LATENCY 2
#define BALLBOT_FW_GUIDANCE_FIRST_LATENCY 3
#define BALLBOT_FW_GUIDE_OFFSET 1
#define BALLBOT_FW_GUIDE_NS 2
#define BALLBOT_FW_GUIDE_NV 2
#define BALLBOT_FW_GUIDE_DUE 3
#define BALLBOT_FW_GUIDE_SNAP 4
#define BALLBOT_FW_GUIDE_NSNAP 2
#define BALLBOT_FW_BG_SZ_ARG 3
#define BALLBOT_FW_BG_SZ_RES 2
#define BALLBOT_FW_BG_SZ_IW 1
#define BALLBOT_FW_BG_SZ_W 1
#define BALLBOT_FW_PARAM_FIELDS(X) X(Ts, 1) X(Qa, 4) X(k, 2)
#define BALLBOT_FW_REFERENCE_FIELDS(X) X(q_ref, 4) X(dq_ref, 4) X(ddq_ref, 4) X(v_ref, 3)
#define BALLBOT_FW_COV_FIELDS(X) X(Qa, 2)
#if STUB_GUIDANCE
#define BALLBOT_FW_RES_tau_lim 0
#define BALLBOT_FW_RES_v_ref_used 1
#define BALLBOT_FW_RES_echo 2
#define BALLBOT_FW_RES_c_next 3
#define BALLBOT_FW_OUTPUT_FIELDS(X) X(tau_lim, 3) X(v_ref_used, 3) X(echo, 16)
#else
#define BALLBOT_FW_RES_tau_lim 0
#define BALLBOT_FW_RES_echo 1
#define BALLBOT_FW_RES_c_next 2
#define BALLBOT_FW_OUTPUT_FIELDS(X) X(tau_lim, 3) X(echo, 16)
#endif

typedef struct ballbot_fw_params {
    ballbot_fw_real Ts[1];
    ballbot_fw_real Qa[4];
    ballbot_fw_real k[2];
} ballbot_fw_params;

typedef struct ballbot_fw_outputs {
    ballbot_fw_real tau_lim[3];
#if STUB_GUIDANCE
    ballbot_fw_real v_ref_used[3];
#endif
    ballbot_fw_real echo[16];
} ballbot_fw_outputs;

extern const ballbot_fw_params ballbot_fw_default_params_data;
extern const ballbot_fw_real ballbot_fw_default_c0[8];
#if STUB_GUIDANCE
extern const ballbot_fw_real ballbot_fw_default_guidance_data[3];
#endif

#endif
