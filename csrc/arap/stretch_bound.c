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
#include "core.h"

#include <math.h>
#include <string.h>
#include <stdio.h>
#include <stdlib.h>

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

// How much of particle i's own motion relative to its goal's it keeps over `ahead` seconds: a goal spring of
// angular frequency ω alone turns a velocity w relative to the goal into an offset w sin(ωT) / ω, so the
// particle moves with its goal plus f = sin(ωT) / (ωT) of that velocity (0 from ωT = π on: a held particle
// goes where its goal goes).
static double od_OwnMotion(const od_Sim* sim, int i, double ahead)
{
	double angle = ahead * sqrt(sim->goals.omega2[i]);
	double spring = angle < 1e-8 ? 1.0 : (angle < M_PI ? sin(angle) / angle : 0.0);
	double keep = 1.0 - od_Damping(sim, i), steps = round(ahead / sim->def.dt);
	double damped = keep < 1.0 && !getenv("OD_NODAMP") ? keep * (1.0 - pow(keep, steps)) / (steps * (1.0 - keep)) : 1.0;
	return spring * damped;
}

// Each particle at the call's end (`ahead` seconds on): its centre into x (3n) and its rotation into R (9n), as
// its velocity v and angular velocity ω carry it there; when the goals' frame was set for this call
// (od_Goals_Moving) as u + f (v - u) and Ω + f (ω - Ω) carry it, u and Ω its goal's over the call
// (od_Goals_CallVelocity) and f its own motion's share (od_OwnMotion): a held particle stops where the
// animation stops within the call, which its velocity at the call's start does not show.
// Experiment: the relative velocities w = v - u over the call, one implicit step of T through the goals and the links, Jacobi.
static void od_Relative(const od_Sim* sim, double ahead, double* w)
{
	const od_Graph* g = sim->graph;
	int n = g->n, iters = atoi(getenv("OD_JAC"));
	const double* r = sim->linkSoftness;
	const double* uv = od_ElasticVolumes(sim);
	double* a = od_Alloc(sizeof(double) * 3 * (size_t)n);
	double* b = od_Alloc(sizeof(double) * 3 * (size_t)n);
	double T2 = ahead * ahead, k = sim->def.stiffness, rho = sim->def.density;
	for (int i = 0; i < n; ++i)
	{
		od_Vec3 rel = od_Sub(od_V3Load(sim->state.v + 3 * i), od_Goals_CallVelocity(sim, i, ahead));
		double keep = 1.0 - od_Damping(sim, i), steps = round(ahead / sim->def.dt);
		double damped = keep < 1.0 ? keep * (1.0 - pow(keep, steps)) / (steps * (1.0 - keep)) : 1.0;
		od_V3Store(a + 3 * i, od_Scale(damped, rel));
	}
	memcpy(b, a, sizeof(double) * 3 * (size_t)n);
	for (int it = 0; it < iters; ++it)
	{
		for (int i = 0; i < n; ++i)
		{
			double m = rho * g->volumes[i], sum = 0.0;
			od_Vec3 acc = od_V3Load(a + 3 * i);
			for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
			{
				int j = g->adj[e];
				double kap = k * od_SofterEnd(r, i, j) * (uv[i] + uv[j]) / m;
				sum += kap;
				acc = od_MulAdd(acc, T2 * kap, od_V3Load(b + 3 * j));
			}
			od_V3Store(w + 3 * i, od_Scale(1.0 / (1.0 + T2 * (sim->goals.omega2[i] + sum)), acc));
		}
		memcpy(b, w, sizeof(double) * 3 * (size_t)n);
	}
	if (iters == 0) memcpy(w, a, sizeof(double) * 3 * (size_t)n);
	od_Free(a);
	od_Free(b);
}

static void od_Ahead(const od_Sim* sim, double ahead, double* x, double* R)
{
	const od_State* s = &sim->state;
	bool goals = sim->goals.omega2 && od_Goals_Moving(sim) && !getenv("OD_OLD");
	double* jac = NULL;
	if (goals && getenv("OD_JAC")) { jac = od_Alloc(sizeof(double) * 3 * (size_t)sim->graph->n); od_Relative(sim, ahead, jac); }
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Vec3 v = od_V3Load(s->v + 3 * i), omega = od_V3Load(s->omega + 3 * i);
		if (goals)
		{
			double lam = getenv("OD_LAM") ? atof(getenv("OD_LAM")) : 1.0;
			double f = 1.0 - lam * (1.0 - od_OwnMotion(sim, i, ahead));
			od_Vec3 u = od_Goals_CallVelocity(sim, i, ahead), spin = od_V3Load(sim->goals.spin + 3 * i);
			v = od_MulAdd(u, f, od_Sub(v, u));
			omega = od_MulAdd(spin, f, od_Sub(omega, spin));
		}
		if (goals && jac) v = od_Add(od_Goals_CallVelocity(sim, i, ahead), od_V3Load(jac + 3 * i));
		od_Mat3 turn = od_M3ExpSkew(od_Scale(ahead, omega)), now = od_M3Load(s->R + 9 * i);
		od_Mat3 r = od_M3Mul(&turn, &now);
		od_M3Store(R + 9 * i, &r);
		od_V3Store(x + 3 * i, od_MulAdd(od_V3Load(s->x + 3 * i), ahead, v));
	}
	od_Free(jac);
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
	if (getenv("OD_RAW")) return stretch;
	return fmin(fmax(stretch - (sim->stretchLimit - 1.0), 0.0) / OD_STRETCH_RAMP, 1.0);
}
static void od_Debug(od_Sim* sim, const double* x, const double* R)
{
	const double* r = sim->linkSoftness;
	setenv("OD_RAW", "1", 1);
	double pred = 0.0, now = 0.0; int ep = -1, en = -1;
	for (int e = 0; e < sim->graph->edgeCount; ++e)
	{
		int i = sim->graph->edges[2 * e], j = sim->graph->edges[2 * e + 1];
		if (!(r[i] < 1.0 || r[j] < 1.0)) continue;
		double a = od_Over(sim, x, R, e), b = od_Over(sim, sim->state.x, sim->state.R, e);
		if (a > pred) { pred = a; ep = e; }
		if (b > now) { now = b; en = e; }
	}
	if (getenv("OD_DUMP"))
	{
		int n = sim->graph->n;
		double* x2 = od_Alloc(sizeof(double) * 12 * (size_t)n);
		unsetenv("OD_OLD");
		od_Ahead(sim, sim->def.dt * 10, x2, x2 + 3 * n);
		setenv("OD_OLD", "1", 1);
		FILE* f = fopen(getenv("OD_DUMP"), "a");
		for (int e = 0; e < sim->graph->edgeCount; ++e)
		{
			int i = sim->graph->edges[2 * e], j = sim->graph->edges[2 * e + 1];
			if (!(r[i] < 1.0 || r[j] < 1.0)) continue;
			fprintf(f, "%lld %d %d %.5f %.5f %.5f\n", sim->counters.steps, n, e, od_Over(sim, x, R, e), od_Over(sim, x2, x2 + 3 * n, e), od_Over(sim, sim->state.x, sim->state.R, e));
		}
		fclose(f);
		od_Free(x2);
	}
	unsetenv("OD_RAW");
	fprintf(stderr, "RAW %lld pred=%.3f (e%d) now=%.3f (e%d)\n", sim->counters.steps, pred, ep, now, en);
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

void od_StretchBound(od_Sim* sim, double ahead)
{
	const double* r = sim->linkSoftness;
	double* raised = sim->linkRaised;
	if (!r || !raised)
	{
		return;
	}
	int n = sim->graph->n;
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
	if (getenv("OD_DEBUG"))
	{
		od_Debug(sim, x, R);
		int raisedCount = 0; double top = 0.0, fmin_ = 1.0, fmax_ = 0.0;
		for (int i = 0; i < n; ++i) { raisedCount += most[i] > 0.0; top = fmax(top, most[i]);
			if (sim->goals.omega2 && r[i] < 1.0) { double f = od_OwnMotion(sim, i, ahead); fmin_ = fmin(fmin_, f); fmax_ = fmax(fmax_, f);} }
		fprintf(stderr, "SB %lld n=%d raised=%d top=%.3f moving=%d softf=[%.3f %.3f]\n", sim->counters.steps, n, raisedCount, top, sim->goals.omega2 && od_Goals_Moving(sim), fmin_, fmax_);
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

void od_StretchBound_DebugEnd(od_Sim* sim)
{
	const double* r = sim->linkSoftness;
	if (!getenv("OD_DUMP") || !r || !sim->linkRaised) return;
	setenv("OD_RAW", "1", 1);
	FILE* f = fopen(getenv("OD_DUMP"), "a");
	for (int e = 0; e < sim->graph->edgeCount; ++e)
	{
		int i = sim->graph->edges[2 * e], j = sim->graph->edges[2 * e + 1];
		if (!(r[i] < 1.0 || r[j] < 1.0)) continue;
		fprintf(f, "E %lld %d %d %.5f\n", sim->counters.steps, sim->graph->n, e, od_Over(sim, sim->state.x, sim->state.R, e));
	}
	fclose(f);
	unsetenv("OD_RAW");
}
