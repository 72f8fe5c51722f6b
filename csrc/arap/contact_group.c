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
		od_BodyContact_Keep(&group->pairs, group->sims, group->count);
		for (int b = 0; b < group->count; ++b)
		{
			od_Step_Finish(group->sims[b], k, steps);
		}
		od_BodyContact_Carry(&group->pairs, group->sims, group->count);
		od_BodyContact_TurnAnchors(&group->pairs, group->sims);
		status = status == OD_OK ? od_BodyContact_Impacts(&group->pairs, group->sims, group->count, &group->def) : status;
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

// Where particle p of the group (particles numbered over the members in order) is now.
static const double* od_GroupPosition(const od_ContactGroup* group, int p)
{
	const od_PairScratch* s = &group->pairs;
	return group->sims[s->body[p]]->state.x + 3 * s->local[p];
}

void od_ContactGroup_GetPairs(const od_ContactGroup* group, int* pairs, double* forces)
{
	for (int k = 0; k < od_ContactGroup_GetPairCount(group); ++k)
	{
		const od_ContactPair* p = &group->pairs.pairs[k];
		double* f = forces + OD_PAIR_VALUES * k;
		pairs[2 * k] = p->a;
		pairs[2 * k + 1] = p->b;
		f[0] = p->force;
		memcpy(f + 1, p->tangent, sizeof p->tangent);
		memcpy(f + 4, p->n, sizeof p->n);
		// A pair not anchored takes its anchor at the next step's start (od_Slip), where its particles are now.
		const double *xa = od_GroupPosition(group, p->a), *xb = od_GroupPosition(group, p->b);
		for (int c = 0; c < 3; ++c)
		{
			f[7 + c] = p->anchored ? p->anchor[c] : xb[c] - xa[c];
		}
	}
}

// A carried force that would move its two particles by more than this in one step, unopposed (|f| h² (1/m_a +
// 1/m_b)), is no state a step leaves (those move them by about the contact thickness): a saved state is
// untrusted input (issue 28), and 1e300 made every later step fail.
#define OD_PAIR_MAX_PUSH 1e3 // m

// The mass of particle p of the group (particles numbered over the members in order).
static double od_GroupMass(const od_ContactGroup* group, int p)
{
	int b = 0;
	for (; p >= group->sims[b]->graph->n; ++b)
	{
		p -= group->sims[b]->graph->n;
	}
	return group->sims[b]->def.density * group->sims[b]->graph->volumes[p];
}

// A pair's carried forces: finite, the normal force >= 0, the normal a unit vector, the push and the anchor
// bounded.
static od_Status od_CheckPairForces(const od_ContactGroup* group, int k, const int* pair, const double* f)
{
	for (int c = 0; c < OD_PAIR_VALUES; ++c)
	{
		if (!isfinite(f[c]) || (c == 0 && f[0] < 0.0))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "forces[%d, %d] = %g must be finite%s", k, c, f[c],
						   c == 0 ? " and >= 0" : "");
		}
	}
	double n2 = f[4] * f[4] + f[5] * f[5] + f[6] * f[6];
	if (!(fabs(n2 - 1.0) < 1e-6))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "forces[%d, 4:7]: the normal (%g, %g, %g) is not a unit vector", k, f[4],
					   f[5], f[6]);
	}
	double anchor = sqrt(f[7] * f[7] + f[8] * f[8] + f[9] * f[9]);
	if (!(anchor <= OD_PAIR_MAX_PUSH))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "forces[%d, 7:10]: the anchor (%g, %g, %g) is %g m long (at most %g)", k, f[7],
					   f[8], f[9], anchor, OD_PAIR_MAX_PUSH);
	}
	double h = group->sims[0]->def.dt, size = f[0] + sqrt(f[1] * f[1] + f[2] * f[2] + f[3] * f[3]);
	double push = size * h * h * (1.0 / od_GroupMass(group, pair[0]) + 1.0 / od_GroupMass(group, pair[1]));
	if (!(push <= OD_PAIR_MAX_PUSH))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "forces[%d]: a normal and friction force of %g N would push its particles "
										  "%g m in one step (at most %g)", k, size, push, OD_PAIR_MAX_PUSH);
	}
	return OD_OK;
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
		od_Status status = od_CheckPairForces(group, k, pairs + 2 * k, forces + OD_PAIR_VALUES * k);
		if (status != OD_OK)
		{
			return status;
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
		const double* f = forces + OD_PAIR_VALUES * k;
		*p = (od_ContactPair){ .a = pairs[2 * k], .b = pairs[2 * k + 1], .force = f[0], .anchored = true };
		memcpy(p->tangent, f + 1, sizeof p->tangent);
		memcpy(p->n, f + 4, sizeof p->n);
		memcpy(p->anchor, f + 7, sizeof p->anchor);
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
