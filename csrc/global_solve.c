// The global step: best centres with the rotations held fixed (eqs. 6, 7 and 14, METHOD.md).
//
// ∂E/∂x = 0 is one n x n sparse SPD system with three right-hand sides (x, y, z share the matrix):
//   Σ_j k (v_i + v_j)(x_i - x_j) + (m_i/h²) x_i + Σ_c w_c w_a (Σ_b w_b x_b)
//     = Σ_j k (v_j R_i + v_i R_j)(X̄_i - X̄_j) + (m_i/h²) y_i + Σ_c w_c w_a (t_c - Σ_b w_b R_b (p̄_c - X̄_b)).
// Static poses drop the mass term and put gravity m_i g on the right. The matrix depends only on the
// rest graph, k, ρ, h and the constraint weights, so it is analysed and factored by CHOLMOD once per change
// of those (counted in od_SimCounters) and every iteration only assembles the right side and back-substitutes.
#include "core.h"
#include "math3.h"
#include "sim.h"

#include <cholmod.h>
#include <string.h>
#include <time.h>

static od_Status od_GlobalSolve(od_Sim* sim);

struct od_GlobalSolver
{
	cholmod_common common;
	cholmod_factor* factor;
	cholmod_dense* rhs; // n x 3, column major
	cholmod_dense* x;   // solve2 workspace, reused so that solves do not allocate
	cholmod_dense* y;
	cholmod_dense* e;
	bool valid;
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
	s->common.method[0].ordering = CHOLMOD_AMD;
	s->common.supernodal = CHOLMOD_AUTO;
	*out = s;
	return OD_OK;
}

static void od_FreeFactor(od_GlobalSolver* s)
{
	cholmod_free_factor(&s->factor, &s->common);
	cholmod_free_dense(&s->rhs, &s->common);
	cholmod_free_dense(&s->x, &s->common);
	cholmod_free_dense(&s->y, &s->common);
	cholmod_free_dense(&s->e, &s->common);
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

void od_GlobalSolver_Invalidate(od_GlobalSolver* s)
{
	if (s)
	{
		s->valid = false;
	}
}

static size_t od_EntryCount(const od_Sim* sim)
{
	size_t entries = (size_t)sim->graph->n + 3 * (size_t)sim->graph->edgeCount;
	for (int s = 0; s < sim->constraints.count; ++s)
	{
		const od_Constraint* c = sim->constraints.items + s;
		if (c->kind == OD_POSITION)
		{
			entries += (size_t)c->count * (size_t)(c->count + 1) / 2;
		}
	}
	return entries;
}

static void od_PushEntry(cholmod_triplet* t, int row, int col, double value)
{
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
	double k = sim->def.stiffness, rho = sim->def.density, h = sim->def.dt;
	for (int i = 0; i < g->n; ++i)
	{
		double diag = sim->mode == OD_DYNAMIC ? rho * g->volumes[i] / (h * h) : 0.0;
		od_PushEntry(t, i, i, diag);
	}
	for (int e = 0; e < g->edgeCount; ++e)
	{
		int a = g->edges[2 * e], b = g->edges[2 * e + 1];
		double kab = k * (g->volumes[a] + g->volumes[b]);
		od_PushEntry(t, a, a, kab);
		od_PushEntry(t, b, b, kab);
		od_PushEntry(t, a, b, -kab);
	}
	for (int s = 0; s < sim->constraints.count; ++s)
	{
		const od_Constraint* c = sim->constraints.items + s;
		if (c->kind != OD_POSITION)
		{
			continue;
		}
		for (int a = 0; a < c->count; ++a)
		{
			for (int b = a; b < c->count; ++b)
			{
				od_PushEntry(t, c->idx[a], c->idx[b], c->weight * c->w[a] * c->w[b]);
			}
		}
	}
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
	double volume = 0.0;
	for (int i = 0; i < g->n; ++i)
	{
		double elastic = 0.0;
		for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
		{
			elastic += g->volumes[i] + g->volumes[g->adj[e]];
		}
		double inertia = d->density * g->volumes[i] / (d->dt * d->dt);
		if (sim->mode == OD_DYNAMIC && d->stiffness * elastic > OD_STIFF_STEP * inertia)
		{
			return true;
		}
		volume += g->volumes[i];
	}
	double limit = OD_HEAVY_WEIGHT * d->stiffness * volume / g->n;
	for (int s = 0; s < sim->constraints.count; ++s)
	{
		const od_Constraint* c = sim->constraints.items + s;
		if (c->kind == OD_POSITION && c->weight > limit)
		{
			return true;
		}
	}
	return false;
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
	s->factor = cholmod_analyze(a, cc);
	sim->counters.analyses++;
	if (s->factor)
	{
		cholmod_factorize(a, s->factor, cc);
		sim->counters.factorizations++;
	}
	cholmod_free_sparse(&a, cc);
	s->rhs = cholmod_zeros((size_t)n, 3, CHOLMOD_REAL, cc);
	if (!s->factor || !s->rhs || cc->status < CHOLMOD_OK)
	{
		int status = cc->status;
		od_FreeFactor(s);
		return status == CHOLMOD_OUT_OF_MEMORY ? od_Fail(OD_ERROR_MEMORY, "out of memory factoring the global matrix")
											   : od_Fail(OD_ERROR_INTERNAL, "CHOLMOD failed (status %d)", status);
	}
	if (cc->status == CHOLMOD_NOT_POSDEF)
	{
		int minor = (int)s->factor->minor;
		od_FreeFactor(s);
		return od_Fail(OD_ERROR_SINGULAR,
					   "the global matrix is not positive definite (pivot %d): a piece of the graph is unconstrained "
					   "or the parameters are degenerate",
					   minor);
	}
	s->valid = true;
	return OD_OK;
}

static void od_AddRow(double* b, int n, int i, double sign, od_Vec3 f)
{
	b[i] += sign * f.x;
	b[i + n] += sign * f.y;
	b[i + 2 * n] += sign * f.z;
}

// The inertia (or gravity) and elastic terms of the right side b, or with `residual` of b - A x, each term
// taken against the current centres before it is summed: (m/h²)(y - x) and, per edge, with d = X̄_i - X̄_j,
// k v_j (R_i d - (x_i - x_j)) + k v_i (R_j d - (x_i - x_j)).
static void od_FillTerms(const od_Sim* sim, double* b, bool residual)
{
	const od_Graph* g = sim->graph;
	const od_State* st = &sim->state;
	int n = g->n;
	double k = sim->def.stiffness, rho = sim->def.density, h = sim->def.dt;
	od_Vec3 zero = od_V3(0, 0, 0);
	for (int i = 0; i < n; ++i)
	{
		double m = rho * g->volumes[i];
		od_Vec3 x = residual ? od_V3Load(st->x + 3 * i) : zero;
		od_Vec3 f = sim->mode == OD_DYNAMIC ? od_Scale(m / (h * h), od_Sub(od_V3Load(sim->y + 3 * i), x))
											: od_Scale(m, od_V3Load(sim->def.gravity));
		b[i] = b[i + n] = b[i + 2 * n] = 0.0;
		od_AddRow(b, n, i, 1.0, f);
	}
	for (int e = 0; e < g->edgeCount; ++e)
	{
		int i = g->edges[2 * e], j = g->edges[2 * e + 1];
		od_Mat3 ri = od_M3Load(st->R + 9 * i), rj = od_M3Load(st->R + 9 * j);
		od_Vec3 d = od_Sub(od_V3Load(g->centers + 3 * i), od_V3Load(g->centers + 3 * j));
		od_Vec3 dx = residual ? od_Sub(od_V3Load(st->x + 3 * i), od_V3Load(st->x + 3 * j)) : zero;
		od_Vec3 f = od_Add(od_Scale(k * g->volumes[j], od_Sub(od_M3MulV(&ri, d), dx)),
						   od_Scale(k * g->volumes[i], od_Sub(od_M3MulV(&rj, d), dx)));
		od_AddRow(b, n, i, 1.0, f);
		od_AddRow(b, n, j, -1.0, f);
	}
}

static void od_FillRhs(const od_Sim* sim, double* b)
{
	od_FillTerms(sim, b, false);
	od_Constraints_AddRhs(sim, b);
}

// b - A x at the current centres (-∂E/∂x), summed from small residuals so that nothing large cancels:
// od_FillTerms' and each position constraint's -w w_a e with e = Σ_b w_b (R_b (p̄ - X̄_b) + x_b - t) (the
// skinning weights sum to 1). A constraint's rounding then stays in its own, stiff direction.
static void od_FillResidual(const od_Sim* sim, double* r)
{
	const od_Graph* g = sim->graph;
	const od_State* st = &sim->state;
	int n = g->n;
	od_FillTerms(sim, r, true);
	for (int s = 0; s < sim->constraints.count; ++s)
	{
		const od_Constraint* c = sim->constraints.items + s;
		if (c->kind != OD_POSITION)
		{
			continue;
		}
		od_Vec3 p = od_V3Load(c->point), t = od_V3Load(c->target), off = od_V3(0, 0, 0);
		for (int a = 0; a < c->count; ++a)
		{
			int b = c->idx[a];
			od_Mat3 rb = od_M3Load(st->R + 9 * b);
			od_Vec3 arm = od_Sub(p, od_V3Load(g->centers + 3 * b));
			od_Vec3 q = od_Add(od_M3MulV(&rb, arm), od_Sub(od_V3Load(st->x + 3 * b), t));
			off = od_MulAdd(off, c->w[a], q);
		}
		for (int a = 0; a < c->count; ++a)
		{
			od_AddRow(r, n, c->idx[a], -c->weight * c->w[a], off);
		}
	}
}

static double od_Now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

od_Status od_GlobalStep(od_Sim* sim)
{
	double start = od_Now();
	od_Status status = od_GlobalSolve(sim);
	sim->counters.globalSeconds += od_Now() - start;
	return status;
}

double od_Clock(void)
{
	return od_Now();
}

static od_Status od_GlobalSolve(od_Sim* sim)
{
	od_GlobalSolver* s = sim->solver[sim->mode];
	if (!s->valid)
	{
		od_Status status = od_Factor(sim, s);
		if (status != OD_OK)
		{
			return status;
		}
	}
	int n = sim->graph->n;
	if (s->refine)
	{
		od_FillResidual(sim, s->rhs->x);
	}
	else
	{
		od_FillRhs(sim, s->rhs->x);
	}
	if (!cholmod_solve2(CHOLMOD_A, s->factor, s->rhs, NULL, &s->x, NULL, &s->y, &s->e, &s->common))
	{
		return od_Fail(OD_ERROR_INTERNAL, "CHOLMOD solve failed (status %d)", s->common.status);
	}
	sim->counters.solves++;
	const double* x = s->x->x;
	double* pos = sim->state.x;
	for (int i = 0; i < n; ++i) // the solution, or with refine a correction to the current centres
	{
		for (int c = 0; c < 3; ++c)
		{
			pos[3 * i + c] = (s->refine ? pos[3 * i + c] : 0.0) + x[i + c * n];
		}
	}
	return OD_OK;
}
