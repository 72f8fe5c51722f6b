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

// How the current call's iteration runs: accelerated or plain pairs, and the tolerance its error estimate is
// held to (0: a fixed count: no tolerance, or a static solve). The auto accelerator's step probes with two
// plain pairs, then goes on plain or turns Chebyshev on (tolerance.c).
od_StepPlan od_Tolerance_Plan(const od_Sim* sim);
// Plain pairs for the rest of the step, estimated as auto's plain pairs under a tolerance (a contact group's
// forces change between pairs, and an accelerator's extrapolation feeds their changes back: body_contact.c).
void od_Tolerance_PlainPlan(od_StepPlan* plan);
// After a pair under a tolerance: the step's error estimate, to compare with plan->tolerance, and the plan's
// next pair. The estimate is the residual of the current iterate against the one remembered, which it then
// replaces; auto's plain pairs double it; auto's first pair gives INFINITY (no contraction measured yet: a
// step capped there reports an infinite error).
double od_Tolerance_Check(od_Sim* sim, od_StepPlan* plan);
