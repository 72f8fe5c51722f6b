// The constraint set: adding, moving, reweighting and removing constraints, and the lazy rebuild of their
// terms (constraints.c).
#pragma once

#include "sim.h"

// Skin weights of every constraint again (after a change of m); advances the matrix version.
void od_Constraints_Reskin(od_Sim* sim);
// Rebuilds the terms that the set's changes made stale; called at the start of every step or static solve.
od_Status od_Constraints_Prepare(od_Sim* sim);
// Whether a constraint of either kind involves particle i (after od_Constraints_Prepare).
bool od_Constraints_Touches(const od_Sim* sim, int i);
double od_Constraints_Energy(const od_Sim* sim);
void od_Constraints_Destroy(od_ConstraintSet* set);
