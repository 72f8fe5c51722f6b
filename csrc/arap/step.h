// The stages of a dynamic step (simulation.c), for a caller that steps several simulations together
// (contact_group.c): Begin, then per step Solve on each, the pairs between them, Finish on each, and End.
#pragma once

#include "sim.h"

// Takes the simulation (OD_ERROR_BUSY if another thread has it) for a call of `steps` steps.
od_Status od_Step_Begin(od_Sim* sim, int steps);
// The prediction and the iterations of one step (the state at its start kept in sim->previous).
od_Status od_Step_Solve(od_Sim* sim);
// Floor, colliders and velocities of step k of `steps`.
void od_Step_Finish(od_Sim* sim, int k, int steps);
// Releases the simulation; on failure its state and collider frames go back to those at Begin.
od_Status od_Step_End(od_Sim* sim, od_Status status);
