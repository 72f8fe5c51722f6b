// Position constraints (eq. 8): their terms of the local step, the global matrix, the right side and the
// objective (position_constraints.c).
#pragma once

#include "math3.h"
#include "sim.h"

#include <stddef.h>

// Where the constraint's point is now: Σ_j w_j (R_j (p̄ - X̄_j) + x_j).
void od_Positions_Current(const od_Constraint* c, const od_Graph* g, const od_State* s, double out[3]);
od_Status od_Positions_Build(od_ConstraintSet* set, const od_Graph* g);
void od_Positions_BuildTargets(od_ConstraintSet* set, const od_Graph* g);
void od_Positions_AddLocal(const od_Sim* sim, int i, od_Mat3* cmat);
od_Vec3 od_Positions_RhsRow(const od_Sim* sim, int a);

// The global matrix's constraint entries (upper triangle, one per pair a <= b of each constraint).
typedef void od_EntryFn(void* context, int row, int col, double value);
size_t od_Positions_EntryCount(const od_ConstraintSet* set);
void od_Positions_FillMatrix(const od_ConstraintSet* set, od_EntryFn* push, void* context);
double od_Positions_MaxWeight(const od_ConstraintSet* set);
void od_Positions_AddResidual(const od_Sim* sim, double* r);

double od_Positions_Energy(const od_Sim* sim);
// A static pose is defined only when every connected piece has a position constraint.
od_Status od_Positions_CheckPinned(const od_Sim* sim);
