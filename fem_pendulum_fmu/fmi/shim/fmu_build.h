/* What the build tells the binary about its FMU (fem_pendulum_fmu/fmi/binary_config.py, as -D flags):
 * the modelDescription's GUID, its FMU state capability flags, the highest input derivative order it
 * takes (0: canInterpolateInputs is false) and its maxOutputDerivativeOrder. */
#ifndef FEM_PENDULUM_FMU_BUILD_H
#define FEM_PENDULUM_FMU_BUILD_H

#ifndef FMU_GUID
#error "FMU_GUID must be defined (fem_pendulum_fmu/fmi/binary_config.py)"
#endif
#ifndef FMU_CAN_GET_SET_STATE
#define FMU_CAN_GET_SET_STATE 0
#endif
#ifndef FMU_CAN_SERIALIZE_STATE
#define FMU_CAN_SERIALIZE_STATE 0
#endif
#ifndef FMU_INPUT_DERIVATIVE_ORDER
#define FMU_INPUT_DERIVATIVE_ORDER 0
#endif
#ifndef FMU_MAX_OUTPUT_DERIVATIVE_ORDER
#define FMU_MAX_OUTPUT_DERIVATIVE_ORDER 0
#endif

#endif
