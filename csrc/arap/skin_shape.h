// The skinned surface as the particles' contact shape with the floor and the colliders (skin_shape.c).
#pragma once

#include "math3.h"
#include "sim.h"

#include <stdbool.h>

void od_SkinShape_Destroy(od_SkinShape* shape);
// Whether the floor and the colliders touch the skin's points (else the ellipsoids). This, PointSupport and Reach
// are inline: called from the other files for each near particle at each of the forces' updates, as calls they
// took the colliders bench's 1,000-particle Suzanne on the ramp 28.39 M instructions a step, 28.01 M inline.
static inline bool od_SkinShape_Used(const od_Sim* sim)
{
	return sim->skinShape.count > 0;
}
// How far below its centre particle i's lowest point reaches when turned by `rotation` (the floor's support).
double od_SkinShape_Below(const od_Sim* sim, int i, const double* rotation);
// The same along unit n: the largest -n·(rotation o) of its points (contact inside the iterations, surface_contact.c),
// and which point that is in *point (global index; NULL: not wanted).
double od_SkinShape_Support(const od_Sim* sim, int i, const double* rotation, od_Vec3 n, int* point);
// -n·(rotation o) of that one point: -(rotationᵀ n)·o, read from the array (od_M3MulTV's products and sums; its
// od_Mat3 was a copy through the stack: od_HeldDepth took 85 instructions, 75 so).
static inline double od_SkinShape_PointSupport(const od_Sim* sim, int point, const double* r, od_Vec3 n)
{
	od_Vec3 w = { r[0] * n.x + r[3] * n.y + r[6] * n.z, r[1] * n.x + r[4] * n.y + r[7] * n.z,
				  r[2] * n.x + r[5] * n.y + r[8] * n.z };
	return -od_Dot(w, od_V3Load(sim->skinShape.offset + 4 * point));
}
// The distance from particle i's centre of its farthest point.
static inline double od_SkinShape_Reach(const od_Sim* sim, int i)
{
	return sim->skinShape.reach[i];
}
