// The local step: each particle's rotation, the others held fixed (eqs. 4 and 13, METHOD.md).
//
// R_i maximizes tr(R_iᵀ C_i) with
//   C_i = k Σ_j [R_j (Ā_j + Ā_i) + v_j (x_j - x_i)(X̄_j - X̄_i)ᵀ] + (ρ/h²) R̃_i Ā_i + constraint terms.
// The energy is exactly -tr(R_iᵀ C_i) + const in R_i, so each update is an exact block-coordinate
// minimization. Updates are Gauss-Seidel (each particle sees its neighbours' new rotations): with
// Jacobi updates the iteration can climb to a garbage state (METHOD.md, measured fact 1).
#include "math3.h"
#include "polar.h"
#include "core.h"
#include "sim.h"

#include <string.h>

// C_i's elastic part, k Σ_j [R_j Ā_j + R_j Ā_i + v_j (x_j - x_i)(X̄_j - X̄_i)ᵀ], is summed as k [Σ_j P_j +
// (Σ_j R_j) Ā_i + Σ_j ...] with P_j = R_j Ā_j kept per particle (od_SetRotatedMoment): a neighbour costs 18
// additions and 9 multiply-adds, and everything read per edge is a per-particle array that stays in cache.
static void od_SetRotatedMoment(od_Sim* sim, int i, const od_Mat3* r)
{
	od_Mat3 a = od_M3Load(sim->graph->moments + 9 * i);
	od_Mat3 p = od_M3Mul(r, &a);
	od_M3Store(sim->rotatedMoment + 9 * i, &p);
}

static od_Mat3 od_LocalMatrix(const od_Sim* sim, int i, const od_Mat3* ri)
{
	const od_Graph* g = sim->graph;
	const double* x = sim->state.x;
	const double* rot = sim->state.R;
	const double* pm = sim->rotatedMoment;
	const double* ctr = g->centers;
	double sumP[9] = { 0 }, sumR[9] = { 0 }, arm[9] = { 0 };
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		int j = g->adj[e];
		const double* rj = rot + 9 * j;
		const double* pj = pm + 9 * j;
		for (int c = 0; c < 9; ++c)
		{
			sumP[c] += pj[c];
			sumR[c] += rj[c];
		}
		double vj = g->volumes[j];
		double d[3], a[3];
		for (int c = 0; c < 3; ++c)
		{
			d[c] = x[3 * j + c] - x[3 * i + c];
			a[c] = vj * (ctr[3 * j + c] - ctr[3 * i + c]);
		}
		for (int r = 0; r < 3; ++r)
		{
			for (int c = 0; c < 3; ++c)
			{
				arm[3 * r + c] += d[r] * a[c];
			}
		}
	}
	od_Mat3 ai = od_M3Load(g->moments + 9 * i), sr = od_M3Load(sumR);
	od_Mat3 out = od_M3Mul(&sr, &ai);
	double k = sim->def.stiffness;
	for (int c = 0; c < 9; ++c)
	{
		out.m[c] = k * (out.m[c] + sumP[c] + arm[c]);
	}
	if (sim->mode == OD_DYNAMIC)
	{
		const double* t = sim->inertiaTerm + 9 * i;
		for (int c = 0; c < 9; ++c)
		{
			out.m[c] += t[c];
		}
	}
	if (od_Constraints_Touches(sim, i))
	{
		od_Constraints_AddLocal(sim, i, ri, &out);
	}
	return out;
}

static int od_UpdateRotation(od_Sim* sim, int i, bool directions)
{
	double* rot = sim->state.R + 9 * i;
	od_Mat3 before = od_M3Load(rot);
	od_Mat3 c = od_LocalMatrix(sim, i, &before);
	od_Mat3 r = before;
	int fallback = od_PolarRotationWarm(&c, &r);
	od_M3Store(rot, &r);
	od_SetRotatedMoment(sim, i, &r);
	if (directions)
	{
		od_Constraints_RotationChanged(sim, i, &before, &r);
	}
	return fallback;
}

// Greedy colouring in index order of the conflict graph: graph edges and shared constraints.
od_Status od_LocalStep_PrepareColors(od_Sim* sim)
{
	if (!sim->colorsDirty)
	{
		return OD_OK;
	}
	const od_Graph* g = sim->graph;
	const od_ConstraintSet* set = &sim->constraints;
	int n = g->n;
	int* color = od_Alloc(sizeof(int) * (size_t)n);
	int* stamp = od_AllocZero((size_t)n + 1, sizeof(int));
	int* start = od_Realloc(sim->colorStart, sizeof(int) * ((size_t)n + 2));
	sim->colorStart = start ? start : sim->colorStart;
	if (!color || !stamp || !start || (!sim->colorOrder && !(sim->colorOrder = od_Alloc(sizeof(int) * (size_t)n))))
	{
		od_Free(color);
		od_Free(stamp);
		return od_Fail(OD_ERROR_MEMORY, "out of memory colouring the graph");
	}
	int colors = 0;
	for (int i = 0; i < n; ++i)
	{
		// stamp[c] == i + 1 marks colour c as taken by a conflicting particle coloured before i.
		for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
		{
			int j = g->adj[e];
			if (j < i)
			{
				stamp[color[j]] = i + 1;
			}
		}
		for (int p = set->pairStart[i]; p < set->pairStart[i + 1]; ++p)
		{
			int j = set->pairCol[p];
			if (j < i)
			{
				stamp[color[j]] = i + 1;
			}
		}
		for (int e = set->touchStart[i]; e < set->touchStart[i + 1]; ++e)
		{
			const od_Constraint* c = set->items + set->touchSlot[e];
			for (int k = 0; k < c->count; ++k)
			{
				if (c->idx[k] < i)
				{
					stamp[color[c->idx[k]]] = i + 1;
				}
			}
		}
		int c = 0;
		while (stamp[c] == i + 1)
		{
			++c;
		}
		color[i] = c;
		colors = c + 1 > colors ? c + 1 : colors;
	}
	memset(start, 0, sizeof(int) * ((size_t)colors + 1));
	for (int i = 0; i < n; ++i)
	{
		start[color[i] + 1]++;
	}
	for (int c = 0; c < colors; ++c)
	{
		start[c + 1] += start[c];
	}
	for (int i = 0; i < n; ++i)
	{
		sim->colorOrder[start[color[i]]++] = i;
	}
	for (int c = colors; c > 0; --c)
	{
		start[c] = start[c - 1];
	}
	start[0] = 0;
	sim->colorCount = colors;
	sim->colorsDirty = false;
	od_Free(color);
	od_Free(stamp);
	return OD_OK;
}

// Work is cut into one contiguous range of particle indices per thread (od_TaskRange), not handed out in
// small chunks: neighbouring indices share cache lines of R and P, and interleaved chunks made the two
// threads fight over them (the 10k-particle sweep ran slower on two threads than on one).
#define OD_MAX_THREADS 64

typedef struct od_SweepJob
{
	od_Sim* sim;
	const int* items;
	int count, tasks;
	bool directions;
	long long fallbacks[OD_MAX_THREADS];
} od_SweepJob;

// A colour with fewer particles runs on the calling thread: waking the others costs more (measured: 100
// particles stepped 1.6x slower on two threads than on one).
#define OD_SWEEP_SPLIT 512

static void od_SweepTask(void* ctx, int task, int thread)
{
	od_SweepJob* job = ctx;
	int begin = 0, end = job->count;
	if (job->count >= OD_SWEEP_SPLIT)
	{
		od_TaskRange(job->count, job->tasks, task, &begin, &end);
	}
	for (int k = begin; k < end; ++k)
	{
		job->fallbacks[thread] += od_UpdateRotation(job->sim, job->items[k], job->directions);
	}
}

static void od_RotatedMomentTask(void* ctx, int task, int thread)
{
	(void)thread;
	od_Sim* sim = ctx;
	int begin, end;
	od_TaskRange(sim->graph->n, od_Pool_Threads(sim->pool), task, &begin, &end);
	for (int i = begin; i < end; ++i)
	{
		od_Mat3 r = od_M3Load(sim->state.R + 9 * i);
		od_SetRotatedMoment(sim, i, &r);
	}
}

static void od_Sweep(od_Sim* sim);

void od_LocalStep(od_Sim* sim)
{
	double start = od_Clock();
	od_Sweep(sim);
	sim->counters.localSeconds += od_Clock() - start;
}

static void od_Sweep(od_Sim* sim)
{
	bool directions = sim->constraints.directionCount > 0;
	if (!sim->rotatedMomentValid && sim->pool && sim->graph->n >= OD_SWEEP_SPLIT)
	{
		od_Pool_Run(sim->pool, od_Pool_Threads(sim->pool), od_RotatedMomentTask, sim);
	}
	else if (!sim->rotatedMomentValid)
	{
		for (int i = 0; i < sim->graph->n; ++i)
		{
			od_Mat3 r = od_M3Load(sim->state.R + 9 * i);
			od_SetRotatedMoment(sim, i, &r);
		}
	}
	sim->rotatedMomentValid = true; // the sweep keeps P current as it turns each particle
	if (directions)
	{
		od_Constraints_BeginLocal(sim);
	}
	if (!sim->pool)
	{
		for (int i = 0; i < sim->graph->n; ++i)
		{
			sim->counters.polarFallbacks += od_UpdateRotation(sim, i, directions);
		}
		return;
	}
	od_SweepJob job = { .sim = sim, .directions = directions, .tasks = od_Pool_Threads(sim->pool) };
	for (int c = 0; c < sim->colorCount; ++c)
	{
		job.items = sim->colorOrder + sim->colorStart[c];
		job.count = sim->colorStart[c + 1] - sim->colorStart[c];
		od_Pool_Run(sim->pool, job.count >= OD_SWEEP_SPLIT ? job.tasks : 1, od_SweepTask, &job);
	}
	for (int t = 0; t < OD_MAX_THREADS; ++t)
	{
		sim->counters.polarFallbacks += job.fallbacks[t];
	}
}
