// The stretch bound: flesh stiffens as it stretches. Each particle's link softness r_i is raised toward 1 by its
// most stretched link at the call's start, r_i + (1 - r_i) t, t = (s - L) / OD_STRETCH_RAMP clamped to [0, 1],
// s = |x_i - x_j| over the link's animated length |g_i - g_j| (the goal centres when the goals carry the rest,
// else the rest centres) and L the stretch limit. The weights of a call are held through it (lagged from its
// start, so each step minimises one objective) and are a function of the call's start alone: a call from a
// restored state makes the same weights, and with no link past L the weights, the factor and the bits are
// those of the softness as set (docs/goals.md, "Stretch bound (stop 48)").
#include "stretch_bound.h"
#include "energy.h"
#include "goal.h"
#include "math3.h"

#include <math.h>

// The stretch over the limit at which a link's ends are raised all the way to 1.
#define OD_STRETCH_RAMP 0.1

void od_MakeLinkWeights(od_Sim* sim, const double* r)
{
	const od_Graph* g = sim->graph;
	for (int i = 0; i < g->n; ++i)
	{
		for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
		{
			sim->linkWeight[e] = od_SofterEnd(r, i, g->adj[e]);
		}
	}
}

// t of particle i's most stretched link, 0 when none is past the limit.
static double od_MostStretched(const od_Sim* sim, const double* rest, int i)
{
	const od_Graph* g = sim->graph;
	od_Vec3 xi = od_V3Load(sim->state.x + 3 * i), ri = od_V3Load(rest + 3 * i);
	double most = 0.0;
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		int j = g->adj[e];
		double length = od_Length(od_Sub(od_V3Load(rest + 3 * j), ri));
		double over = od_Length(od_Sub(od_V3Load(sim->state.x + 3 * j), xi)) - sim->stretchLimit * length;
		most = fmax(most, over / (OD_STRETCH_RAMP * length));
	}
	return fmin(most, 1.0);
}

void od_StretchBound(od_Sim* sim)
{
	const double* r = sim->linkSoftness;
	double* raised = sim->linkRaised;
	if (!r || !raised)
	{
		return;
	}
	const double* rest = od_Goals_CarryRest(sim) ? sim->goals.x : sim->graph->centers;
	bool changed = false;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		double t = od_MostStretched(sim, rest, i);
		double value = t > 0.0 ? r[i] + (1.0 - r[i]) * t : r[i];
		changed = changed || value != raised[i];
		raised[i] = value;
	}
	if (changed)
	{
		od_MakeLinkWeights(sim, raised);
		sim->stiffnessVersion++;
		sim->edgeStiffness = 0.0; // the edges' terms are made again (local_step.c)
	}
}
