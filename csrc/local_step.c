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

static od_Mat3 od_LocalMatrix(const od_Sim* sim, int i)
{
	const od_Graph* g = sim->graph;
	const od_State* s = &sim->state;
	double k = sim->def.stiffness;
	od_Vec3 xi = od_V3Load(s->x + 3 * i), ci = od_V3Load(g->centers + 3 * i);
	od_Mat3 ai = od_M3Load(g->moments + 9 * i);
	od_Mat3 c = od_M3Zero();
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		int j = g->adj[e];
		od_Mat3 rj = od_M3Load(s->R + 9 * j);
		od_Mat3 sum = od_M3Load(g->moments + 9 * j);
		od_M3AddScaled(&sum, 1.0, &ai);
		od_Mat3 t = od_M3Mul(&rj, &sum);
		od_M3AddScaled(&c, k, &t);
		od_Vec3 d = od_Sub(od_V3Load(s->x + 3 * j), xi);
		od_Vec3 dbar = od_Sub(od_V3Load(g->centers + 3 * j), ci);
		od_M3AddOuter(&c, k * g->volumes[j], d, dbar);
	}
	if (sim->mode == OD_DYNAMIC)
	{
		double h = sim->def.dt;
		od_Mat3 rt = od_M3Load(sim->Rtilde + 9 * i);
		od_Mat3 t = od_M3Mul(&rt, &ai);
		od_M3AddScaled(&c, sim->def.density / (h * h), &t);
	}
	if (sim->constraints.touchStart[i] != sim->constraints.touchStart[i + 1])
	{
		od_Constraints_AddLocal(sim, i, &c);
	}
	return c;
}

void od_LocalStep(od_Sim* sim)
{
	double* rot = sim->state.R;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Mat3 c = od_LocalMatrix(sim, i);
		od_Mat3 r = od_M3Load(rot + 9 * i);
		sim->counters.polarFallbacks += od_PolarRotationWarm(&c, &r);
		od_M3Store(rot + 9 * i, &r);
	}
}
