// The constraint set: position and direction constraints (eqs. 8 and 10 of the paper) on rest-space points.
//
// A constraint is skinned like a mesh vertex: its point moves with the m nearest particles and the
// Sumner weights of METHOD.md. The set is stored densely (slots) with an id -> slot table, so removal
// is O(1) and ids stay valid. The set never reaches into the solver: a change that alters the global
// matrix (adding or removing a position constraint, or changing its weight) advances matrixVersion, which
// the global solver compares with the version it factored (global_solve.c); direction constraints and
// moved targets change only the terms rebuilt here, lazily, by od_Constraints_Prepare. Each kind's maths
// lives in its own file (position_constraints.c, direction_constraints.c).
#include "constraints.h"

#include "buffer.h"
#include "core.h"
#include "direction_constraints.h"
#include "math3.h"
#include "position_constraints.h"
#include "sim.h"

#include <math.h>
#include <string.h>

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

// Marks what a change of constraint c (added, removed, reweighted) made stale.
static void od_Changed(od_ConstraintSet* set, const od_Constraint* c)
{
	if (c->kind == OD_POSITION)
	{
		set->matrixVersion++;
		set->pairsDirty = true;
		set->targetsDirty = true;
	}
	else
	{
		set->incidenceDirty = true;
	}
}

static od_Status od_CheckVector(const char* name, const double* v, bool nonzero)
{
	if (!v || !od_IsFinite3(v))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "%s must be three finite numbers", name);
	}
	if (nonzero && v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0) // any other finite vector is a direction (od_Unit)
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
	od_Status status = od_Grow((void**)&set->items, &set->capacity, set->count + 1, sizeof(od_Constraint), "constraint set");
	if (status == OD_OK)
	{
		status = od_Grow((void**)&set->slotOfId, &set->idCapacity, set->nextId + 1, sizeof(int), "constraint set");
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
	od_Changed(set, c);
	*id = c->id;
	return OD_OK;
}

// The checks of a new constraint's point (finite, near the graph), target (finite; nonzero for a direction)
// and weight.
static od_Status od_CheckNew(const od_Sim* sim, const double point[3], const double* target, bool direction,
							 double weight)
{
	od_Status status = od_CheckVector("point", point, false);
	status = status == OD_OK ? od_Graph_CheckRestPoint(sim->graph, point, "point") : status;
	if (status == OD_OK && target)
	{
		status = od_CheckVector("target", target, direction);
	}
	return status == OD_OK ? od_CheckWeight(weight) : status;
}

static od_Constraint od_NewConstraint(od_ConstraintKind kind, const double point[3], double weight)
{
	od_Constraint c;
	memset(&c, 0, sizeof c);
	c.kind = kind;
	c.weight = weight;
	memcpy(c.point, point, sizeof c.point);
	return c;
}

od_Status od_Sim_AddPositionConstraint(od_Sim* sim, const double point[3], const double* target, double weight,
									   int* id)
{
	od_Status status = od_CheckNew(sim, point, target, false, weight);
	if (status != OD_OK)
	{
		return status;
	}
	od_Constraint c = od_NewConstraint(OD_POSITION, point, weight);
	if (target)
	{
		memcpy(c.target, target, sizeof c.target);
	}
	else
	{
		c.count = od_Graph_SkinWeights(sim->graph, c.point, sim->def.skinNeighbors, c.idx, c.w);
		od_Positions_Current(&c, sim->graph, &sim->state, c.target);
	}
	return od_AddConstraint(sim, &c, id);
}

od_Status od_Sim_AddDirectionConstraint(od_Sim* sim, const double point[3], const double direction[3],
										const double* target, double weight, int* id)
{
	od_Status status = od_CheckNew(sim, point, target, true, weight);
	if (status == OD_OK)
	{
		status = od_CheckVector("direction", direction, true);
	}
	if (status != OD_OK)
	{
		return status;
	}
	od_Constraint c = od_NewConstraint(OD_DIRECTION, point, weight);
	od_V3Store(c.direction, od_Unit(od_V3Load(direction)));
	double length = 1.0;
	if (target)
	{
		memcpy(c.target, target, sizeof c.target);
	}
	else
	{
		c.count = od_Graph_SkinWeights(sim->graph, c.point, sim->def.skinNeighbors, c.idx, c.w);
		od_Directions_Current(&c, &sim->state, c.target, &length);
		if (length < 1e-12)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "direction: the skinned direction at this point vanishes; give a target");
		}
	}
	od_V3Store(c.target, od_Unit(od_V3Load(c.target)));
	return od_AddConstraint(sim, &c, id);
}

static od_Constraint* od_Find(const od_Sim* sim, int id)
{
	const od_ConstraintSet* set = &sim->constraints;
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
		t = od_Unit(t);
	}
	od_V3Store(c->target, t);
	sim->constraints.targetsDirty = c->kind == OD_POSITION || sim->constraints.targetsDirty;
	return OD_OK;
}

od_Status od_Sim_GetConstraintTarget(const od_Sim* sim, int id, double target[3])
{
	const od_Constraint* c = od_Find(sim, id);
	if (!c)
	{
		return OD_ERROR_NOT_FOUND;
	}
	memcpy(target, c->target, sizeof c->target);
	return OD_OK;
}

od_Status od_Sim_RestoreConstraintTarget(od_Sim* sim, int id, const double target[3])
{
	od_Constraint* c = od_Find(sim, id);
	if (!c)
	{
		return OD_ERROR_NOT_FOUND;
	}
	memcpy(c->target, target, sizeof c->target);
	sim->constraints.targetsDirty = true;
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
	if (c->kind == OD_POSITION) // a direction constraint's weight is read where it is used: nothing is stale
	{
		od_Changed(&sim->constraints, c);
	}
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
	od_Changed(set, c);
	set->incidenceDirty = true; // the last constraint moves into the freed slot, which touchSlot names
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
	return OD_OK;
}

int od_Sim_GetConstraintCount(const od_Sim* sim)
{
	return sim->constraints.count;
}

void od_Constraints_Reskin(od_Sim* sim)
{
	od_ConstraintSet* set = &sim->constraints;
	for (int s = 0; s < set->count; ++s)
	{
		od_Constraint* c = set->items + s;
		c->count = od_Graph_SkinWeights(sim->graph, c->point, sim->def.skinNeighbors, c->idx, c->w);
	}
	set->matrixVersion++;
	set->pairsDirty = set->incidenceDirty = set->targetsDirty = true;
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
		status = od_Resize((void**)&set->touchStart, rows, "constraint terms");
		if (status == OD_OK)
		{
			status = od_Resize((void**)&set->pairStart, rows, "constraint terms");
		}
		if (status == OD_OK)
		{
			status = od_Resize((void**)&set->targetMoment, sizeof(double) * 12 * (size_t)g->n, "constraint terms");
		}
	}
	if (status == OD_OK && set->incidenceDirty)
	{
		status = od_Directions_Build(set, g);
		set->incidenceDirty = status != OD_OK;
	}
	if (status == OD_OK && set->pairsDirty)
	{
		status = od_Positions_Build(set, g);
		set->pairsDirty = status != OD_OK;
	}
	if (status == OD_OK && set->targetsDirty)
	{
		od_Positions_BuildTargets(set, g);
		set->targetsDirty = false;
	}
	return status;
}

bool od_Constraints_Touches(const od_Sim* sim, int i)
{
	const od_ConstraintSet* set = &sim->constraints;
	return set->pairStart[i] != set->pairStart[i + 1] || set->touchStart[i] != set->touchStart[i + 1];
}

double od_Constraints_Energy(const od_Sim* sim)
{
	return od_Positions_Energy(sim) + od_Directions_Energy(sim);
}
