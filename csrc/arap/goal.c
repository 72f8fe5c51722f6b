// Goals: each particle pulled toward an animated frame (Soft Body's Goal, nCloth's Input Mesh Attract, in
// ARAP form). The only file that holds their maths.
//
// Particle i with goal centre g_i, goal rotation G_i and angular frequency ω_i = 2π f_i adds
//   E_goal,i = ½ ρ ω_i² (v_i |x_i - g_i|² + tr((R_i - G_i) Ā_i (R_i - G_i)ᵀ)),
// the inertia term of implicit Euler with (R̃, y, 1/h²) replaced by (G, g, ω²): a spring whose frequency,
// not its stiffness, is the setting, so it means the same at any size, mass and frame rate. It adds
// ρ v_i ω_i² to the global matrix's diagonal (refactored once per change of frequencies, tracked by
// goals.version), ρ v_i ω_i² g_i to the right side and ρ ω_i² G_i Ā_i to C_i of the local step; a new
// goal frame per frame changes only the right side and that term. Without goals (frequencies NULL)
// nothing here runs.
#include "goal.h"

#include "check.h"
#include "core.h"
#include "math3.h"

#include <math.h>
#include <string.h>

#define OD_TWO_PI 6.283185307179586

void od_Goals_Destroy(od_Goals* goals)
{
	od_Free(goals->omega2);
	od_Free(goals->x);
	od_Free(goals->R);
	od_Free(goals->term);
	goals->omega2 = goals->x = goals->R = goals->term = NULL; // the version stays: it keys the factor
}

// ρ ω_i² G_i Ā_i for every particle.
static void od_UpdateTerms(od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	od_Goals* goals = &sim->goals;
	for (int i = 0; i < g->n; ++i)
	{
		od_Mat3 r = od_M3Load(goals->R + 9 * i), a = od_M3Load(g->moments + 9 * i);
		od_Mat3 ra = od_M3Mul(&r, &a);
		for (int k = 0; k < 9; ++k)
		{
			goals->term[9 * i + k] = sim->def.density * goals->omega2[i] * ra.m[k];
		}
	}
}

// Goal frames start at the rest frames.
static od_Status od_Allocate(od_Sim* sim)
{
	int n = sim->graph->n;
	od_Goals* goals = &sim->goals;
	goals->omega2 = od_Alloc(sizeof(double) * n);
	goals->x = od_Alloc(sizeof(double) * 3 * n);
	goals->R = od_Alloc(sizeof(double) * 9 * n);
	goals->term = od_Alloc(sizeof(double) * 9 * n);
	if (!goals->omega2 || !goals->x || !goals->R || !goals->term)
	{
		od_Goals_Destroy(goals);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the goals of %d particles", n);
	}
	memcpy(goals->x, sim->graph->centers, sizeof(double) * 3 * n);
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 eye = od_M3Identity();
		od_M3Store(goals->R + 9 * i, &eye);
	}
	return OD_OK;
}

od_Status od_Sim_SetGoalFrequencies(od_Sim* sim, const double* frequencies)
{
	int n = sim->graph->n;
	for (int i = 0; frequencies && i < n; ++i)
	{
		if (!(frequencies[i] >= 0.0) || !isfinite(frequencies[i]))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "goal frequencies[%d] = %g must be finite and >= 0", i, frequencies[i]);
		}
	}
	sim->goals.version++;
	if (!frequencies)
	{
		od_Goals_Destroy(&sim->goals);
		return OD_OK;
	}
	if (!sim->goals.omega2)
	{
		od_Status status = od_Allocate(sim);
		if (status != OD_OK)
		{
			return status;
		}
	}
	for (int i = 0; i < n; ++i)
	{
		double omega = OD_TWO_PI * frequencies[i];
		sim->goals.omega2[i] = omega * omega;
	}
	od_UpdateTerms(sim);
	return OD_OK;
}

od_Status od_Sim_SetGoals(od_Sim* sim, const double* positions, const double* rotations)
{
	int n = sim->graph->n;
	if (!sim->goals.omega2)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "goals: set the goal frequencies first");
	}
	if (!positions)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "goal positions are required");
	}
	od_Status status = od_CheckFinite("goal positions", positions, 3 * n);
	if (status == OD_OK && rotations)
	{
		status = od_CheckRotations("goal rotations", rotations, n);
	}
	if (status != OD_OK)
	{
		return status;
	}
	memcpy(sim->goals.x, positions, sizeof(double) * 3 * n);
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 r = rotations ? od_M3Load(rotations + 9 * i) : od_M3Identity();
		od_M3Store(sim->goals.R + 9 * i, &r);
	}
	od_UpdateTerms(sim);
	return OD_OK;
}

double od_Goals_Diagonal(const od_Sim* sim, int i)
{
	return sim->goals.omega2 ? sim->def.density * sim->graph->volumes[i] * sim->goals.omega2[i] : 0.0;
}

od_Vec3 od_Goals_RhsRow(const od_Sim* sim, int i, bool residual)
{
	od_Vec3 g = od_V3Load(sim->goals.x + 3 * i);
	if (residual)
	{
		g = od_Sub(g, od_V3Load(sim->state.x + 3 * i));
	}
	return od_Scale(od_Goals_Diagonal(sim, i), g);
}

void od_Goals_AddLocal(const od_Sim* sim, int i, double c[9])
{
	const double* t = sim->goals.term + 9 * i;
	for (int k = 0; k < 9; ++k)
	{
		c[k] += t[k];
	}
}

bool od_Goals_Hold(const od_Sim* sim, int i)
{
	return sim->goals.omega2 && sim->goals.omega2[i] > 0.0;
}

double od_Goals_Energy(const od_Sim* sim)
{
	const od_Goals* goals = &sim->goals;
	const od_Graph* g = sim->graph;
	double e = 0.0;
	for (int i = 0; goals->omega2 && i < g->n; ++i)
	{
		od_Mat3 r = od_M3Load(sim->state.R + 9 * i), gr = od_M3Load(goals->R + 9 * i), a = od_M3Load(g->moments + 9 * i);
		od_M3AddScaled(&r, -1.0, &gr);
		od_Mat3 da = od_M3Mul(&r, &a);
		od_Vec3 d = od_Sub(od_V3Load(sim->state.x + 3 * i), od_V3Load(goals->x + 3 * i));
		e += goals->omega2[i] * (od_M3Inner(&da, &r) + g->volumes[i] * od_Dot(d, d));
	}
	return 0.5 * sim->def.density * e;
}
