// Direction constraints (eq. 10): their terms of the local step and the objective
// (direction_constraints.c). They never enter the global matrix nor the right side.
#pragma once

#include "math3.h"
#include "sim.h"

// The unnormalised skinned direction Σ_j w_j R_j n̄ and its length.
void od_Directions_Current(const od_Constraint* c, const od_State* s, double out[3], double* length);
od_Status od_Directions_Build(od_ConstraintSet* set, const od_Graph* g);
void od_Directions_BeginLocal(od_Sim* sim);
void od_Directions_AddLocal(const od_Sim* sim, int i, const od_Mat3* ri, od_Mat3* cmat);
void od_Directions_RotationChanged(od_Sim* sim, int i, const od_Mat3* before, const od_Mat3* after);
double od_Directions_Energy(const od_Sim* sim);
