// Position constraints (eq. 8): how they enter the local step (a term of C_i), the global matrix, the
// right side and the objective. The only file that holds their maths.
//
// With s_c = Σ_j w_j (R_j a_cj + x_j), a_cj = p̄_c - X̄_j, particle i gets
//   C_i += Σ_c w (t_c - s_c + R_i w_i a_ci)(w_i a_ci)ᵀ
//        = T_i - Σ_{j≠i} R_j P_ij - Σ_j x_j (Σ_c w w_i w_j a_ci)ᵀ,   T_i = Σ_c w w_i t_c a_ciᵀ,
// and row a of the right side gets Σ_c w w_a t_c - Σ_j R_j (Σ_c w w_a w_j a_cj); the matrix gets
// w w_a w_b per pair of a constraint's particles. Folding the constraints into the particle pairs they
// join makes the per-iteration cost proportional to the pairs (16 for a pinned end face of any number of
// vertices) instead of the constraints: a painted pin group of thousands of vertices costs what its
// handful of particles cost. The pair moments change only with the set; the target terms are rebuilt
// once per step when a target moved.
#include "position_constraints.h"

#include "buffer.h"
#include "core.h"
#include "goal.h"
#include "graph.h"
#include "math3.h"
#include "sim.h"

#include <stdlib.h>
#include <string.h>

#define OD_TERMS "position constraint terms"
#define OD_PAIR_DOUBLES 15

typedef struct od_PairEntry
{
	long long key; // i * n + j
	int slot, ki, kj;
} od_PairEntry;

static int od_ComparePairEntry(const void* a, const void* b)
{
	const od_PairEntry *x = a, *y = b;
	if (x->key != y->key)
	{
		return x->key < y->key ? -1 : 1;
	}
	if (x->slot != y->slot)
	{
		return x->slot < y->slot ? -1 : 1;
	}
	return x->ki != y->ki ? x->ki - y->ki : x->kj - y->kj;
}

void od_Positions_Current(const od_Constraint* c, const od_Graph* g, const od_State* s, double out[3])
{
	od_Vec3 p = od_V3Load(c->point), sum = od_V3(0, 0, 0);
	for (int k = 0; k < c->count; ++k)
	{
		int j = c->idx[k];
		od_Mat3 r = od_M3Load(s->R + 9 * j);
		od_Vec3 q = od_Add(od_M3MulV(&r, od_Sub(p, od_V3Load(g->centers + 3 * j))), od_V3Load(s->x + 3 * j));
		sum = od_MulAdd(sum, c->w[k], q);
	}
	od_V3Store(out, sum);
}

// Sorted (i, j, constraint) entries of every position constraint, accumulated into the pair rows.
od_Status od_Positions_Build(od_ConstraintSet* set, const od_Graph* g)
{
	size_t count = 0;
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		count += c->kind == OD_POSITION ? (size_t)c->count * (size_t)c->count : 0;
	}
	od_PairEntry* entries = od_Alloc(sizeof(od_PairEntry) * (count ? count : 1));
	if (!entries)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the %s", OD_TERMS);
	}
	size_t e = 0;
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		for (int a = 0; c->kind == OD_POSITION && a < c->count; ++a)
		{
			for (int b = 0; b < c->count; ++b)
			{
				entries[e++] = (od_PairEntry){ (long long)c->idx[a] * g->n + c->idx[b], s, a, b };
			}
		}
	}
	qsort(entries, count, sizeof *entries, od_ComparePairEntry);
	int pairs = 0;
	for (size_t k = 0; k < count; ++k)
	{
		pairs += k == 0 || entries[k].key != entries[k - 1].key;
	}
	od_Status status = od_Resize((void**)&set->pairCol, sizeof(int) * (size_t)pairs, OD_TERMS);
	if (status == OD_OK)
	{
		status = od_Resize((void**)&set->pairData, sizeof(double) * OD_PAIR_DOUBLES * (size_t)pairs, OD_TERMS);
	}
	if (status != OD_OK)
	{
		od_Free(entries);
		return status;
	}
	memset(set->pairStart, 0, sizeof(int) * ((size_t)g->n + 1));
	memset(set->pairData, 0, sizeof(double) * OD_PAIR_DOUBLES * (size_t)pairs);
	int p = -1;
	for (size_t k = 0; k < count; ++k)
	{
		const od_PairEntry* pe = entries + k;
		int i = (int)(pe->key / g->n), j = (int)(pe->key % g->n);
		if (k == 0 || pe->key != entries[k - 1].key)
		{
			set->pairCol[++p] = j;
			set->pairStart[i + 1]++;
		}
		const od_Constraint* c = set->items + pe->slot;
		double f = c->weight * c->w[pe->ki] * c->w[pe->kj];
		od_Vec3 ai = od_Sub(od_V3Load(c->point), od_V3Load(g->centers + 3 * i));
		od_Vec3 aj = od_Sub(od_V3Load(c->point), od_V3Load(g->centers + 3 * j));
		double* d = set->pairData + OD_PAIR_DOUBLES * p;
		od_Mat3 m = od_M3Load(d);
		od_M3AddOuter(&m, f, aj, ai);
		od_M3Store(d, &m);
		od_V3Store(d + 9, od_MulAdd(od_V3Load(d + 9), f, ai));
		od_V3Store(d + 12, od_MulAdd(od_V3Load(d + 12), f, aj));
	}
	for (int i = 0; i < g->n; ++i)
	{
		set->pairStart[i + 1] += set->pairStart[i];
	}
	od_Free(entries);
	return OD_OK;
}

void od_Positions_BuildTargets(od_ConstraintSet* set, const od_Graph* g)
{
	memset(set->targetMoment, 0, sizeof(double) * 12 * (size_t)g->n);
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		for (int k = 0; c->kind == OD_POSITION && k < c->count; ++k)
		{
			int i = c->idx[k];
			double f = c->weight * c->w[k];
			double* d = set->targetMoment + 12 * i;
			od_Mat3 m = od_M3Load(d);
			od_M3AddOuter(&m, f, od_V3Load(c->target), od_Sub(od_V3Load(c->point), od_V3Load(g->centers + 3 * i)));
			od_M3Store(d, &m);
			od_V3Store(d + 9, od_MulAdd(od_V3Load(d + 9), f, od_V3Load(c->target)));
		}
	}
}

void od_Positions_AddLocal(const od_Sim* sim, int i, od_Mat3* cmat)
{
	const od_ConstraintSet* set = &sim->constraints;
	const double* x = sim->state.x;
	if (set->pairStart[i] != set->pairStart[i + 1])
	{
		od_Mat3 t = od_M3Load(set->targetMoment + 12 * i);
		od_M3AddScaled(cmat, 1.0, &t);
		for (int p = set->pairStart[i]; p < set->pairStart[i + 1]; ++p)
		{
			int j = set->pairCol[p];
			const double* d = set->pairData + OD_PAIR_DOUBLES * p;
			if (j != i)
			{
				od_Mat3 rj = od_M3Load(sim->state.R + 9 * j), m = od_M3Load(d);
				od_Mat3 rm = od_M3Mul(&rj, &m);
				od_M3AddScaled(cmat, -1.0, &rm);
			}
			od_M3AddOuter(cmat, -1.0, od_V3Load(x + 3 * j), od_V3Load(d + 9));
		}
	}
}

// Row a of the right side: Σ_c w w_a t_c - Σ_j R_j (Σ_c w w_a w_j a_cj).
od_Vec3 od_Positions_RhsRow(const od_Sim* sim, int a)
{
	const od_ConstraintSet* set = &sim->constraints;
	if (set->pairStart[a] == set->pairStart[a + 1])
	{
		return od_V3(0, 0, 0);
	}
	od_Vec3 f = od_V3Load(set->targetMoment + 12 * a + 9);
	for (int p = set->pairStart[a]; p < set->pairStart[a + 1]; ++p)
	{
		od_Mat3 rj = od_M3Load(sim->state.R + 9 * set->pairCol[p]);
		f = od_Sub(f, od_M3MulV(&rj, od_V3Load(set->pairData + OD_PAIR_DOUBLES * p + 12)));
	}
	return f;
}

size_t od_Positions_EntryCount(const od_ConstraintSet* set)
{
	size_t entries = 0;
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		entries += c->kind == OD_POSITION ? (size_t)c->count * (size_t)(c->count + 1) / 2 : 0;
	}
	return entries;
}

void od_Positions_FillMatrix(const od_ConstraintSet* set, od_EntryFn* push, void* context)
{
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		for (int a = 0; c->kind == OD_POSITION && a < c->count; ++a)
		{
			for (int b = a; b < c->count; ++b)
			{
				push(context, c->idx[a], c->idx[b], c->weight * c->w[a] * c->w[b]);
			}
		}
	}
}

double od_Positions_MaxWeight(const od_ConstraintSet* set)
{
	double most = 0.0;
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		most = c->kind == OD_POSITION && c->weight > most ? c->weight : most;
	}
	return most;
}

// Adds each position constraint's -w w_a e to the residual r, with e = Σ_b w_b (R_b (p̄ - X̄_b) + x_b - t)
// (the skinning weights sum to 1), so that a constraint's rounding stays in its own, stiff direction.
void od_Positions_AddResidual(const od_Sim* sim, double* r)
{
	const od_Graph* g = sim->graph;
	const od_State* st = &sim->state;
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
			od_V3Store(r + 3 * c->idx[a], od_MulAdd(od_V3Load(r + 3 * c->idx[a]), -c->weight * c->w[a], off));
		}
	}
}

double od_Positions_Energy(const od_Sim* sim)
{
	const od_ConstraintSet* set = &sim->constraints;
	double e = 0.0;
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		if (c->kind == OD_POSITION)
		{
			double q[3];
			od_Positions_Current(c, sim->graph, &sim->state, q);
			od_Vec3 d = od_Sub(od_V3Load(q), od_V3Load(c->target));
			e += 0.5 * c->weight * od_Dot(d, d);
		}
	}
	return e;
}

// Whether a goal holds some particle of the piece.
static bool od_GoalHolds(const od_Sim* sim, int piece)
{
	for (int i = 0; i < sim->graph->n; ++i)
	{
		if (sim->graph->piece[i] == piece && od_Goals_Hold(sim, i))
		{
			return true;
		}
	}
	return false;
}

// A static pose is defined only when every connected piece has a position constraint (or a goal).
od_Status od_Positions_CheckPinned(const od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	const od_ConstraintSet* set = &sim->constraints;
	if (set->positionCount == 0 && !sim->goals.omega2)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "solve_static needs at least one position constraint");
	}
	for (int piece = 0; piece < g->pieceCount; ++piece)
	{
		bool pinned = od_GoalHolds(sim, piece);
		for (int s = 0; s < set->count && !pinned; ++s)
		{
			const od_Constraint* c = set->items + s;
			for (int k = 0; k < c->count && !pinned; ++k)
			{
				pinned = c->kind == OD_POSITION && c->w[k] > 0.0 && g->piece[c->idx[k]] == piece;
			}
		}
		if (!pinned)
		{
			return od_Fail(OD_ERROR_ARGUMENT,
						   "solve_static: connected piece %d of the graph has no position constraint, so its pose "
						   "is undetermined",
						   piece);
		}
	}
	return OD_OK;
}
