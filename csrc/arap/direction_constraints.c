// Direction constraints (eq. 10): how they enter the local step and the objective. The only file that
// holds their maths. They are nonlinear in the rotations (the length l of the skinned direction is held
// fixed during a local step), so they stay per constraint, with their skinned direction updated
// incrementally as rotations change; they never enter the global matrix nor the right side, so neither
// their weights nor their targets refactor anything.
#include "direction_constraints.h"

#include "buffer.h"
#include "core.h"
#include "math3.h"
#include "sim.h"

#include <string.h>

#define OD_TERMS "direction constraint terms"

void od_Directions_Current(const od_Constraint* c, const od_State* s, double out[3], double* length)
{
	od_Vec3 n = od_V3Load(c->direction), sum = od_V3(0, 0, 0);
	for (int k = 0; k < c->count; ++k)
	{
		od_Mat3 r = od_M3Load(s->R + 9 * c->idx[k]);
		sum = od_MulAdd(sum, c->w[k], od_M3MulV(&r, n));
	}
	*length = od_Length(sum);
	od_V3Store(out, sum);
}

// Per particle, the direction constraints touching it (CSR by a counting sort).
od_Status od_Directions_Build(od_ConstraintSet* set, const od_Graph* g)
{
	int n = g->n, entries = 0;
	for (int s = 0; s < set->count; ++s)
	{
		entries += set->items[s].kind == OD_DIRECTION ? set->items[s].count : 0;
	}
	od_Status status = od_Resize((void**)&set->touchSlot, sizeof(int) * (size_t)entries, OD_TERMS);
	if (status == OD_OK)
	{
		status = od_Resize((void**)&set->touchArm, sizeof(double) * 3 * (size_t)entries, OD_TERMS);
	}
	if (status == OD_OK)
	{
		status = od_Resize((void**)&set->current, sizeof(double) * 3 * (size_t)set->count, OD_TERMS);
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

void od_Directions_BeginLocal(od_Sim* sim)
{
	od_ConstraintSet* set = &sim->constraints;
	for (int s = 0; s < set->count; ++s)
	{
		double length;
		if (set->items[s].kind == OD_DIRECTION)
		{
			od_Directions_Current(set->items + s, &sim->state, set->current + 3 * s, &length);
		}
	}
}

void od_Directions_AddLocal(const od_Sim* sim, int i, const od_Mat3* ri, od_Mat3* cmat)
{
	const od_ConstraintSet* set = &sim->constraints;
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

void od_Directions_RotationChanged(od_Sim* sim, int i, const od_Mat3* before, const od_Mat3* after)
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

double od_Directions_Energy(const od_Sim* sim)
{
	const od_ConstraintSet* set = &sim->constraints;
	double e = 0.0;
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		if (c->kind == OD_DIRECTION)
		{
			double q[3], l;
			od_Directions_Current(c, &sim->state, q, &l);
			od_Vec3 d = od_Sub(od_Scale(l > 0.0 ? 1.0 / l : 1.0, od_V3Load(q)), od_V3Load(c->target));
			e += 0.5 * c->weight * od_Dot(d, d);
		}
	}
	return e;
}
