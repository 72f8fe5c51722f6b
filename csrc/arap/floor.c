// Collision with the floor plane z = height and friction (METHOD.md, "Collision with a floor").
//
// An ellipsoid with frame E = R Ē and radii r reaches down to x_z - s with s = sqrt(Σ_a (r_a e_a,z)²).
// A particle below that is lifted by the difference; one that began the step inside deeper than the recovery
// (contact.c: 1 m/s times the step) keeps that excess, so it leaves at the recovery speed, as from a collider
// (lifted whole, a slab placed with its ellipsoids 8-9 mm in the floor left at 1.4-2.4 m/s at 240 Hz, +218-475 J;
// now 1.0-1.1 m/s, +95-110 J; docs/contact.md, stacks, ninth round). With the skin as the contact shape
// (skin_shape.c) s is how far its lowest skin point reaches below its centre, so the skin, not the ellipsoid,
// rests on the floor.
// Friction is Coulomb-like and position based: the tangential displacement of this step is cut by at most μ
// times the lift (the normal impulse of the contact times h), and the angular velocity of the touching
// particle is scaled by the same ratio.
//
// With goals carrying the rest (docs/goals.md, "Contact with goals") the lift is only what the particle is
// deeper than its ellipsoid placed at its goal frame (g_i, G_i): a particle on its animation is never
// lifted, one that swings below it stops at the floor (or at its goal's depth, where the goal is below the
// floor itself), and friction acts on that excess lift alone.
#include "floor.h"

#include "contact.h"
#include "goal.h"
#include "math3.h"
#include "skin_shape.h"

// How far particle i's ellipsoid (or its skin points, skin_shape.c) at frame (rotation, centre) reaches below
// the floor (<= 0: clear of it).
static double od_FloorLift(const od_Sim* sim, int i, const double* rotation, const double* centre)
{
	if (od_SkinShape_Used(sim))
	{
		double above = centre[2] - sim->floorHeight, reach = od_SkinShape_Reach(sim, i);
		return above >= reach ? reach - above : od_SkinShape_Below(sim, i, rotation) - above;
	}
	const od_Graph* g = sim->graph;
	od_Mat3 r = od_M3Load(rotation), e0 = od_M3Load(g->axes + 9 * i);
	od_Mat3 e = od_M3Mul(&r, &e0);
	const double* rad = g->radii + 3 * i;
	double s2 = 0.0;
	for (int a = 0; a < 3; ++a)
	{
		double d = rad[a] * e.m[6 + a];
		s2 += d * d;
	}
	return sqrt(s2) - (centre[2] - sim->floorHeight);
}

double od_FloorDepth(const od_Sim* sim, int i, const double* rotation, const double* centre)
{
	double lift = od_FloorLift(sim, i, rotation, centre);
	if (od_Goals_CarryRest(sim))
	{
		lift -= fmax(od_FloorLift(sim, i, sim->goals.R + 9 * i, sim->goals.x + 3 * i), 0.0);
	}
	return lift;
}

void od_FloorStep(od_Sim* sim, const od_State* before, double* angularScale, double* lifted)
{
	const od_Graph* g = sim->graph;
	double* x = sim->state.x;
	double mu = sim->floorFriction;
	for (int i = 0; i < g->n; ++i)
	{
		double lift = od_FloorDepth(sim, i, sim->state.R + 9 * i, x + 3 * i);
		if (lift > 0.0) // one that began the step inside deeper than the recovery leaves at the recovery speed
		{
			lift -= fmax(od_FloorDepth(sim, i, before->R + 9 * i, before->x + 3 * i) - od_RecoveryLimit(sim), 0.0);
		}
		double hold = od_SurfaceContact_Hold(sim, i, OD_SURFACE_FLOOR);
		angularScale[i] = 1.0;
		if (lifted)
		{
			lifted[i] = lift > 0.0 ? lift : 0.0;
		}
		if (!(lift > 0.0) && !(hold > 0.0))
		{
			continue;
		}
		lift = lift > 0.0 ? lift : 0.0;
		x[3 * i + 2] += lift;
		if (mu <= 0.0)
		{
			continue;
		}
		double dx = x[3 * i] - before->x[3 * i], dy = x[3 * i + 1] - before->x[3 * i + 1];
		double given = od_SurfaceContact_Given(sim, i, OD_SURFACE_FLOOR);
		double keep = od_CoulombKeep(sqrt(dx * dx + dy * dy), mu * fmax(lift - given, 0.0) + hold);
		x[3 * i] = before->x[3 * i] + keep * dx;
		x[3 * i + 1] = before->x[3 * i + 1] + keep * dy;
		angularScale[i] = keep;
	}
}
