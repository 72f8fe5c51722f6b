// The local step: each particle's rotation, the others held fixed (eqs. 4 and 13, METHOD.md).
//
// R_i maximizes tr(R_iᵀ C_i) with
//   C_i = k Σ_j w_ij [R_j (s_j Ā_j + s_i Ā_i) + s_j v_j (x_j - x_i)(X̄_j - X̄_i)ᵀ] + (ρ/h²) R̃_i Ā_i + constraint terms
// (s the stiffness scale, od_ElasticScale, and w the link weight, od_LinkWeight: 1 without them; with goals
// carrying the rest, the edges' terms of goal.c's note).
// The energy is exactly -tr(R_iᵀ C_i) + const in R_i, so each update is an exact block-coordinate
// minimization. Updates are Gauss-Seidel (each particle sees its neighbours' new rotations): with
// Jacobi updates the iteration can climb to a garbage state (METHOD.md, measured fact 1).
//
// Batches (issue 26): where the polar decompositions run in AVX2 registers (local_avx2.c), each sweep's order is
// rearranged once, when the partition is made, into batches of up to four particles updated together. A batch is
// led by the first particle not yet updated; a later one, within OD_BATCH_WINDOW places, joins it when it touches
// no constraint and none of its neighbours lies between the two still to be updated (or is in the batch). Updates
// of particles that are not neighbours commute exactly (neither reads the other's rotation), so the batches give
// the serial sweep's result bit for bit, where four consecutive particles would not: k+1 is a neighbour of k for
// 90-100 % of the particles of the scenes measured (docs/speed.md). Particles touching constraints update alone,
// as does every particle where the processor lacks AVX2.
#include "local_step.h"

#include "clock.h"
#include "constraints.h"
#include "core.h"
#include "direction_constraints.h"
#include "energy.h"
#include "goal.h"
#include "local_avx2.h"
#include "math3.h"
#include "platform.h"
#include "polar.h"
#include "position_constraints.h"

#include <string.h>

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
		od_Vec3 ci = od_V3Load(g->centers + 3 * i), row = od_V3(0, 0, 0);
		double si = od_ElasticScale(sim, i);
		for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
		{
			int j = g->adj[e];
			double w = od_LinkWeight(sim, e), wi = w * si, wj = w * od_ElasticScale(sim, j);
			od_Mat3 sum = od_M3Zero();
			od_Vec3 rest;
			if (od_Goals_CarryRest(sim)) // measured against the goal shape (goal.c)
			{
				od_Goals_PrepareEdge(sim, i, e, wi, wj, &sum, &rest);
			}
			else
			{
				od_Mat3 aj = od_M3Load(g->moments + 9 * j);
				od_M3AddScaled(&sum, wj, &aj);
				od_M3AddScaled(&sum, wi, &ai);
				rest = od_Sub(od_V3Load(g->centers + 3 * j), ci);
			}
			for (int c = 0; c < 9; ++c)
			{
				sim->edgeMoment[9 * e + c] = k * sum.m[c];
			}
			od_Vec3 arm = od_Scale(k * (wj * g->volumes[j]), rest);
			od_V3Store(sim->edgeArm + 3 * e, arm);
			row = od_Sub(row, arm);
		}
		od_V3Store(sim->rowArm + 3 * i, row);
	}
	sim->edgeStiffness = k;
}

#ifdef OD_LOCAL_AVX2
// Whether C_i is summed by local_avx2.c's kernel (bit-identical to the scalar sum: docs/speed.md), read once
// here: the platform's answer is a call into another file.
static bool od_LocalUsesAvx2(void)
{
	static int known = -1; // a benign race: every thread finds the same answer
	if (known < 0)
	{
		known = od_Platform_HasAvx2Fma();
	}
	return known == 1;
}
#endif

// The edges' part of C_i into c (local_avx2.c has its AVX2 twin).
static inline void od_LocalEdges(const od_Sim* sim, int i, double c[9])
{
	const od_Graph* g = sim->graph;
	const double* x = sim->state.x;
	const double* rot = sim->state.R;
	double xi0 = x[3 * i], xi1 = x[3 * i + 1], xi2 = x[3 * i + 2];
	// The sum in nine scalars, copied to c after the loop: c's address goes to the goals and constraints below,
	// and summed in c itself the compiler stored it to memory every edge (measured 1.1x slower, Fig. 4 body).
	double s0 = 0, s1 = 0, s2 = 0, s3 = 0, s4 = 0, s5 = 0, s6 = 0, s7 = 0, s8 = 0;
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		int j = g->adj[e];
		const double* rj = rot + 9 * j;
		const double* m = sim->edgeMoment + 9 * e;
		const double* a = sim->edgeArm + 3 * e;
		double d0 = x[3 * j] - xi0, d1 = x[3 * j + 1] - xi1, d2 = x[3 * j + 2] - xi2;
		s0 += rj[0] * m[0] + rj[1] * m[3] + rj[2] * m[6] + d0 * a[0];
		s1 += rj[0] * m[1] + rj[1] * m[4] + rj[2] * m[7] + d0 * a[1];
		s2 += rj[0] * m[2] + rj[1] * m[5] + rj[2] * m[8] + d0 * a[2];
		s3 += rj[3] * m[0] + rj[4] * m[3] + rj[5] * m[6] + d1 * a[0];
		s4 += rj[3] * m[1] + rj[4] * m[4] + rj[5] * m[7] + d1 * a[1];
		s5 += rj[3] * m[2] + rj[4] * m[5] + rj[5] * m[8] + d1 * a[2];
		s6 += rj[6] * m[0] + rj[7] * m[3] + rj[8] * m[6] + d2 * a[0];
		s7 += rj[6] * m[1] + rj[7] * m[4] + rj[8] * m[7] + d2 * a[1];
		s8 += rj[6] * m[2] + rj[7] * m[5] + rj[8] * m[8] + d2 * a[2];
	}
	c[0] = s0, c[1] = s1, c[2] = s2, c[3] = s3, c[4] = s4, c[5] = s5, c[6] = s6, c[7] = s7, c[8] = s8;
}

static od_Mat3 od_LocalMatrix(const od_Sim* sim, int i, const od_Mat3* ri)
{
	od_Mat3 out; // summed in place: a copy of the just-written sum waited on store forwarding (docs/speed.md)
	double* c = out.m;
#ifdef OD_LOCAL_AVX2
	if (od_LocalUsesAvx2())
	{
		od_LocalAvx2_Sum(sim, i, c); // the edges and the inertia
	}
	else
#endif
	{
		od_LocalEdges(sim, i, c);
		if (sim->mode == OD_DYNAMIC)
		{
			const double* t = sim->inertiaTerm + 9 * i;
			for (int k = 0; k < 9; ++k)
			{
				c[k] += t[k];
			}
		}
	}
	if (sim->goals.omega2)
	{
		od_Goals_AddLocal(sim, i, c);
	}
	if (od_Constraints_Touches(sim, i))
	{
		od_Positions_AddLocal(sim, i, &out);
		od_Directions_AddLocal(sim, i, ri, &out);
	}
	return out;
}

static int od_UpdateRotation(od_Sim* sim, int i, bool directions)
{
	double* rot = sim->state.R + 9 * i;
	od_Mat3 before = od_M3Load(rot);
	od_Mat3 c = od_LocalMatrix(sim, i, &before);
	od_Mat3* r = (od_Mat3*)rot; // updated in place: a copy of the polar's result waited on store forwarding
	int fallback = od_PolarRotationWarm(&c, r);
	if (directions)
	{
		od_Directions_RotationChanged(sim, i, &before, r);
	}
	return fallback;
}

// Whether particle i shares an edge, a constraint pair or a direction constraint with a particle outside
// the index range [lo, hi).
static bool od_ReachesOut(const od_Sim* sim, int i, int lo, int hi)
{
	const od_Graph* g = sim->graph;
	const od_ConstraintSet* set = &sim->constraints;
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		if (g->adj[e] < lo || g->adj[e] >= hi)
		{
			return true;
		}
	}
	for (int p = set->pairStart[i]; p < set->pairStart[i + 1]; ++p)
	{
		if (set->pairCol[p] < lo || set->pairCol[p] >= hi)
		{
			return true;
		}
	}
	for (int e = set->touchStart[i]; e < set->touchStart[i + 1]; ++e)
	{
		const od_Constraint* c = set->items + set->touchSlot[e];
		for (int k = 0; k < c->count; ++k)
		{
			if (c->idx[k] < lo || c->idx[k] >= hi)
			{
				return true;
			}
		}
	}
	return false;
}

// The parallel sweep's partition: one contiguous block of particle indices per pool thread. A block's interior
// (particles whose neighbours and constraint partners all lie in the block) is swept by one task in index order;
// its border, the particles that reach into another block, after it in three phases that keep the result a
// function of the pool's size alone:
//   1. every block's interior, each even block's border right after its interior (in the same task);
//   2. each odd block's border;
//   3. on the calling thread, the far border: particles reaching past the blocks next to theirs (none on the
//      lattices and voxelized meshes measured; thin blocks of a small or scattered graph have some).
// Reach is symmetric (edges, constraint pairs and direction constraints list both ends), so an even block's
// border in phase 1 reads of the blocks beside it only their borders, which no task writes in that phase; in
// phase 2 the odd blocks' borders read even blocks, written in phase 1. Blocks keep a serial sweep's memory
// locality; graphs in a spatial order have thin borders. The border swept on one thread after the interiors
// (before issue 26) capped the sweep near 3x on 16 threads: the 10,000-particle beam's border is 32 % of it
// with 16 blocks. A multicolour sweep was measured first: it touched memory once per colour and ran slower on
// two threads than one at 100,000 particles.
//
// Layout: block b's interior is sweepOrder[sweepStart[2b]..sweepStart[2b+1]), its border up to
// sweepStart[2b+2]; the far border from sweepStart[2 blocks] to sweepStart[2 blocks + 1] = n, in index order;
// each range then in batches (od_Schedule).
static void od_PartitionBlock(od_Sim* sim, int blocks, int b, int* at, int* far)
{
	int n = sim->graph->n, lo, hi, nearLo, nearHi, unused;
	od_TaskRange(n, blocks, b, &lo, &hi);
	od_TaskRange(n, blocks, b > 0 ? b - 1 : b, &nearLo, &unused);
	od_TaskRange(n, blocks, b + 1 < blocks ? b + 1 : b, &unused, &nearHi);
	sim->sweepStart[2 * b] = *at;
	for (int i = lo; i < hi; ++i)
	{
		if (!od_ReachesOut(sim, i, lo, hi))
		{
			sim->sweepOrder[(*at)++] = i;
		}
	}
	sim->sweepStart[2 * b + 1] = *at;
	for (int i = lo; i < hi; ++i)
	{
		if (od_ReachesOut(sim, i, nearLo, nearHi))
		{
			sim->sweepOrder[--*far] = i; // filled from the end, reversed below
		}
		else if (od_ReachesOut(sim, i, lo, hi))
		{
			sim->sweepOrder[(*at)++] = i;
		}
	}
}

// Graphs smaller than this sweep on the calling thread: waking the others costs more than it saves
// (measured: 100 particles stepped 1.6x slower on two threads than on one).
#define OD_SWEEP_SPLIT 512
// How far past a batch's first particle its other members are looked for, in places of the sweep's order.
#define OD_BATCH_WINDOW 64

static bool od_SweepsSerially(const od_Sim* sim)
{
	return !sim->pool || sim->graph->n < OD_SWEEP_SPLIT;
}

// The most particles a batch: 4 where the polar decompositions run in AVX2 registers, else 1 (the order kept).
static int od_BatchWidth(void)
{
#ifdef OD_LOCAL_AVX2
	if (od_LocalUsesAvx2())
	{
		return OD_LOCAL_LANES;
	}
#endif
	return 1;
}

typedef struct od_ScheduleScratch
{
	int* place;  // n: each particle's place in sweepOrder
	bool* taken; // n, by place: already in a batch
	int* out;    // n: the batches' order
} od_ScheduleScratch;

// Whether particle i, at place q, may join the batch that particle at place p < q leads: i touches no constraint
// (so its edges are all it shares with others), and no neighbour of i lies in [p, q) still to be updated (or in
// the batch). Then updating i before them changes nothing: i reads none of them, none of them reads i.
static bool od_MayJoin(const od_Sim* sim, int i, const od_ScheduleScratch* s, int p, int q)
{
	const od_Graph* g = sim->graph;
	if (od_Constraints_Touches(sim, i))
	{
		return false;
	}
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		int at = s->place[g->adj[e]];
		if (at >= p && at < q && !s->taken[at])
		{
			return false;
		}
	}
	return true;
}

// Consecutive lone particles into runs of up to OD_RUN (sim.h's sweepBatch): a sweep steps through a run in a
// plain loop (stepping batch by batch cost a chain of particles, all alone, 12 %).
#define OD_RUN 127
static void od_MarkRuns(signed char* batch, int count)
{
	for (int k = 0; k < count;)
	{
		int run = 0;
		while (k + run < count && batch[k + run] == 1 && run < OD_RUN)
		{
			batch[k + run++] = 0;
		}
		batch[k] = (signed char)(run ? -run : batch[k]);
		k += run ? run : batch[k];
	}
}

// sweepOrder[begin..end) reordered into batches of up to `width` that give its serial sweep bit for bit: each
// batch led by the first particle not yet taken, with the first that may join it within OD_BATCH_WINDOW places.
static void od_ScheduleRange(od_Sim* sim, int begin, int end, int width, od_ScheduleScratch* s)
{
	const int* order = sim->sweepOrder;
	int at = begin;
	for (int p = begin; p < end; ++p)
	{
		if (s->taken[p])
		{
			continue;
		}
		int batch[OD_LOCAL_LANES] = { p }, size = 1;
		bool alone = width == 1 || od_Constraints_Touches(sim, order[p]);
		for (int q = p + 1; !alone && size < width && q < end && q <= p + OD_BATCH_WINDOW; ++q)
		{
			if (!s->taken[q] && od_MayJoin(sim, order[q], s, p, q))
			{
				batch[size++] = q;
			}
		}
		for (int k = 0; k < size; ++k)
		{
			s->taken[batch[k]] = true;
			s->out[at + k] = order[batch[k]];
			sim->sweepBatch[at + k] = (signed char)(k ? 0 : size);
		}
		at += size;
	}
	memcpy(sim->sweepOrder + begin, s->out + begin, sizeof(int) * (size_t)(end - begin));
	od_MarkRuns(sim->sweepBatch + begin, end - begin);
}

// Each range [bounds[r], bounds[r + 1]) of the sweep's order in batches (sim.h).
static od_Status od_Schedule(od_Sim* sim, const int* bounds, int ranges)
{
	int n = sim->graph->n;
	od_ScheduleScratch s = { od_Alloc(sizeof(int) * (size_t)n), od_Alloc(sizeof(bool) * (size_t)n),
							 od_Alloc(sizeof(int) * (size_t)n) };
	od_Status status = OD_OK;
	if (s.place && s.taken && s.out)
	{
		for (int k = 0; k < n; ++k)
		{
			s.place[sim->sweepOrder[k]] = k;
			s.taken[k] = false;
		}
		for (int r = 0; r < ranges; ++r)
		{
			od_ScheduleRange(sim, bounds[r], bounds[r + 1], od_BatchWidth(), &s);
		}
	}
	else
	{
		status = od_Fail(OD_ERROR_MEMORY, "out of memory scheduling the sweep");
	}
	od_Free(s.place);
	od_Free(s.taken);
	od_Free(s.out);
	return status;
}

// The threaded sweep's blocks (above), or the serial sweep's index order.
static od_Status od_Partition(od_Sim* sim)
{
	int n = sim->graph->n;
	if (od_SweepsSerially(sim))
	{
		for (int i = 0; i < n; ++i)
		{
			sim->sweepOrder[i] = i;
		}
		return od_Schedule(sim, (const int[]){ 0, n }, 1);
	}
	int blocks = od_Pool_Threads(sim->pool);
	int* start = od_Realloc(sim->sweepStart, sizeof(int) * (2 * (size_t)blocks + 2));
	if (!start)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory partitioning the graph");
	}
	sim->sweepStart = start;
	int at = 0, far = n;
	for (int b = 0; b < blocks; ++b)
	{
		od_PartitionBlock(sim, blocks, b, &at, &far);
	}
	start[2 * blocks] = at;
	start[2 * blocks + 1] = n;
	for (int a = at, z = n - 1; a < z; ++a, --z) // the far border in index order
	{
		int t = sim->sweepOrder[a];
		sim->sweepOrder[a] = sim->sweepOrder[z];
		sim->sweepOrder[z] = t;
	}
	return od_Schedule(sim, start, 2 * blocks + 1);
}

od_Status od_LocalStep_PreparePartition(od_Sim* sim)
{
	if (!sim->partitionDirty)
	{
		return OD_OK;
	}
	size_t n = (size_t)sim->graph->n;
	if ((!sim->sweepOrder && !(sim->sweepOrder = od_Alloc(sizeof(int) * n))) ||
		(!sim->sweepBatch && !(sim->sweepBatch = od_Alloc(n))))
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory partitioning the graph");
	}
	od_Status status = od_Partition(sim);
	sim->partitionDirty = status != OD_OK;
	return status;
}

typedef struct od_SweepJob
{
	od_Sim* sim;
	bool directions;
	bool odd; // phase 2: the odd blocks' borders
	long long fallbacks[OD_POOL_MAX_THREADS];
} od_SweepJob;

// One particle's update on one thread, in nanoseconds: the pool's measure of a sweep's work (docs/speed.md).
#define OD_SWEEP_NS 130.0

// sweepOrder[begin..end) batch by batch and run by run (sim.h); the polar decompositions that fell back to the SVD.
static long long od_SweepBatches(od_Sim* sim, int begin, int end, bool directions)
{
	long long fallbacks = 0;
	for (int k = begin; k < end;)
	{
		int count = sim->sweepBatch[k];
#ifdef OD_LOCAL_AVX2
		if (count > 0) // a batch (only where od_BatchWidth is 4): in the lanes of AVX2 registers, bit-identical
		{
			fallbacks += od_LocalAvx2_Batch(sim, sim->sweepOrder + k, count);
			k += count;
			continue;
		}
#endif
		for (int stop = k - count; k < stop; ++k) // a run
		{
			fallbacks += od_UpdateRotation(sim, sim->sweepOrder[k], directions);
		}
	}
	return fallbacks;
}

static void od_SweepRange(od_SweepJob* job, int begin, int end, int thread)
{
	job->fallbacks[thread] += od_SweepBatches(job->sim, begin, end, job->directions);
}

// Phase 1, task b: block b's interior, and its border when b is even. Phase 2, task t: block 2t + 1's border.
static void od_SweepTask(void* ctx, int task, int thread)
{
	od_SweepJob* job = ctx;
	const int* start = job->sim->sweepStart;
	if (job->odd)
	{
		od_SweepRange(job, start[4 * task + 3], start[4 * task + 4], thread);
	}
	else
	{
		od_SweepRange(job, start[2 * task], start[2 * task + (task % 2 ? 1 : 2)], thread);
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
	if (directions)
	{
		od_Directions_BeginLocal(sim);
	}
	if (od_SweepsSerially(sim))
	{
		sim->counters.polarFallbacks += od_SweepBatches(sim, 0, sim->graph->n, directions);
		return;
	}
	od_SweepJob job = { .sim = sim, .directions = directions };
	int blocks = od_Pool_Threads(sim->pool);
	const int* start = sim->sweepStart;
	int oddBorders = 0;
	for (int b = 1; b < blocks; b += 2)
	{
		oddBorders += start[2 * b + 2] - start[2 * b + 1];
	}
	od_Pool_Run(sim->pool, blocks, OD_SWEEP_NS * (start[2 * blocks] - oddBorders), od_SweepTask, &job);
	job.odd = true;
	od_Pool_Run(sim->pool, blocks / 2, OD_SWEEP_NS * oddBorders, od_SweepTask, &job);
	od_SweepRange(&job, start[2 * blocks], start[2 * blocks + 1], 0); // the far border
	for (int t = 0; t < blocks; ++t)
	{
		sim->counters.polarFallbacks += job.fallbacks[t];
	}
}

// A phase of `count` updates in `tasks` tasks (the longest `longest`) on the threads the pool gives it (one per
// OD_POOL_MIN_WORK of work, at least one, at most one per task), in updates.
static double od_PhaseTime(int count, int longest, int tasks)
{
	int threads = (int)(OD_SWEEP_NS * count / OD_POOL_MIN_WORK);
	threads = threads < tasks ? threads : tasks;
	threads = threads > 1 ? threads : 1;
	return longest > (double)count / threads ? longest : (double)count / threads;
}

void od_LocalStep_Span(const od_Sim* sim, double* serial, double* span)
{
	int n = sim->graph->n;
	*serial = *span = n;
	if (od_SweepsSerially(sim))
	{
		return;
	}
	int blocks = od_Pool_Threads(sim->pool);
	const int* start = sim->sweepStart;
	int first = 0, second = 0, oddBorders = 0; // the longest task of each phase
	for (int b = 0; b < blocks; ++b)
	{
		int task = start[2 * b + (b % 2 ? 1 : 2)] - start[2 * b];
		first = task > first ? task : first;
		int border = b % 2 ? start[2 * b + 2] - start[2 * b + 1] : 0;
		second = border > second ? border : second;
		oddBorders += border;
	}
	*span = od_PhaseTime(start[2 * blocks] - oddBorders, first, blocks) + od_PhaseTime(oddBorders, second, blocks / 2) +
			(n - start[2 * blocks]);
}
