// Simulations that collide with each other (opdeform/colliders.h, docs/contact.md): one call steps them all,
// each through the stages of its own od_Sim_Step (step.h), their solves side by side with the forces of the
// pairs between them updated after every solve, and the pairs still in contact projected after the
// iterations (body_contact.c).
//
// Design: a simulation stays one body with one thread at a time; the group only borrows them for its step
// (each taken as its own step would, OD_ERROR_BUSY if one is in use) and owns nothing but the broad phase's
// scratch and the pairs' forces (kept step to step: its state, od_ContactGroup_GetPairs / SetPairs). Bodies
// see each other's particles after every solve, so the push is two-way and mass weighted; stepping them one
// after the other against frozen copies would let the second always win.
#include "body_contact.h"
#include "core.h"
#include "step.h"

#include <math.h>
#include <string.h>

struct od_ContactGroup
{
	od_Sim** sims;
	int count;
	od_BodyContactDef def;
	od_PairScratch pairs;
};

od_Status od_ContactGroup_Create(od_Sim* const* sims, int count, const od_BodyContactDef* def, od_ContactGroup** out)
{
	*out = NULL;
	int total = 0;
	for (int b = 0; b < count; ++b)
	{
		for (int c = 0; c < b; ++c)
		{
			if (sims[c] == sims[b])
			{
				return od_Fail(OD_ERROR_ARGUMENT, "sims: simulation %d is given twice (%d)", b, c);
			}
		}
		total += sims[b] ? sims[b]->graph->n : 0;
	}
	if (count < 1 || total == 0)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "sims: a group needs at least one simulation");
	}
	od_Status status = od_BodyContact_Check(def, false);
	if (status != OD_OK)
	{
		return status;
	}
	od_ContactGroup* group = od_AllocZero(1, sizeof *group);
	od_Sim** list = od_Alloc(sizeof *list * (size_t)count);
	status = group && list ? od_PairScratch_Reserve(&group->pairs, total)
						   : od_Fail(OD_ERROR_MEMORY, "out of memory for a contact group");
	if (status != OD_OK)
	{
		od_Free(list);
		od_ContactGroup_Destroy(group);
		return status;
	}
	for (int b = 0; b < count && status == OD_OK; ++b)
	{
		status = sims[b] ? od_BodyContact_ReserveForces(sims[b]) : status;
	}
	if (status != OD_OK)
	{
		od_Free(list);
		od_ContactGroup_Destroy(group);
		return status;
	}
	memcpy(list, sims, sizeof *list * (size_t)count);
	*group = (od_ContactGroup){ .sims = list, .count = count, .def = *def, .pairs = group->pairs };
	*out = group;
	return OD_OK;
}

void od_ContactGroup_Destroy(od_ContactGroup* group)
{
	if (group)
	{
		od_PairScratch_Destroy(&group->pairs);
		od_Free(group->sims);
		od_Free(group);
	}
}

od_Status od_ContactGroup_SetContact(od_ContactGroup* group, const od_BodyContactDef* def)
{
	od_Status status = od_BodyContact_Check(def, false);
	if (status == OD_OK)
	{
		group->def = *def;
	}
	return status;
}

// Takes every simulation for the call, or none (those taken are given back when one is busy).
static od_Status od_BeginAll(od_ContactGroup* group, int steps)
{
	double dt = group->sims[0]->def.dt;
	for (int b = 0; b < group->count; ++b)
	{
		od_Status status = group->sims[b]->def.dt == dt
							   ? od_Step_Begin(group->sims[b], steps)
							   : od_Fail(OD_ERROR_ARGUMENT, "sims: simulation %d has dt = %g, the first %g", b,
										 group->sims[b]->def.dt, dt);
		if (status != OD_OK)
		{
			while (--b >= 0)
			{
				od_Step_End(group->sims[b], OD_ERROR_ARGUMENT);
			}
			return status;
		}
	}
	return OD_OK;
}

od_Status od_ContactGroup_Step(od_ContactGroup* group, int steps)
{
	if (steps < 1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "steps = %d must be >= 1", steps);
	}
	od_Status status = od_BeginAll(group, steps);
	if (status != OD_OK)
	{
		return status;
	}
	for (int k = 0; k < steps && status == OD_OK; ++k)
	{
		status = od_BodyContact_Step(&group->pairs, group->sims, group->count, &group->def);
		for (int b = 0; b < group->count; ++b)
		{
			od_Step_Finish(group->sims[b], k, steps);
		}
	}
	od_Status ended = status;
	for (int b = 0; b < group->count; ++b)
	{
		ended = od_Step_End(group->sims[b], ended);
	}
	return ended;
}

int od_ContactGroup_GetPairCount(const od_ContactGroup* group)
{
	return group->pairs.pairCount;
}

void od_ContactGroup_GetPairs(const od_ContactGroup* group, int* pairs, double* forces)
{
	for (int k = 0; k < od_ContactGroup_GetPairCount(group); ++k)
	{
		const od_ContactPair* p = &group->pairs.pairs[k];
		pairs[2 * k] = p->a;
		pairs[2 * k + 1] = p->b;
		forces[7 * k] = p->force;
		memcpy(forces + 7 * k + 1, p->tangent, sizeof p->tangent);
		memcpy(forces + 7 * k + 4, p->n, sizeof p->n);
	}
}

od_Status od_ContactGroup_SetPairs(od_ContactGroup* group, int count, const int* pairs, const double* forces)
{
	int total = 0;
	for (int b = 0; b < group->count; ++b)
	{
		total += group->sims[b]->graph->n;
	}
	if (count < 0)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "count = %d must be >= 0", count);
	}
	for (int k = 0; k < count; ++k)
	{
		if (pairs[2 * k] < 0 || pairs[2 * k] >= pairs[2 * k + 1] || pairs[2 * k + 1] >= total)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "pairs[%d] = (%d, %d) must be particles 0 <= a < b < %d", k,
						   pairs[2 * k], pairs[2 * k + 1], total);
		}
		for (int c = 0; c < 7; ++c)
		{
			if (!isfinite(forces[7 * k + c]) || (c == 0 && forces[7 * k] < 0.0))
			{
				return od_Fail(OD_ERROR_ARGUMENT, "forces[%d, %d] = %g must be finite%s", k, c, forces[7 * k + c],
							   c == 0 ? " and >= 0" : "");
			}
		}
	}
	od_PairScratch* s = &group->pairs;
	if (count > s->pairCapacity)
	{
		od_ContactPair* grown = od_Realloc(s->pairs, sizeof *grown * (size_t)count);
		if (!grown)
		{
			return od_Fail(OD_ERROR_MEMORY, "out of memory for %d contact pairs", count);
		}
		s->pairs = grown;
		s->pairCapacity = count;
	}
	for (int k = 0; k < count; ++k)
	{
		od_ContactPair* p = &s->pairs[k];
		*p = (od_ContactPair){ .a = pairs[2 * k], .b = pairs[2 * k + 1], .force = forces[7 * k] };
		memcpy(p->tangent, forces + 7 * k + 1, sizeof p->tangent);
		memcpy(p->n, forces + 7 * k + 4, sizeof p->n);
	}
	// The particles' bodies, which the first solve's forces read (a new group's first broad phase sets them).
	for (int b = 0, g = 0; b < group->count; ++b)
	{
		for (int i = 0; i < group->sims[b]->graph->n; ++i, ++g)
		{
			s->body[g] = b;
			s->local[g] = i;
		}
	}
	s->pairCount = count;
	s->nearCount = count; // the first solve sees every carried force (od_IterateWithForces)
	return OD_OK;
}
