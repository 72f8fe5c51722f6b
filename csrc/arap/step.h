// The stages of a dynamic step (step.c), for od_Sim_Step (simulation.c) and for a caller that steps several
// simulations together (contact_group.c, body_contact.c): Begin, then per step Start on each, Advance on each
// with the pairs between them in between, Finish on each, and End.
#pragma once

#include "sim.h"

// Takes the simulation (OD_ERROR_BUSY if another thread has it) for a call of `steps` steps.
od_Status od_Step_Begin(od_Sim* sim, int steps);
// The prediction and the iterations of one step (the state at its start kept in sim->previous): Start, then
// Advance until *more is false (the first call is the global solve, each later one a local/global pair; a
// contact group may advance a finished member further, reported once), or Solve for all of them.
// chooseStart: under a tolerance, start from the rotations od_Tolerance_ChooseStart picks (else the previous).
void od_Step_Start(od_Sim* sim, bool chooseStart);
od_Status od_Step_Advance(od_Sim* sim, bool* more);
od_Status od_Step_Solve(od_Sim* sim);
// Floor, colliders and velocities of step k of `steps`.
void od_Step_Finish(od_Sim* sim, int k, int steps);
// Releases the simulation; on failure its state and collider frames go back to those at Begin.
od_Status od_Step_End(od_Sim* sim, od_Status status);
