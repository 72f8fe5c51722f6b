// The error estimate of a step's iteration under a tolerance (tolerance.c).
#pragma once

#include "sim.h"

// Allocates the iterate copies (once, when a tolerance is first set) and measures the body's size.
od_Status od_Tolerance_Prepare(od_Sim* sim);
void od_Tolerance_Destroy(od_Tolerance* tol);
// Remembers the current iterate (after a step's first global solve).
void od_Tolerance_Start(od_Sim* sim);
// A step's first rotations (after od_Predict, before the iteration): the previous ones or the predicted ones,
// whichever gives the lower objective after a global solve (tolerance.c).
void od_Tolerance_ChooseStart(od_Sim* sim);
// The residual of the current iterate against the one remembered, which it then replaces (tolerance.c).
double od_Tolerance_Estimate(od_Sim* sim);
