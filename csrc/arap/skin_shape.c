// The skinned surface as the particles' contact shape with the floor and the colliders (docs/contact.md,
// "Contact on the skin"; opdeform/colliders.h, od_Sim_SetContactSkin).
//
// The particles' ellipsoids reach past the mesh they carry (a 2.7 m Suzanne's by 4.5 cm, median over 200
// directions, at 100 particles), so a body whose ellipsoids touch rests with its skin above the collider by
// that overhang (3-4 cm). Here the skin's points (the rest mesh's vertices, or any sampling of it) are carried
// rigidly by particles, at x_i + R_i (v - X̄_i), and the floor and the colliders meet those points instead of
// the ellipsoids, with the same push of the particle's centre and the same friction (floor.c, contact.c); the
// ARAP solve is not touched. Which particles carry a vertex is the caller's choice: Simulation.set_contact_skin
// gives it to every particle that skins it (weight > 0). A skinned vertex is a convex combination of those
// carried copies, so where each copy is out of a plane the vertex is too: Suzanne's skin rests on the floor at
// 0 and at the thickness (5 mm) on a sphere or a ramp, never inside. Given to its largest weight's particle
// alone, the vertex dipped 4-7 mm into them (the other particles' copies lower), the push-out hiding it.
// A particle given no point keeps its centre, so an interior particle still stops at a collider once the skin
// has gone past.
#include "skin_shape.h"

#include "check.h"
#include "core.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void od_SkinShape_Destroy(od_SkinShape* shape)
{
	od_Free(shape->start);
	od_Free(shape->offset);
	od_Free(shape->reach);
	*shape = (od_SkinShape){ 0 };
}

bool od_SkinShape_Used(const od_Sim* sim)
{
	return sim->skinShape.count > 0;
}

static od_Status od_CheckSkin(const od_Sim* sim, const double* points, const int* particles, int count)
{
	if (count < 0 || (count > 0 && (!points || !particles)))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "count = %d: give count >= 0 points with their particles", count);
	}
	od_Status status = od_CheckFinite("points", points, 3 * count);
	for (int k = 0; k < count && status == OD_OK; ++k)
	{
		if (particles[k] < 0 || particles[k] >= sim->graph->n)
		{
			status = od_Fail(OD_ERROR_ARGUMENT, "particles[%d] = %d is out of range: there are %d particles", k,
							 particles[k], sim->graph->n);
		}
	}
	return status;
}

// Longest offset first, then by its coordinates (a total order: the same on every platform).
static int od_LongerFirst(const void* a, const void* b)
{
	const double *p = a, *q = b;
	const int order[4] = { 3, 0, 1, 2 };
	for (int k = 0; k < 4; ++k)
	{
		if (p[order[k]] != q[order[k]])
		{
			return p[order[k]] > q[order[k]] ? -1 : 1;
		}
	}
	return 0;
}

// Points by particle (a counting sort), longest offset first (contact.c stops at the first point the centre's
// distance proves clear), a particle given none at its centre (offset 0).
static void od_FillSkin(od_SkinShape* s, const od_Graph* g, const double* points, const int* particles, int count,
						int* next)
{
	int n = g->n;
	for (int k = 0; k < count; ++k)
	{
		s->start[particles[k] + 1]++;
	}
	for (int i = 0; i < n; ++i)
	{
		s->start[i + 1] += s->start[i] + (s->start[i + 1] == 0);
	}
	memcpy(next, s->start, sizeof(int) * (size_t)n);
	memset(s->offset, 0, sizeof(double) * 4 * (size_t)s->count);
	for (int k = 0; k < count; ++k)
	{
		int i = particles[k], at = next[i]++;
		od_Vec3 d = od_Sub(od_V3Load(points + 3 * k), od_V3Load(g->centers + 3 * i));
		od_V3Store(s->offset + 4 * at, d);
		s->offset[4 * at + 3] = od_Length(d);
	}
	for (int i = 0; i < n; ++i)
	{
		int first = s->start[i];
		qsort(s->offset + 4 * first, (size_t)(s->start[i + 1] - first), sizeof(double) * 4, od_LongerFirst);
		s->reach[i] = s->offset[4 * first + 3];
	}
}

od_Status od_Sim_SetContactSkin(od_Sim* sim, const double* points, const int* particles, int count)
{
	od_Status status = od_CheckSkin(sim, points, particles, count);
	if (status != OD_OK)
	{
		return status;
	}
	od_SkinShape_Destroy(&sim->skinShape);
	if (count == 0)
	{
		return OD_OK;
	}
	int n = sim->graph->n, kept = count;
	bool* given = od_AllocZero((size_t)n, sizeof(bool));
	if (!given)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for %d skin points", count);
	}
	for (int k = 0; k < count; ++k)
	{
		given[particles[k]] = true;
	}
	for (int i = 0; i < n; ++i)
	{
		kept += !given[i];
	}
	od_Free(given);
	od_SkinShape s = { .count = kept, .given = count, .start = od_AllocZero((size_t)n + 1, sizeof(int)),
					   .offset = od_Alloc(sizeof(double) * 4 * (size_t)kept),
					   .reach = od_Alloc(sizeof(double) * (size_t)n) };
	int* next = od_Alloc(sizeof(int) * (size_t)n);
	if (!s.start || !s.offset || !s.reach || !next)
	{
		od_Free(next);
		od_SkinShape_Destroy(&s);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for %d skin points", count);
	}
	od_FillSkin(&s, sim->graph, points, particles, count, next);
	od_Free(next);
	sim->skinShape = s;
	return OD_OK;
}

int od_Sim_GetContactSkinCount(const od_Sim* sim)
{
	return sim->skinShape.given;
}

const double* od_SkinShape_Points(const od_Sim* sim, int i, int* count)
{
	const od_SkinShape* s = &sim->skinShape;
	*count = s->start[i + 1] - s->start[i];
	return s->offset + 4 * s->start[i];
}

double od_SkinShape_Below(const od_Sim* sim, int i, const double* rotation)
{
	const od_SkinShape* s = &sim->skinShape;
	double below = -INFINITY;
	for (int k = s->start[i]; k < s->start[i + 1] && s->offset[4 * k + 3] > below; ++k) // longest first
	{
		const double* o = s->offset + 4 * k;
		below = fmax(below, -(rotation[6] * o[0] + rotation[7] * o[1] + rotation[8] * o[2]));
	}
	return below;
}

double od_SkinShape_Reach(const od_Sim* sim, int i)
{
	return sim->skinShape.reach[i];
}
