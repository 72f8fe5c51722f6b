// The stretch bound (od_Sim_SetStretchLimit): flesh stiffens as it stretches. At a call's start, each link's
// stretch of the skin at the call's end, as the particles' velocities carry them there (od_Over), past the limit L
// by t (over OD_STRETCH_RAMP, at most 1) raises its ends' link softness r to r^(1 - t): gently at first, all the
// way to 1 at L + OD_STRETCH_RAMP. The weights of a call are held through it (each step minimises one objective)
// and are a function of the call's start and its duration: a call from a restored state makes the same (a frame
// split into several calls looks ahead less far), a static solve uses the softness as set, and with no link
// past L the weights, the factor and the bits are those of the softness as set (docs/goals.md, "Stretch bound
// (stop 48)").
#include "stretch_bound.h"
#include "energy.h"
#include "goal.h"
#include "math3.h"

#include <math.h>
#include <string.h>

// The stretch over the limit at which a link's ends are raised all the way to 1.
#define OD_STRETCH_RAMP 0.2

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

// The rest vector d_ij of link (i, j) in particle i's frame: the goal shape's G_iᵀ (g_j - g_i) when the goals
// carry the rest, else the rest's c_j - c_i.
static od_Vec3 od_RestVector(const od_Sim* sim, int i, int j)
{
	if (!od_Goals_CarryRest(sim))
	{
		const double* c = sim->graph->centers;
		return od_Sub(od_V3Load(c + 3 * j), od_V3Load(c + 3 * i));
	}
	od_Mat3 gi = od_M3Load(sim->goals.R + 9 * i);
	return od_M3MulTV(&gi, od_Sub(od_V3Load(sim->goals.x + 3 * j), od_V3Load(sim->goals.x + 3 * i)));
}

// Each particle at the call's end (`ahead` seconds on) as its velocities carry it there: its centre into x (3n)
// and its rotation into R (9n).
static void od_Ahead(const od_Sim* sim, double ahead, double* x, double* R)
{
	const od_State* s = &sim->state;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Mat3 turn = od_M3ExpSkew(od_Scale(ahead, od_V3Load(s->omega + 3 * i))), now = od_M3Load(s->R + 9 * i);
		od_Mat3 r = od_M3Mul(&turn, &now);
		od_M3Store(R + 9 * i, &r);
		od_V3Store(x + 3 * i, od_MulAdd(od_V3Load(s->x + 3 * i), ahead, od_V3Load(s->v + 3 * i)));
	}
}

// The stretch link e = (i, j) adds to the skin between its ends at the call's end (od_Ahead's x, R): the gap at its
// middle between the skin its ends carry, δ = x_j - x_i - (R_i d_ij - R_j d_ji) / 2 (their stretch, and their
// disagreement on their turn where it parts the skin), times the link's skin gradient (the most half the
// difference of its ends' skin weights changes per metre along a mesh edge: a gap δ stretches such an edge by
// about |δ| g), or over the link's length |d_ij| without a gradient. Past the limit, over OD_STRETCH_RAMP, in
// [0, 1].
static double od_Over(const od_Sim* sim, const double* x, const double* R, int e)
{
	int i = sim->graph->edges[2 * e], j = sim->graph->edges[2 * e + 1];
	od_Mat3 ri = od_M3Load(R + 9 * i), rj = od_M3Load(R + 9 * j);
	od_Vec3 xi = od_V3Load(x + 3 * i), xj = od_V3Load(x + 3 * j);
	od_Vec3 dij = od_RestVector(sim, i, j), dji = od_RestVector(sim, j, i);
	od_Vec3 carried = od_Scale(0.5, od_Sub(od_M3MulV(&ri, dij), od_M3MulV(&rj, dji)));
	double gap = od_Length(od_Sub(od_Sub(xj, xi), carried));
	const double* g = sim->skinGradient;
	double length = od_Length(dij); // 0 where goal centres coincide: nothing to measure the stretch against
	double stretch = g ? gap * g[e] : (length > 0.0 ? gap / length : 0.0);
	return fmin(fmax(stretch - (sim->stretchLimit - 1.0), 0.0) / OD_STRETCH_RAMP, 1.0);
}

void od_StretchBound_Lower(od_Sim* sim)
{
	size_t bytes = sizeof(double) * (size_t)sim->graph->n;
	if (sim->linkSoftness && sim->linkRaised && memcmp(sim->linkRaised, sim->linkSoftness, bytes))
	{
		memcpy(sim->linkRaised, sim->linkSoftness, bytes);
		od_MakeLinkWeights(sim, sim->linkSoftness);
		sim->stiffnessVersion++;
		sim->edgeStiffness = 0.0;
	}
}

// Whether any of the n particles has softened links (r < 1): else no link has anything to raise, and the raised
// softness is r (od_Sim_SetStretchLimit, od_FillLinkWeights and each call here leave it so).
static bool od_Softened(const double* r, int n)
{
	for (int i = 0; i < n; ++i)
	{
		if (r[i] < 1.0)
		{
			return true;
		}
	}
	return false;
}

void od_StretchBound(od_Sim* sim, double ahead)
{
	const double* r = sim->linkSoftness;
	double* raised = sim->linkRaised;
	int n = sim->graph->n;
	if (!r || !raised || !od_Softened(r, n))
	{
		return;
	}
	double *most = raised + n, *x = most + n, *R = x + 3 * n; // the scratch (od_Sim_SetStretchLimit)
	memset(most, 0, sizeof(double) * (size_t)n);
	od_Ahead(sim, ahead, x, R);
	for (int e = 0; e < sim->graph->edgeCount; ++e)
	{
		int i = sim->graph->edges[2 * e], j = sim->graph->edges[2 * e + 1];
		double t = r[i] < 1.0 || r[j] < 1.0 ? od_Over(sim, x, R, e) : 0.0; // a stiff link has nothing to raise
		most[i] = fmax(most[i], t);
		most[j] = fmax(most[j], t);
	}
	bool changed = false;
	for (int i = 0; i < n; ++i)
	{
		double value = most[i] > 0.0 ? pow(r[i], 1.0 - most[i]) : r[i];
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
