// The skinned surface as the particles' contact shape with the floor and the colliders (docs/contact.md,
// "Contact on the skin"; opdeform/colliders.h, od_Sim_SetContactSkin).
//
// The particles' ellipsoids reach past the mesh they carry (a 2.7 m Suzanne's by 4.5 cm, median over 200
// directions, at 100 particles), so a body whose ellipsoids touch rests with its skin above the collider by
// that overhang (3-4 cm). Here the skin's points (the rest mesh's vertices, or any sampling of it) are carried
// rigidly by particles, at x_i + R_i (v - X̄_i), and the floor and the colliders meet those points instead of
// the ellipsoids, with the same push of the particle's centre and the same friction (floor.c, contact.c); the
// ARAP solve is not touched. Which particles carry a vertex is the caller's choice: Simulation.set_contact_skin
// gives it to every particle that skins it (weight > 0; from 0.05 on while the goals carry the rest: a far copy
// of small weight met a floor the skin never neared, docs/contact.md). A skinned vertex is a convex combination
// of those carried copies, so where each copy is out of a plane the vertex is too: Suzanne's skin rests on the
// floor at 0 and at the thickness (5 mm) on a sphere or a ramp, never inside. Given to its largest weight's particle
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
	od_Free(shape->first);
	od_Free(shape->group);
	od_Free(shape->offset);
	od_Free(shape->reach);
	*shape = (od_SkinShape){ 0 };
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

#define OD_SKIN_GROUP 16 // points a group holds at most

// A point while sorting: its place along a Morton curve over its particle's box, then its offset.
typedef struct od_SkinPoint
{
	unsigned long long key;
	double o[3];
} od_SkinPoint;

// By key, then by the offset (a total order: the same on every platform).
static int od_AlongCurve(const void* a, const void* b)
{
	const od_SkinPoint *p = a, *q = b;
	if (p->key != q->key)
	{
		return p->key < q->key ? -1 : 1;
	}
	for (int k = 0; k < 3; ++k)
	{
		if (p->o[k] != q->o[k])
		{
			return p->o[k] < q->o[k] ? -1 : 1;
		}
	}
	return 0;
}

// Interleaves the bits of three 10-bit cell indices.
static unsigned long long od_Morton(const int cell[3])
{
	unsigned long long key = 0;
	for (int bit = 9; bit >= 0; --bit)
	{
		for (int a = 0; a < 3; ++a)
		{
			key = (key << 1) | (unsigned long long)((cell[a] >> bit) & 1);
		}
	}
	return key;
}

// The box of points [0, count).
static void od_Box(const od_SkinPoint* pts, int count, od_Vec3* lo, od_Vec3* hi)
{
	*lo = *hi = od_V3Load(pts[0].o);
	for (int k = 1; k < count; ++k)
	{
		*lo = od_V3(fmin(lo->x, pts[k].o[0]), fmin(lo->y, pts[k].o[1]), fmin(lo->z, pts[k].o[2]));
		*hi = od_V3(fmax(hi->x, pts[k].o[0]), fmax(hi->y, pts[k].o[1]), fmax(hi->z, pts[k].o[2]));
	}
}

// Orders points [0, count) of one particle along a Morton curve over their box, so that runs of them are near.
static void od_OrderPoints(od_SkinPoint* pts, int count)
{
	od_Vec3 lo, hi;
	od_Box(pts, count, &lo, &hi);
	double size = fmax(fmax(hi.x - lo.x, hi.y - lo.y), fmax(hi.z - lo.z, 1e-300));
	for (int k = 0; k < count; ++k)
	{
		int cell[3];
		for (int a = 0; a < 3; ++a)
		{
			cell[a] = (int)fmin(1023.0, 1024.0 * (pts[k].o[a] - (&lo.x)[a]) / size);
		}
		pts[k].key = od_Morton(cell);
	}
	qsort(pts, (size_t)count, sizeof *pts, od_AlongCurve);
}

// One group: points pts[0, count) stored from point `at` on, its bounding sphere about its box's centre; returns
// the farthest of them from the particle's centre.
static double od_StoreGroup(od_SkinShape* s, int g, const od_SkinPoint* pts, int count, int at)
{
	od_Vec3 lo, hi;
	od_Box(pts, count, &lo, &hi);
	od_Vec3 c = od_Scale(0.5, od_Add(lo, hi));
	double radius = 0.0, far = 0.0;
	for (int k = 0; k < count; ++k)
	{
		double* o = s->offset + 4 * (at + k);
		memcpy(o, pts[k].o, sizeof pts[k].o);
		o[3] = od_Length(od_Sub(od_V3Load(o), c));
		radius = fmax(radius, o[3]);
		far = fmax(far, od_Length(od_V3Load(o)));
	}
	od_V3Store(s->group + 5 * g, c);
	s->group[5 * g + 3] = radius;
	s->group[5 * g + 4] = od_Length(c) + radius;
	s->first[g + 1] = at + count;
	return far;
}

// Points by particle (a counting sort: `begin` the n + 1 bounds, pts the points), a particle given none at its
// centre (offset 0); each particle's in groups of OD_SKIN_GROUP points that follow each other along a Morton
// curve.
static void od_FillSkin(od_SkinShape* s, const od_Graph* g, const double* points, const int* particles, int count,
						int* begin, od_SkinPoint* pts)
{
	int n = g->n, groups = 0;
	for (int k = 0; k < count; ++k)
	{
		begin[particles[k] + 1]++;
	}
	for (int i = 0; i < n; ++i)
	{
		begin[i + 1] += begin[i] + (begin[i + 1] == 0);
	}
	int* next = s->start; // the fill's cursors until the groups are known
	memcpy(next, begin, sizeof(int) * (size_t)n);
	memset(pts, 0, sizeof *pts * (size_t)s->count);
	for (int k = 0; k < count; ++k)
	{
		int i = particles[k], at = next[i]++;
		od_V3Store(pts[at].o, od_Sub(od_V3Load(points + 3 * k), od_V3Load(g->centers + 3 * i)));
	}
	for (int i = 0; i < n; ++i)
	{
		s->start[i] = groups;
		s->reach[i] = 0.0;
		od_OrderPoints(pts + begin[i], begin[i + 1] - begin[i]);
		for (int at = begin[i]; at < begin[i + 1]; at += OD_SKIN_GROUP, ++groups)
		{
			int size = begin[i + 1] - at < OD_SKIN_GROUP ? begin[i + 1] - at : OD_SKIN_GROUP;
			s->reach[i] = fmax(s->reach[i], od_StoreGroup(s, groups, pts + at, size, at));
		}
	}
	s->start[n] = groups;
}

od_Status od_Sim_SetContactSkin(od_Sim* sim, const double* points, const int* particles, int count, int bodies)
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
	int groups = kept / OD_SKIN_GROUP + n;
	od_SkinShape s = { .count = kept, .given = count, .start = od_Alloc(sizeof(int) * ((size_t)n + 1)),
					   .first = od_AllocZero((size_t)groups + 1, sizeof(int)),
					   .group = od_Alloc(sizeof(double) * 5 * (size_t)groups),
					   .offset = od_Alloc(sizeof(double) * 4 * (size_t)kept),
					   .reach = od_Alloc(sizeof(double) * (size_t)n), .bodies = bodies != 0 };
	int* begin = od_AllocZero((size_t)n + 1, sizeof(int));
	od_SkinPoint* pts = od_Alloc(sizeof(od_SkinPoint) * (size_t)kept);
	if (!s.start || !s.first || !s.group || !s.offset || !s.reach || !begin || !pts)
	{
		od_Free(begin);
		od_Free(pts);
		od_SkinShape_Destroy(&s);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for %d skin points", count);
	}
	od_FillSkin(&s, sim->graph, points, particles, count, begin, pts);
	od_Free(begin);
	od_Free(pts);
	sim->skinShape = s;
	return OD_OK;
}

int od_Sim_GetContactSkinCount(const od_Sim* sim)
{
	return sim->skinShape.given;
}

double od_SkinShape_Below(const od_Sim* sim, int i, const double* rotation)
{
	return od_SkinShape_Support(sim, i, rotation, (od_Vec3){ 0.0, 0.0, 1.0 }, NULL);
}

double od_SkinShape_Support(const od_Sim* sim, int i, const double* rotation, od_Vec3 n, int* point)
{
	const od_SkinShape* s = &sim->skinShape;
	od_Mat3 r = od_M3Load(rotation);
	od_Vec3 m = od_M3MulTV(&r, n); // -n·(R o) = -(Rᵀ n)·o
	double below = -INFINITY;
	int top = s->first[s->start[i]];
	for (int g = s->start[i]; g < s->start[i + 1]; ++g)
	{
		double centre = -od_Dot(m, od_V3Load(s->group + 5 * g));
		for (int k = s->first[g]; k < s->first[g + 1] && centre + s->group[5 * g + 3] > below; ++k)
		{
			double d = -od_Dot(m, od_V3Load(s->offset + 4 * k));
			if (d > below) // not fmax: that was a call to libm here (0.1 ms a step in the colliders bench)
			{
				below = d;
				top = k;
			}
		}
	}
	if (point)
	{
		*point = top;
	}
	return below;
}

