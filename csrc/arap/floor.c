// Collision with the floor plane z = height and friction (METHOD.md, "Collision with a floor").
//
// An ellipsoid with frame E = R Ē and radii r reaches down to x_z - s with s = sqrt(Σ_a (r_a e_a,z)²).
// A particle below that is lifted by the difference. Friction is Coulomb-like and position based: the
// tangential displacement of this step is cut by at most μ times the lift (the normal impulse of the
// contact times h), and the angular velocity of the touching particle is scaled by the same ratio.
#include "floor.h"

#include "contact.h"
#include "math3.h"

void od_FloorStep(od_Sim* sim, const od_State* before, double* angularScale)
{
	const od_Graph* g = sim->graph;
	double* x = sim->state.x;
	double mu = sim->floorFriction;
	for (int i = 0; i < g->n; ++i)
	{
		od_Mat3 r = od_M3Load(sim->state.R + 9 * i), e0 = od_M3Load(g->axes + 9 * i);
		od_Mat3 e = od_M3Mul(&r, &e0);
		const double* rad = g->radii + 3 * i;
		double s2 = 0.0;
		for (int a = 0; a < 3; ++a)
		{
			double d = rad[a] * e.m[6 + a];
			s2 += d * d;
		}
		double lift = sqrt(s2) - (x[3 * i + 2] - sim->floorHeight);
		angularScale[i] = 1.0;
		if (!(lift > 0.0))
		{
			continue;
		}
		x[3 * i + 2] += lift;
		if (mu <= 0.0)
		{
			continue;
		}
		double dx = x[3 * i] - before->x[3 * i], dy = x[3 * i + 1] - before->x[3 * i + 1];
		double keep = od_CoulombKeep(sqrt(dx * dx + dy * dy), mu * lift);
		x[3 * i] = before->x[3 * i] + keep * dx;
		x[3 * i + 1] = before->x[3 * i + 1] + keep * dy;
		angularScale[i] = keep;
	}
}
