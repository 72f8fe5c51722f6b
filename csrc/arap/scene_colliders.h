// Scene colliders of a simulation (scene_colliders.c): the set's life and the frames over a call of od_Sim_Step.
#pragma once

#include "opdeform/colliders.h"
#include "sim.h"

void od_Colliders_Destroy(od_Colliders* set);
// Starts a call of `steps` steps: each collider moves to its target over them.
void od_Colliders_BeginCall(od_Sim* sim, int steps);
// Ends the call: at the targets when done, else back at the frames the call started from.
void od_Colliders_EndCall(od_Sim* sim, bool done);
