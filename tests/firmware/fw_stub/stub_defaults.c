/* stub_defaults.c - the stand-in's default parameters, power-on state, guidance data. */
#include "ballbot_fw_config.h"

const ballbot_fw_params ballbot_fw_default_params_data = {{0.005}, {1, 0, 0, 2}, {3, 4}};
const ballbot_fw_real ballbot_fw_default_c0[8] = {0, 0, 1, 0, 0, 0, 0, 7};
#if STUB_GUIDANCE
const ballbot_fw_real ballbot_fw_default_guidance_data[3] = {5, 6, 7};
#endif
