// The global step: best centres with the rotations held fixed (eqs. 6, 7 and 14, METHOD.md).
//
// ∂E/∂x = 0 is one n x n sparse SPD system with three right-hand sides (x, y, z share the matrix):
//   Σ_j k (v_i + v_j)(x_i - x_j) + (m_i/h²) x_i + Σ_c w_c w_a (Σ_b w_b x_b)
//     = Σ_j k (v_j R_i + v_i R_j)(X̄_i - X̄_j) + (m_i/h²) y_i + Σ_c w_c w_a (t_c - Σ_b w_b R_b (p̄_c - X̄_b)),
// with each elastic v_i taken as s_i v_i under a stiffness scale s (od_ElasticScale) and each edge's terms weighted
// by its link weight w_ij (od_LinkWeight).
// With goals carrying the rest, X̄_i - X̄_j is the goal shape's, seen from i's goal frame in the R_i term and from
// j's in the R_j term (goal.c); the matrix is the same.
// Static poses drop the mass term and put gravity m_i g on the right. The matrix depends only on the
// rest graph, k, its scale, ρ, h and the constraint weights, so it is analysed and factored by CHOLMOD once per change
// of those (counted in od_SimCounters: the solver keeps the inputs it factored, od_MatrixKey, and compares
// them with the simulation's before each solve; nothing else invalidates it) and every iteration only assembles the right side and substitutes
// (cholesky.c, which keeps the factor in its own layout and may split the substitution over threads).
#include "global_solve.h"

#include "cholesky.h"
#include "clock.h"
#include "core.h"
#include "energy.h"
#include "goal.h"
#include "local_step.h"
#include "math3.h"
#include "position_constraints.h"

#include <cholmod.h>
#include <string.h>

static od_Status od_GlobalSolve(od_Sim* sim);

// What the factored matrix was made of: a solve refactors when any differs from the simulation's.
typedef struct od_MatrixKey
{
	unsigned constraints; // od_ConstraintSet.matrixVersion
	unsigned goals;       // od_Goals.version
	unsigned scale;       // od_Sim.stiffnessVersion
	double stiffness, density, dt; // density and dt 0 for static poses (no mass term)
	int factorization, threads;
} od_MatrixKey;

struct od_GlobalSolver
{
	cholmod_common common;
	od_Cholesky* factor;
	double* rhs; // n rows of (x, y, z)
	bool valid;  // a factor of the matrix that key describes
	od_MatrixKey key;
	bool refine; // solve for a correction from the residual instead (od_NeedsCorrection, od_FillResidual)
};

od_Status od_GlobalSolver_Create(od_GlobalSolver** out)
{
	od_GlobalSolver* s = od_AllocZero(1, sizeof *s);
	if (!s)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory creating the global solver");
	}
	cholmod_start(&s->common);
	s->common.print = 0;
	s->common.nmethods = 1;
	s->common.supernodal = CHOLMOD_AUTO;
	// Auto: supernodal when the factorization's flops per entry of L pass 400. Measured on beam lattices
	// (scripts/bench scale): 10,000 particles (158 flops per entry) factor 2.2x faster simplicial, 100,000
	// (994) 1.5x faster supernodal; CHOLMOD's default switch, 40, chose supernodal for both. The substitution
	// is the same either way (cholesky.c).
	s->common.supernodal_switch = 400.0;
	*out = s;
	return OD_OK;
}

static void od_FreeFactor(od_GlobalSolver* s)
{
	od_Cholesky_Destroy(s->factor);
	od_Free(s->rhs);
	s->factor = NULL;
	s->rhs = NULL;
	s->valid = false;
}

void od_GlobalSolver_Destroy(od_GlobalSolver* s)
{
	if (!s)
	{
		return;
	}
	od_FreeFactor(s);
	cholmod_finish(&s->common);
	od_Free(s);
}

static od_MatrixKey od_KeyOf(const od_Sim* sim)
{
	bool dynamic = sim->mode == OD_DYNAMIC;
	return (od_MatrixKey){
		.constraints = sim->constraints.matrixVersion,
		.goals = sim->goals.version,
		.scale = sim->stiffnessVersion,
		.stiffness = sim->def.stiffness,
		.density = dynamic ? sim->def.density : 0.0,
		.dt = dynamic ? sim->def.dt : 0.0,
		.factorization = sim->solverDef.factorization,
		.threads = sim->solverDef.threads,
	};
}

static bool od_SameKey(const od_MatrixKey* a, const od_MatrixKey* b)
{
	return a->constraints == b->constraints && a->goals == b->goals && a->scale == b->scale &&
		   a->stiffness == b->stiffness && a->density == b->density && a->dt == b->dt &&
		   a->factorization == b->factorization && a->threads == b->threads;
}

static size_t od_EntryCount(const od_Sim* sim)
{
	return (size_t)sim->graph->n + 3 * (size_t)sim->graph->edgeCount + od_Positions_EntryCount(&sim->constraints);
}

static void od_PushEntry(void* context, int row, int col, double value)
{
	cholmod_triplet* t = context;
	int* ti = t->i;
	int* tj = t->j;
	double* tx = t->x;
	size_t k = t->nnz++;
	ti[k] = row < col ? row : col; // upper triangle (stype > 0)
	tj[k] = row < col ? col : row;
	tx[k] = value;
}

static void od_FillMatrix(const od_Sim* sim, cholmod_triplet* t)
{
	const od_Graph* g = sim->graph;
	const double* u = od_ElasticVolumes(sim);
	double k = sim->def.stiffness, rho = sim->def.density, h = sim->def.dt;
	for (int i = 0; i < g->n; ++i)
	{
		double diag = (sim->mode == OD_DYNAMIC ? rho * g->volumes[i] / (h * h) : 0.0) + od_Goals_Diagonal(sim, i);
		od_PushEntry(t, i, i, diag);
	}
	const double* r = od_LinkSoftnessInUse(sim);
	for (int e = 0; e < g->edgeCount; ++e)
	{
		int a = g->edges[2 * e], b = g->edges[2 * e + 1];
		double kab = k * (od_SofterEnd(r, a, b) * (u[a] + u[b])); // w_ab (u_a + u_b), as od_EdgeVolume
		od_PushEntry(t, a, a, kab);
		od_PushEntry(t, b, b, kab);
		od_PushEntry(t, a, b, -kab);
	}
	od_Positions_FillMatrix(&sim->constraints, od_PushEntry, t);
}

// When some terms of the matrix dwarf others, the assembled right side loses the small ones: constraint
// weights far above the elastic terms (k times the mean volume; the default weight is 1e3 of them) round a
// pin's w t to about ±200 N at 1e12, and a step stiff against its inertia (k Σ_j (v_i + v_j) h² far above
// ρ v_i) rounds k v R (X̄_i - X̄_j) against m y / h². The error lands outside the stiff directions, in the
// soft ones, and global steps raise the energy (measured: the bar with 1e12-weight pins at both ends came
// out 2e-5 m and 3.5e-3 J off the exact minimiser; a collapsed 4x4x4 lattice at k = 1e12 ρ, h = 1/60 came to
// rest at 1e-10 J with rises of 1e-11 J). Such scenes solve instead for the correction to the current
// centres from the residual summed term by term (od_FillResidual): the same one back-substitution, exact to
// round-off (the bar with heavy pins: 3e-15 J off a 50-digit solve, as close as doubles get; the lattice:
// rises below 1e-4 of round-off).
// Only its constraint terms cost more, per constraint instead of per particle pair, so the paper's scenes,
// far below both limits (the bar: 1e3 elastic units, a stiffness ratio of 1.1e3), keep the right side.
#define OD_HEAVY_WEIGHT 1e8
#define OD_STIFF_STEP 3e3

static bool od_NeedsCorrection(const od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	const od_SimDef* d = &sim->def;
	const double* u = od_ElasticVolumes(sim);
	double volume = 0.0;
	for (int i = 0; i < g->n; ++i)
	{
		double elastic = 0.0;
		for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
		{
			elastic += od_EdgeVolume(sim, u, i, e);
		}
		double inertia = d->density * g->volumes[i] / (d->dt * d->dt);
		if (sim->mode == OD_DYNAMIC && d->stiffness * elastic > OD_STIFF_STEP * inertia)
		{
			return true;
		}
		volume += g->volumes[i];
	}
	return od_Positions_MaxWeight(&sim->constraints) > OD_HEAVY_WEIGHT * d->stiffness * volume / g->n;
}

static od_Status od_CheckFactor(const cholmod_factor* factor, const cholmod_common* cc)
{
	if (!factor || cc->status < CHOLMOD_OK)
	{
		return cc->status == CHOLMOD_OUT_OF_MEMORY ? od_Fail(OD_ERROR_MEMORY, "out of memory factoring the global matrix")
												   : od_Fail(OD_ERROR_INTERNAL, "CHOLMOD failed (status %d)", cc->status);
	}
	if (cc->status == CHOLMOD_NOT_POSDEF)
	{
		return od_Fail(OD_ERROR_SINGULAR,
					   "the global matrix is not positive definite (pivot %d): a piece of the graph is unconstrained "
					   "or the parameters are degenerate",
					   (int)factor->minor);
	}
	return OD_OK;
}

#define OD_METIS_PARTICLES 20000

// The symbolic analysis. METIS's nested dissection when threads share the substitution (its balanced
// elimination tree splits between them, cholesky.c) or the graph is large: on the beam lattices its factor has
// the fill of AMD's at 10,000 particles but 38 % less at 100,000 (2.4e7 entries against 3.8e7, 2.7x fewer
// flops), for 0.7 s of analysis against 0.07. Else AMD, whose analysis is 5x cheaper and is paid again on every
// change of stiffness, step or weights: small graphs on one thread, and graphs whose AMD factor is too small to
// split on any thread count (OD_CHOLESKY_SPLIT_ENTRIES; with METIS there the 100-particle step on 2 threads
// was 1.05x the wall time of one thread's, its substitution 1.09x). AMD if METIS is not built in.
static cholmod_factor* od_Analyze(cholmod_sparse* a, cholmod_common* cc, int n, int threads)
{
	bool large = n >= OD_METIS_PARTICLES;
	cc->method[0].ordering = large ? CHOLMOD_METIS : CHOLMOD_AMD;
	cholmod_factor* factor = cholmod_analyze(a, cc);
	if (factor && !large && threads > 1 && cc->lnz >= OD_CHOLESKY_SPLIT_ENTRIES)
	{
		cc->method[0].ordering = CHOLMOD_METIS;
		cholmod_factor* split = cholmod_analyze(a, cc);
		if (!split && cc->status == CHOLMOD_NOT_INSTALLED)
		{
			cc->status = CHOLMOD_OK; // AMD's stays
			return factor;
		}
		cholmod_free_factor(&factor, cc);
		factor = split;
	}
	if (!factor && cc->status == CHOLMOD_NOT_INSTALLED)
	{
		cc->method[0].ordering = CHOLMOD_AMD;
		factor = cholmod_analyze(a, cc);
	}
	return factor;
}

static od_Status od_Factor(od_Sim* sim, od_GlobalSolver* s)
{
	int n = sim->graph->n;
	cholmod_common* cc = &s->common;
	static const int paths[3] = { CHOLMOD_AUTO, CHOLMOD_SIMPLICIAL, CHOLMOD_SUPERNODAL };
	cc->supernodal = paths[sim->solverDef.factorization];
	od_FreeFactor(s);
	size_t entries = od_EntryCount(sim);
	cholmod_triplet* t = cholmod_allocate_triplet((size_t)n, (size_t)n, entries, 1, CHOLMOD_REAL, cc);
	if (!t)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory assembling the global matrix (%zu entries)", entries);
	}
	od_FillMatrix(sim, t);
	s->refine = od_NeedsCorrection(sim);
	cholmod_sparse* a = cholmod_triplet_to_sparse(t, entries, cc);
	cholmod_free_triplet(&t, cc);
	if (!a)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory assembling the global matrix");
	}
	int threads = sim->pool ? od_Pool_Threads(sim->pool) : 1;
	double start = od_Clock();
	cholmod_factor* factor = od_Analyze(a, cc, n, threads);
	sim->counters.analyses++;
	double analyzed = od_Clock();
	sim->counters.analyzeSeconds += analyzed - start;
	if (factor)
	{
		cholmod_factorize(a, factor, cc);
		sim->counters.factorizations++;
	}
	cholmod_free_sparse(&a, cc);
	od_Status status = od_CheckFactor(factor, cc);
	if (status == OD_OK)
	{
		status = od_Cholesky_Create(factor, cc, threads, &s->factor);
	}
	sim->counters.factorSeconds += od_Clock() - analyzed;
	cholmod_free_factor(&factor, cc);
	s->rhs = status == OD_OK ? od_Alloc(sizeof(double) * 3 * (size_t)n) : NULL;
	if (status == OD_OK && !s->rhs)
	{
		status = od_Fail(OD_ERROR_MEMORY, "out of memory for the global solve");
	}
	if (status != OD_OK)
	{
		od_FreeFactor(s);
		return status;
	}
	s->valid = true;
	return OD_OK;
}

// X̄_i - X̄_j of directed edge e = (i, j), as particle i's term of the right side sees it (from) and as j's
// (to): the rest centres' difference for both, or with goals carrying the rest the goal shape's, in i's goal
// frame and in j's (goal.c).
static inline void od_EdgeOffsets(const double* rest, int e, const od_Vec3* ci, const double* cj, double from[3],
								  double to[3])
{
	if (rest)
	{
		memcpy(from, rest + 6 * e, sizeof(double) * 3);
		memcpy(to, rest + 6 * e + 3, sizeof(double) * 3);
		return;
	}
	from[0] = to[0] = ci->x - cj[0];
	from[1] = to[1] = ci->y - cj[1];
	from[2] = to[2] = ci->z - cj[2];
}

// The sums over particle i's edges of od_RhsRow, each weighted w_ij by the link weights w. Both are inlined at
// each call (OD_EDGE_INLINE), so that with w NULL (no link softness) the weight folds away: the loops of before,
// without a test and a product per edge, the same bits.
#define OD_EDGE_INLINE static inline __attribute__((always_inline))

// Σ_j w_ij R_j d, d = X̄_i - X̄_j as j's term sees it, R_j read in place (no copy of R_j: measured 1.1x faster on
// the Fig. 4 body).
OD_EDGE_INLINE od_Vec3 od_TurnedOffsets(const od_Sim* sim, int i, const od_Vec3* ci, const double* rest,
										const double* w)
{
	const od_Graph* g = sim->graph;
	const double* rot = sim->state.R;
	double t0 = 0.0, t1 = 0.0, t2 = 0.0;
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		int j = g->adj[e];
		const double* rj = rot + 9 * j;
		double b[3], d[3];
		od_EdgeOffsets(rest, e, ci, g->centers + 3 * j, b, d);
		double d0 = d[0], d1 = d[1], d2 = d[2], we = w ? w[e] : 1.0;
		t0 = t0 + we * (rj[0] * d0 + rj[1] * d1 + rj[2] * d2);
		t1 = t1 + we * (rj[3] * d0 + rj[4] * d1 + rj[5] * d2);
		t2 = t2 + we * (rj[6] * d0 + rj[7] * d1 + rj[8] * d2);
	}
	return od_V3(t0, t1, t2);
}

// Σ_j w_ij u_j (R_i b - (x_i - x_j)) + Σ_j w_ij u_i (R_j d - (x_i - x_j)), b and d = X̄_i - X̄_j in i's frame
// and in j's: the residual's edge terms, read in place like od_TurnedOffsets, the same operations as
// od_MulAdd(.., od_M3MulV(..)).
OD_EDGE_INLINE od_Vec3 od_ResidualEdges(const od_Sim* sim, int i, const od_Vec3* xi, const od_Vec3* ci,
										const od_Mat3* ri, const double* rest, const double* w)
{
	const od_Graph* g = sim->graph;
	const od_State* st = &sim->state;
	const double* u = od_ElasticVolumes(sim);
	const double* r = ri->m;
	double ui = u[i], a0 = 0.0, a1 = 0.0, a2 = 0.0, t0 = 0.0, t1 = 0.0, t2 = 0.0;
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		int j = g->adj[e];
		double we = w ? w[e] : 1.0, uj = we * u[j], wi = we * ui;
		const double* rj = st->R + 9 * j;
		const double* xj = st->x + 3 * j;
		double b[3], d[3];
		od_EdgeOffsets(rest, e, ci, g->centers + 3 * j, b, d);
		double x0 = xi->x - xj[0], x1 = xi->y - xj[1], x2 = xi->z - xj[2];
		a0 = a0 + uj * ((r[0] * b[0] + r[1] * b[1] + r[2] * b[2]) - x0);
		a1 = a1 + uj * ((r[3] * b[0] + r[4] * b[1] + r[5] * b[2]) - x1);
		a2 = a2 + uj * ((r[6] * b[0] + r[7] * b[1] + r[8] * b[2]) - x2);
		t0 = t0 + wi * ((rj[0] * d[0] + rj[1] * d[1] + rj[2] * d[2]) - x0);
		t1 = t1 + wi * ((rj[3] * d[0] + rj[4] * d[1] + rj[5] * d[2]) - x1);
		t2 = t2 + wi * ((rj[6] * d[0] + rj[7] * d[1] + rj[8] * d[2]) - x2);
	}
	return od_Add(od_V3(a0, a1, a2), od_V3(t0, t1, t2));
}

// Row i of the right side b: the inertia (m/h²) y_i or gravity m_i g, the constraints' row
// (od_Positions_RhsRow) and per neighbour j, with d = X̄_i - X̄_j, u = s v the scaled volumes and w the link
// weights, k w_ij u_j R_i d + k w_ij u_i R_j d, gathered as R_i (k Σ_j w_ij u_j d) + k u_i Σ_j w_ij R_j d, the
// first sum kept per particle (rowArm, local_step.c). With `residual`, row i of b - A x instead, each term taken
// against the current centres before it is summed so that nothing large cancels: (m/h²)(y_i - x_i) and
// k w_ij u_j (R_i d - (x_i - x_j)) + k w_ij u_i (R_j d - (x_i - x_j)); the constraints' part is added apart
// (od_FillResidual). Rows are independent, so threads split them.
static od_Vec3 od_RhsRow(const od_Sim* sim, int i, bool residual)
{
	const od_Graph* g = sim->graph;
	const od_State* st = &sim->state;
	const double* u = od_ElasticVolumes(sim);
	double k = sim->def.stiffness, h = sim->def.dt, vi = g->volumes[i], ui = u[i];
	od_Vec3 xi = od_V3Load(st->x + 3 * i), ci = od_V3Load(g->centers + 3 * i);
	od_Mat3 ri = od_M3Load(st->R + 9 * i);
	const double* rest = sim->goals.edgeRest; // NULL unless the goals carry the rest
	const double* w = sim->linkWeight;        // NULL without a link softness (OD_EDGE_INLINE)
	od_Vec3 f;
	if (residual)
	{
		f = od_Scale(k, w ? od_ResidualEdges(sim, i, &xi, &ci, &ri, rest, w)
						  : od_ResidualEdges(sim, i, &xi, &ci, &ri, rest, NULL));
	}
	else
	{
		od_Vec3 turned = w ? od_TurnedOffsets(sim, i, &ci, rest, w) : od_TurnedOffsets(sim, i, &ci, rest, NULL);
		f = od_MulAdd(od_M3MulV(&ri, od_V3Load(sim->rowArm + 3 * i)), k * ui, turned);
	}
	double m = sim->def.density * vi;
	if (sim->mode == OD_DYNAMIC)
	{
		od_Vec3 y = od_V3Load(sim->y + 3 * i);
		f = od_MulAdd(f, m / (h * h), residual ? od_Sub(y, xi) : y);
	}
	else
	{
		f = od_MulAdd(f, m, od_V3Load(sim->def.gravity));
	}
	if (sim->goals.omega2)
	{
		f = od_Add(f, od_Goals_RhsRow(sim, i, residual));
	}
	if (sim->contactForce && sim->mode == OD_DYNAMIC) // particle contact inside the iterations (body_contact.c)
	{
		f = od_Add(f, od_V3Load(sim->contactForce + 3 * i));
	}
	if (sim->surface.force && sim->mode == OD_DYNAMIC) // the floor and colliders inside the iterations (surface_contact.c)
	{
		f = od_Add(f, od_V3Load(sim->surface.force + 3 * i));
	}
	return residual ? f : od_Add(f, od_Positions_RhsRow(sim, i));
}

#define OD_RHS_CHUNK 256
#define OD_RHS_NS 60.0 // one row on one thread, in nanoseconds: the pool's measure of the work (docs/speed.md)

typedef struct od_RhsJob
{
	const od_Sim* sim;
	double* b;
	bool residual;
} od_RhsJob;

static void od_RhsTask(void* ctx, int task, int thread)
{
	(void)thread;
	const od_RhsJob* job = ctx;
	int begin = task * OD_RHS_CHUNK, end = begin + OD_RHS_CHUNK;
	end = end < job->sim->graph->n ? end : job->sim->graph->n;
	for (int i = begin; i < end; ++i)
	{
		od_V3Store(job->b + 3 * i, od_RhsRow(job->sim, i, job->residual));
	}
}

static void od_FillRows(const od_Sim* sim, double* b, bool residual)
{
	od_RhsJob job = { sim, b, residual };
	int tasks = (sim->graph->n + OD_RHS_CHUNK - 1) / OD_RHS_CHUNK;
	if (sim->pool)
	{
		od_Pool_Run(sim->pool, tasks, OD_RHS_NS * sim->graph->n, od_RhsTask, &job);
		return;
	}
	for (int t = 0; t < tasks; ++t)
	{
		od_RhsTask(&job, t, 0);
	}
}

// b - A x at the current centres (-∂E/∂x), summed from small residuals so that nothing large cancels:
// od_RhsRow's and each position constraint's (od_Positions_AddResidual).
static void od_FillResidual(const od_Sim* sim, double* r)
{
	od_FillRows(sim, r, true);
	od_Positions_AddResidual(sim, r);
}

// The right side's rows on one thread and on the longest of the threads the pool gives it (one per
// OD_POOL_MIN_WORK, chunks dealt evenly), then the substitution's work (od_Cholesky_Span), in nanoseconds by the
// pool's per-item costs.
static void od_GlobalSpan(const od_Sim* sim, double* serial, double* span)
{
	int n = sim->graph->n, threads = sim->pool ? od_Pool_Threads(sim->pool) : 1;
	int tasks = (n + OD_RHS_CHUNK - 1) / OD_RHS_CHUNK, filled = (int)(OD_RHS_NS * n / OD_POOL_MIN_WORK);
	threads = threads < filled ? threads : filled > 1 ? filled : 1;
	int rows = (tasks + threads - 1) / threads * OD_RHS_CHUNK;
	double solveSerial, solveSpan;
	od_Cholesky_Span(sim->solver[sim->mode]->factor, &solveSerial, &solveSpan);
	*serial = OD_RHS_NS * n + OD_ENTRY_NS * solveSerial;
	*span = OD_RHS_NS * (rows < n ? rows : n) + OD_ENTRY_NS * solveSpan;
}

od_ThreadBound od_Sim_GetThreadBound(const od_Sim* sim)
{
	od_ThreadBound out = { sim->pool ? od_Pool_Threads(sim->pool) : 1, 0.0, 0.0 };
	double serial, span;
	if (!sim->pool || !sim->partitionDirty) // the partition is made by a step
	{
		od_LocalStep_Span(sim, &serial, &span);
		out.local = serial / span;
	}
	if (sim->solver[sim->mode]->valid)
	{
		od_GlobalSpan(sim, &serial, &span);
		out.global = serial / span;
	}
	return out;
}

od_Status od_GlobalStep(od_Sim* sim)
{
	double start = od_Clock();
	od_Status status = od_GlobalSolve(sim);
	sim->counters.globalSeconds += od_Clock() - start;
	return status;
}

void od_GlobalResponse(od_Sim* sim, double* b)
{
	od_Cholesky_Solve(sim->solver[sim->mode]->factor, sim->pool, b, b);
}

static od_Status od_GlobalSolve(od_Sim* sim)
{
	od_GlobalSolver* s = sim->solver[sim->mode];
	od_MatrixKey key = od_KeyOf(sim);
	if (!s->valid || !od_SameKey(&s->key, &key))
	{
		s->key = key;
		od_Status status = od_Factor(sim, s);
		if (status != OD_OK)
		{
			return status;
		}
	}
	int n = sim->graph->n;
	if (s->refine)
	{
		od_FillResidual(sim, s->rhs);
	}
	else
	{
		od_FillRows(sim, s->rhs, false);
	}
	double* pos = sim->state.x;
	if (!s->refine)
	{
		od_Cholesky_Solve(s->factor, sim->pool, s->rhs, pos);
	}
	else // a correction to the current centres
	{
		od_Cholesky_Solve(s->factor, sim->pool, s->rhs, s->rhs);
		for (int i = 0; i < 3 * n; ++i)
		{
			pos[i] += s->rhs[i];
		}
	}
	sim->counters.solves++;
	return OD_OK;
}
