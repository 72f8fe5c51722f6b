// Goals (goal.c): a pull of each particle toward an animated frame; their terms of the global matrix, the
// right side, the local step and the objective.
#pragma once

#include "math3.h"
#include "sim.h"

void od_Goals_Destroy(od_Goals* goals);
// ρ v_i ω_i², the goal's entry of the global matrix's diagonal (0 without goals).
double od_Goals_Diagonal(const od_Sim* sim, int i);
// ρ v_i ω_i² g_i, or with `residual` ρ v_i ω_i² (g_i - x_i).
od_Vec3 od_Goals_RhsRow(const od_Sim* sim, int i, bool residual);
// Adds ρ ω_i² G_i Ā_i to the local step's C_i (call only when sim->goals.omega2).
void od_Goals_AddLocal(const od_Sim* sim, int i, double c[9]);
// Whether particle i has a goal of nonzero frequency (it then pins its piece in a static pose).
bool od_Goals_Hold(const od_Sim* sim, int i);
double od_Goals_Energy(const od_Sim* sim);
// Whether the goals carry the rest (od_Sim_SetGoalRest) and exist: the edges' terms then come from the goal shape.
static inline bool od_Goals_CarryRest(const od_Sim* sim)
{
	return sim->goals.edgeRest != NULL;
}
// d_ij = G_iᵀ (g_j - g_i) and Q_ji = G_jᵀ G_i of the goal shape (call only when od_Goals_CarryRest).
void od_Goals_EdgeRest(const od_Sim* sim, int i, int j, od_Vec3* arm, od_Mat3* turn);
// Directed edge e = (i, j) from the goal shape: its moment s_j Ā_j Q_ji + s_i Q_ji Ā_i and arm d_ij of the local
// step (without k and s_j v_j), and goals.edgeRest's six numbers for the right side (global_solve.c).
void od_Goals_PrepareEdge(const od_Sim* sim, int i, int e, double si, double sj, od_Mat3* moment, od_Vec3* arm);
// A call of `steps` steps begins (od_Step_Begin); each step's goals are then placed by od_Goals_Place (goal.c).
void od_Goals_BeginCall(od_Sim* sim, int steps);
// Places goals carrying the rest for the call's step goals.step (od_Step_Start); the last has the frame set.
void od_Goals_Place(od_Sim* sim);
// Goal i's velocity over the step being made (goals carrying the rest): the chord of its screw motion over the
// step, exp(-b h [Ω_i]×) V(-h Ω_i) u_i, b the step's steps before the frame (goal.c, od_TrackMotion).
od_Vec3 od_Goals_StepVelocity(const od_Sim* sim, int i);
// The frame set back in place after a call (or a failed one).
void od_Goals_EndCall(od_Sim* sim);
