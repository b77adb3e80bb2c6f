/* lamech's integer codes: lamech/numeric/_kernels/codes.py is the one definition;
 * tests/test_cengine.py checks that every value here is the same as there. */
#ifndef LAMECH_CODES_H
#define LAMECH_CODES_H

#define LM_EV_LIFT_OFF 0
#define LM_EV_CONTACT 1
#define LM_EV_SLIP 2
#define LM_EV_STICK 3
#define LM_EV_IMPACT 4
#define LM_EV_SWITCH 5
#define LM_FR_NONE 0
#define LM_FR_STICK 1
#define LM_FR_SLIP 2
#define LM_FR_OFF 3
#define LM_ST_END 0
#define LM_ST_FOUND 1
#define LM_ST_CONTACT 2
#define LM_ST_STICK 3
#define LM_ST_EVENTS 4
#define LM_ST_STEP 5
#define LM_ST_GROWTH 6
#define LM_ST_PENETRATION 7
#define LM_ST_GRAZE 8
#define LM_ST_SETTLE 9
#define LM_ST_START 10
#define LM_ST_SINGULAR 11
#define LM_ST_BUDGET 12
#define LM_ST_MEMORY 13
#define LM_DT_NONE 0
#define LM_DT_MULTIPLIER 1
#define LM_DT_RATIO 2
#define LM_DT_REVERSAL 3
#define LM_DT_INITIAL 4
#define LM_DT_IMPACT 5
#define LM_DT_ACCUMULATION 6
#define LM_DT_IMPULSE 7
#define LM_TL_RTOL 0
#define LM_TL_ATOL 1
#define LM_TL_MAX_STEP 2
#define LM_TL_ARM_POS 3
#define LM_TL_ARM_VEL 4
#define LM_TL_BLOW_UP 5
#define LM_TL_PEN 6
#define LM_TL_TOL 7
#define LM_TL_T_END 8
#define LM_TL_SIZE 9
#define LM_LM_MAX_STEPS 0
#define LM_LM_TO_END 1
#define LM_LM_IMPACTS 2
#define LM_LM_DIPS 3
#define LM_LM_STARTS 4
#define LM_LM_SIZE 5
#define LM_IO_NEXT 0
#define LM_IO_CONTACT 1
#define LM_IO_EVALUATIONS 2
#define LM_IO_SIZE 3
#define LM_FO_T 0
#define LM_FO_H 1
#define LM_FO_MOVED 2
#define LM_FO_SIZE 3

#endif
