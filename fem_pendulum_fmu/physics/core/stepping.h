/* What the core's C files share beyond femp_core.h. */
#ifndef FEMP_STEPPING_H
#define FEMP_STEPPING_H

#include "femp_core.h"

#define FEMP_PI 3.14159265358979323846 /* Python's math.pi, which the C99 library need not name */

/* a contact's hold after dt out of contact: shrunk by the rules' decay, never below 0 */
double femp_decayed_hold(const struct femp_step_control *c, double hold, double dt);

#endif
