// How constraints enter the local step (a term of C_i) and the global step (a term of the right side).
//
// Position constraints (eq. 8): with s_c = Σ_j w_j (R_j a_cj + x_j), a_cj = p̄_c - X̄_j, particle i gets
//   C_i += Σ_c w (t_c - s_c + R_i w_i a_ci)(w_i a_ci)ᵀ
//        = T_i - Σ_{j≠i} R_j P_ij - Σ_j x_j (Σ_c w w_i w_j a_ci)ᵀ,   T_i = Σ_c w w_i t_c a_ciᵀ,
// and row a of the right side gets Σ_c w w_a t_c - Σ_j R_j (Σ_c w w_a w_j a_cj). Folding the constraints
// into the particle pairs they join makes the per-iteration cost proportional to the pairs (16 for a
// pinned end face of any number of vertices) instead of the constraints: a painted pin group of thousands
// of vertices costs what its handful of particles cost. The pair moments change only with the set; the
// target terms are rebuilt once per step when a target moved.
// Direction constraints (eq. 10) are nonlinear in the rotations (the length l is held fixed during a
// local step), so they stay per constraint, with their skinned direction updated incrementally as
// rotations change.
#include "core.h"
#include "math3.h"
#include "sim.h"

#include <stdlib.h>
#include <string.h>

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

static od_Status od_Reserve(void** p, size_t bytes)
{
	void* q = od_Realloc(*p, bytes ? bytes : 1);
	if (!q)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the constraint terms");
	}
	*p = q;
	return OD_OK;
}

// Sorted (i, j, constraint) entries of every position constraint, accumulated into the pair rows.
static od_Status od_BuildPairs(od_ConstraintSet* set, const od_Graph* g)
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
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the constraint terms");
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
	od_Status status = od_Reserve((void**)&set->pairCol, sizeof(int) * (size_t)pairs);
	if (status == OD_OK)
	{
		status = od_Reserve((void**)&set->pairData, sizeof(double) * OD_PAIR_DOUBLES * (size_t)pairs);
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

// Per particle, the direction constraints touching it (CSR by a counting sort).
static od_Status od_BuildDirectionIncidence(od_ConstraintSet* set, const od_Graph* g)
{
	int n = g->n, entries = 0;
	for (int s = 0; s < set->count; ++s)
	{
		entries += set->items[s].kind == OD_DIRECTION ? set->items[s].count : 0;
	}
	od_Status status = od_Reserve((void**)&set->touchSlot, sizeof(int) * (size_t)entries);
	if (status == OD_OK)
	{
		status = od_Reserve((void**)&set->touchArm, sizeof(double) * 3 * (size_t)entries);
	}
	if (status == OD_OK)
	{
		status = od_Reserve((void**)&set->current, sizeof(double) * 3 * (size_t)set->count);
	}
	if (status != OD_OK)
	{
		return status;
	}
	int* start = set->touchStart;
	memset(start, 0, sizeof(int) * ((size_t)n + 1));
	for (int s = 0; s < set->count; ++s)
	{
		for (int k = 0; set->items[s].kind == OD_DIRECTION && k < set->items[s].count; ++k)
		{
			start[set->items[s].idx[k] + 1]++;
		}
	}
	for (int i = 0; i < n; ++i)
	{
		start[i + 1] += start[i];
	}
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		for (int k = 0; c->kind == OD_DIRECTION && k < c->count; ++k)
		{
			int e = start[c->idx[k]]++;
			set->touchSlot[e] = s;
			od_V3Store(set->touchArm + 3 * e, od_Scale(c->w[k], od_V3Load(c->direction)));
		}
	}
	for (int i = n; i > 0; --i) // each start[i] now holds the end of block i; shift to block starts
	{
		start[i] = start[i - 1];
	}
	start[0] = 0;
	return OD_OK;
}

static void od_BuildTargets(od_ConstraintSet* set, const od_Graph* g)
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

// Rebuilds what the set's changes made stale; called at the start of every step or static solve.
od_Status od_Constraints_Prepare(od_Sim* sim)
{
	od_ConstraintSet* set = &sim->constraints;
	const od_Graph* g = sim->graph;
	od_Status status = OD_OK;
	if (!set->touchStart)
	{
		size_t rows = sizeof(int) * ((size_t)g->n + 1);
		status = od_Reserve((void**)&set->touchStart, rows);
		if (status == OD_OK)
		{
			status = od_Reserve((void**)&set->pairStart, rows);
		}
		if (status == OD_OK)
		{
			status = od_Reserve((void**)&set->targetMoment, sizeof(double) * 12 * (size_t)g->n);
		}
	}
	if (status == OD_OK && set->touchDirty)
	{
		status = od_BuildDirectionIncidence(set, g);
		if (status == OD_OK)
		{
			status = od_BuildPairs(set, g);
		}
		set->touchDirty = status != OD_OK;
	}
	if (status == OD_OK && set->targetsDirty)
	{
		od_BuildTargets(set, g);
		set->targetsDirty = false;
	}
	return status;
}

bool od_Constraints_Touches(const od_Sim* sim, int i)
{
	const od_ConstraintSet* set = &sim->constraints;
	return set->pairStart[i] != set->pairStart[i + 1] || set->touchStart[i] != set->touchStart[i + 1];
}

void od_Constraints_BeginLocal(od_Sim* sim)
{
	od_ConstraintSet* set = &sim->constraints;
	for (int s = 0; s < set->count; ++s)
	{
		double length;
		if (set->items[s].kind == OD_DIRECTION)
		{
			od_Constraints_CurrentDirection(set->items + s, &sim->state, set->current + 3 * s, &length);
		}
	}
}

void od_Constraints_AddLocal(const od_Sim* sim, int i, const od_Mat3* ri, od_Mat3* cmat)
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
	// Direction: w r r̄ᵀ with r̄ = (w_i / l) n̄, r = n - q / l + R_i r̄.
	for (int e = set->touchStart[i]; e < set->touchStart[i + 1]; ++e)
	{
		int slot = set->touchSlot[e];
		const od_Constraint* c = set->items + slot;
		od_Vec3 q = od_V3Load(set->current + 3 * slot);
		double l = od_Length(q);
		if (l < 1e-12)
		{
			continue;
		}
		od_Vec3 rbar = od_Scale(1.0 / l, od_V3Load(set->touchArm + 3 * e));
		od_Vec3 r = od_Add(od_Sub(od_V3Load(c->target), od_Scale(1.0 / l, q)), od_M3MulV(ri, rbar));
		od_M3AddOuter(cmat, c->weight, r, rbar);
	}
}

void od_Constraints_RotationChanged(od_Sim* sim, int i, const od_Mat3* before, const od_Mat3* after)
{
	od_ConstraintSet* set = &sim->constraints;
	if (set->touchStart[i] == set->touchStart[i + 1])
	{
		return;
	}
	od_Mat3 d = *after;
	od_M3AddScaled(&d, -1.0, before);
	for (int e = set->touchStart[i]; e < set->touchStart[i + 1]; ++e)
	{
		double* cur = set->current + 3 * set->touchSlot[e];
		od_V3Store(cur, od_Add(od_V3Load(cur), od_M3MulV(&d, od_V3Load(set->touchArm + 3 * e))));
	}
}

// Row a of the right side: Σ_c w w_a t_c - Σ_j R_j (Σ_c w w_a w_j a_cj).
od_Vec3 od_Constraints_RhsRow(const od_Sim* sim, int a)
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
