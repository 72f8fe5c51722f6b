// The local step: each particle's rotation, the others held fixed (eqs. 4 and 13, METHOD.md).
//
// R_i maximizes tr(R_iᵀ C_i) with
//   C_i = k Σ_j [R_j (Ā_j + Ā_i) + v_j (x_j - x_i)(X̄_j - X̄_i)ᵀ] + (ρ/h²) R̃_i Ā_i + constraint terms.
// The energy is exactly -tr(R_iᵀ C_i) + const in R_i, so each update is an exact block-coordinate
// minimization. Updates are Gauss-Seidel (each particle sees its neighbours' new rotations): with
// Jacobi updates the iteration can climb to a garbage state (METHOD.md, measured fact 1).
#include "math3.h"
#include "polar.h"
#include "sim.h"

void od_LocalStep_PrepareEdges(od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	double k = sim->def.stiffness;
	if (sim->edgeStiffness == k)
	{
		return;
	}
	for (int i = 0; i < g->n; ++i)
	{
		od_Mat3 ai = od_M3Load(g->moments + 9 * i);
		od_Vec3 ci = od_V3Load(g->centers + 3 * i);
		for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
		{
			int j = g->adj[e];
			od_Mat3 sum = od_M3Load(g->moments + 9 * j);
			od_M3AddScaled(&sum, 1.0, &ai);
			for (int c = 0; c < 9; ++c)
			{
				sim->edgeMoment[9 * e + c] = k * sum.m[c];
			}
			od_V3Store(sim->edgeArm + 3 * e, od_Scale(k * g->volumes[j], od_Sub(od_V3Load(g->centers + 3 * j), ci)));
		}
	}
	sim->edgeStiffness = k;
}

static od_Mat3 od_LocalMatrix(const od_Sim* sim, int i, const od_Mat3* ri)
{
	const od_Graph* g = sim->graph;
	const double* x = sim->state.x;
	const double* rot = sim->state.R;
	double c[9] = { 0 };
	double xi0 = x[3 * i], xi1 = x[3 * i + 1], xi2 = x[3 * i + 2];
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		int j = g->adj[e];
		const double* rj = rot + 9 * j;
		const double* m = sim->edgeMoment + 9 * e;
		const double* a = sim->edgeArm + 3 * e;
		double d[3] = { x[3 * j] - xi0, x[3 * j + 1] - xi1, x[3 * j + 2] - xi2 };
		for (int r = 0; r < 3; ++r)
		{
			for (int k = 0; k < 3; ++k)
			{
				c[3 * r + k] += rj[3 * r] * m[k] + rj[3 * r + 1] * m[3 + k] + rj[3 * r + 2] * m[6 + k] + d[r] * a[k];
			}
		}
	}
	if (sim->mode == OD_DYNAMIC)
	{
		const double* t = sim->inertiaTerm + 9 * i;
		for (int k = 0; k < 9; ++k)
		{
			c[k] += t[k];
		}
	}
	od_Mat3 out = od_M3Load(c);
	if (od_Constraints_Touches(sim, i))
	{
		od_Constraints_AddLocal(sim, i, ri, &out);
	}
	return out;
}

void od_LocalStep(od_Sim* sim)
{
	double* rot = sim->state.R;
	bool directions = sim->constraints.directionCount > 0;
	if (directions)
	{
		od_Constraints_BeginLocal(sim);
	}
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Mat3 before = od_M3Load(rot + 9 * i);
		od_Mat3 c = od_LocalMatrix(sim, i, &before);
		od_Mat3 r = before;
		sim->counters.polarFallbacks += od_PolarRotationWarm(&c, &r);
		od_M3Store(rot + 9 * i, &r);
		if (directions)
		{
			od_Constraints_RotationChanged(sim, i, &before, &r);
		}
	}
}
