// Position and direction constraints (eqs. 8 and 10 of the paper) on rest-space points.
//
// A constraint is skinned like a mesh vertex: its point moves with the m nearest particles and the
// Sumner weights of METHOD.md. The set is stored densely (slots) with an id -> slot table, so removal
// is O(1) and ids stay valid. Adding or removing a constraint or changing a weight invalidates the
// factorizations; moving a target does not (it only changes right-hand sides).
#include "core.h"
#include "math3.h"
#include "sim.h"

#include <math.h>
#include <string.h>

static od_Status od_Grow(void** p, int* capacity, int needed, size_t item)
{
	if (needed <= *capacity)
	{
		return OD_OK;
	}
	int cap = *capacity ? *capacity : 8;
	while (cap < needed)
	{
		cap *= 2;
	}
	void* q = od_Realloc(*p, (size_t)cap * item);
	if (!q)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory growing the constraint set");
	}
	*p = q;
	*capacity = cap;
	return OD_OK;
}

void od_Constraints_Destroy(od_ConstraintSet* set)
{
	od_Free(set->items);
	od_Free(set->slotOfId);
	od_Free(set->touchStart);
	od_Free(set->touchSlot);
	od_Free(set->touchArm);
	od_Free(set->current);
	od_Free(set->pairStart);
	od_Free(set->pairCol);
	od_Free(set->pairData);
	od_Free(set->targetMoment);
	memset(set, 0, sizeof *set);
}

static void od_Invalidate(od_Sim* sim)
{
	od_GlobalSolver_Invalidate(sim->solver[OD_DYNAMIC]);
	od_GlobalSolver_Invalidate(sim->solver[OD_STATIC]);
	sim->constraints.touchDirty = true;
	sim->constraints.targetsDirty = true;
}

void od_Constraints_CurrentPoint(const od_Constraint* c, const od_Graph* g, const od_State* s, double out[3])
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

void od_Constraints_CurrentDirection(const od_Constraint* c, const od_State* s, double out[3], double* length)
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

static od_Status od_CheckVector(const char* name, const double* v, bool nonzero)
{
	if (!v || !od_IsFinite3(v))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "%s must be three finite numbers", name);
	}
	if (nonzero && od_Length(od_V3Load(v)) < 1e-300)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "%s must not be the zero vector", name);
	}
	return OD_OK;
}

static od_Status od_CheckWeight(double weight)
{
	if (!(weight > 0.0) || !isfinite(weight))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "weight = %g must be finite and > 0", weight);
	}
	return OD_OK;
}

static od_Status od_AddConstraint(od_Sim* sim, od_Constraint* c, int* id)
{
	od_ConstraintSet* set = &sim->constraints;
	od_Status status = od_Grow((void**)&set->items, &set->capacity, set->count + 1, sizeof(od_Constraint));
	if (status == OD_OK)
	{
		status = od_Grow((void**)&set->slotOfId, &set->idCapacity, set->nextId + 1, sizeof(int));
	}
	if (status != OD_OK)
	{
		return status;
	}
	c->id = set->nextId++;
	c->count = od_Graph_SkinWeights(sim->graph, c->point, sim->def.skinNeighbors, c->idx, c->w);
	set->slotOfId[c->id] = set->count;
	set->items[set->count++] = *c;
	if (c->kind == OD_POSITION)
	{
		set->positionCount++;
	}
	else
	{
		set->directionCount++;
	}
	od_Invalidate(sim);
	*id = c->id;
	return OD_OK;
}

od_Status od_Sim_AddPositionConstraint(od_Sim* sim, const double point[3], const double* target, double weight,
									   int* id)
{
	od_Status status = od_CheckVector("point", point, false);
	if (status == OD_OK && target)
	{
		status = od_CheckVector("target", target, false);
	}
	if (status == OD_OK)
	{
		status = od_CheckWeight(weight);
	}
	if (status != OD_OK)
	{
		return status;
	}
	od_Constraint c;
	memset(&c, 0, sizeof c);
	c.kind = OD_POSITION;
	c.weight = weight;
	memcpy(c.point, point, sizeof c.point);
	if (target)
	{
		memcpy(c.target, target, sizeof c.target);
	}
	else
	{
		c.count = od_Graph_SkinWeights(sim->graph, c.point, sim->def.skinNeighbors, c.idx, c.w);
		od_Constraints_CurrentPoint(&c, sim->graph, &sim->state, c.target);
	}
	return od_AddConstraint(sim, &c, id);
}

od_Status od_Sim_AddDirectionConstraint(od_Sim* sim, const double point[3], const double direction[3],
										const double* target, double weight, int* id)
{
	od_Status status = od_CheckVector("point", point, false);
	if (status == OD_OK)
	{
		status = od_CheckVector("direction", direction, true);
	}
	if (status == OD_OK && target)
	{
		status = od_CheckVector("target", target, true);
	}
	if (status == OD_OK)
	{
		status = od_CheckWeight(weight);
	}
	if (status != OD_OK)
	{
		return status;
	}
	od_Constraint c;
	memset(&c, 0, sizeof c);
	c.kind = OD_DIRECTION;
	c.weight = weight;
	memcpy(c.point, point, sizeof c.point);
	od_V3Store(c.direction, od_Scale(1.0 / od_Length(od_V3Load(direction)), od_V3Load(direction)));
	double length = 1.0;
	if (target)
	{
		memcpy(c.target, target, sizeof c.target);
	}
	else
	{
		c.count = od_Graph_SkinWeights(sim->graph, c.point, sim->def.skinNeighbors, c.idx, c.w);
		od_Constraints_CurrentDirection(&c, &sim->state, c.target, &length);
		if (length < 1e-12)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "direction: the skinned direction at this point vanishes; give a target");
		}
	}
	od_V3Store(c.target, od_Scale(1.0 / od_Length(od_V3Load(c.target)), od_V3Load(c.target)));
	return od_AddConstraint(sim, &c, id);
}

static od_Constraint* od_Find(od_Sim* sim, int id)
{
	od_ConstraintSet* set = &sim->constraints;
	if (id < 0 || id >= set->nextId || set->slotOfId[id] < 0)
	{
		od_Fail(OD_ERROR_NOT_FOUND, "no constraint with id %d", id);
		return NULL;
	}
	return set->items + set->slotOfId[id];
}

od_Status od_Sim_SetConstraintTarget(od_Sim* sim, int id, const double target[3])
{
	od_Constraint* c = od_Find(sim, id);
	if (!c)
	{
		return OD_ERROR_NOT_FOUND;
	}
	od_Status status = od_CheckVector("target", target, c->kind == OD_DIRECTION);
	if (status != OD_OK)
	{
		return status;
	}
	od_Vec3 t = od_V3Load(target);
	if (c->kind == OD_DIRECTION)
	{
		t = od_Scale(1.0 / od_Length(t), t);
	}
	od_V3Store(c->target, t);
	sim->constraints.targetsDirty = c->kind == OD_POSITION || sim->constraints.targetsDirty;
	return OD_OK;
}

od_Status od_Sim_SetConstraintWeight(od_Sim* sim, int id, double weight)
{
	od_Constraint* c = od_Find(sim, id);
	if (!c)
	{
		return OD_ERROR_NOT_FOUND;
	}
	od_Status status = od_CheckWeight(weight);
	if (status != OD_OK)
	{
		return status;
	}
	c->weight = weight;
	od_Invalidate(sim);
	return OD_OK;
}

od_Status od_Sim_RemoveConstraint(od_Sim* sim, int id)
{
	od_Constraint* c = od_Find(sim, id);
	if (!c)
	{
		return OD_ERROR_NOT_FOUND;
	}
	od_ConstraintSet* set = &sim->constraints;
	int slot = set->slotOfId[id];
	if (c->kind == OD_POSITION)
	{
		set->positionCount--;
	}
	else
	{
		set->directionCount--;
	}
	set->items[slot] = set->items[--set->count];
	set->slotOfId[set->items[slot].id] = slot;
	set->slotOfId[id] = -1;
	od_Invalidate(sim);
	return OD_OK;
}

int od_Sim_GetConstraintCount(const od_Sim* sim)
{
	return sim->constraints.count;
}

double od_Constraints_Energy(const od_Sim* sim)
{
	const od_ConstraintSet* set = &sim->constraints;
	double e = 0.0;
	for (int s = 0; s < set->count; ++s)
	{
		const od_Constraint* c = set->items + s;
		double q[3], l = 1.0;
		if (c->kind == OD_POSITION)
		{
			od_Constraints_CurrentPoint(c, sim->graph, &sim->state, q);
		}
		else
		{
			od_Constraints_CurrentDirection(c, &sim->state, q, &l);
			l = l > 0.0 ? l : 1.0;
		}
		od_Vec3 d = od_Sub(od_Scale(1.0 / l, od_V3Load(q)), od_V3Load(c->target));
		e += 0.5 * c->weight * od_Dot(d, d);
	}
	return e;
}

// A static pose is defined only when every connected piece has a position constraint.
od_Status od_Constraints_CheckPinned(const od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	const od_ConstraintSet* set = &sim->constraints;
	if (set->positionCount == 0)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "solve_static needs at least one position constraint");
	}
	for (int piece = 0; piece < g->pieceCount; ++piece)
	{
		bool pinned = false;
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
