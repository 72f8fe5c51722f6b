// The skin as the contact shape between the bodies of a group (docs/contact.md, "Contact on the skin between
// bodies"; Simulation.set_contact_skin on a member of a ContactGroup).
//
// A pair of particles of two bodies of a group (body_contact.c), either with a contact skin, meets on the skin: its
// shapes' supports along the pair's normal are their carried points' (or an ellipsoid's, for a member without a skin),
// so the pair's forces and projection hold the points, not the ellipsoids, apart. A particle's patch of skin is as wide
// as the body's curvature, not the particle, so the normal matters: two 0.6 m spheres touching, measured along a line
// 20° off their common normal, overlap by R (1 - cos 20°) = 2 cm. The normal is the best separating axis of a few (the
// centre line, the pair's last normal, its push direction, the particles' outward directions), refined by a few halving
// steps along the gradient of the distance (the supporting points' difference): 0.6 m spheres at rest on each other 2.4
// cm apart along the push direction alone, 1.8-2.0 cm with the candidates, 0.1 cm refined. In a group's iterations a
// pair is re-aimed at every update from its last normal and its centre line alone (body_contact.c, od_SkinNormal).
// Measured: scripts/skin_pairs.py, docs/contact.md.
#include "skin_pairs.h"

#include "contact.h"
#include "skin_shape.h"

#include <math.h>

// Whether sim's skin points are its shape between bodies (od_Sim_SetContactSkin's bodies).
static bool od_MeetsBodies(const od_Sim* sim)
{
	return od_SkinShape_Used(sim) && sim->skinShape.bodies;
}

bool od_SkinPair_Used(const od_Sim* a, const od_Sim* b)
{
	return a != b && (od_MeetsBodies(a) || od_MeetsBodies(b));
}

double od_SkinPair_Support(const od_Sim* sim, int i, const od_Mat3* moment, od_Vec3 n)
{
	return od_MeetsBodies(sim) ? od_SkinShape_Support(sim, i, sim->state.R + 9 * i, od_Scale(-1.0, n), NULL)
								  : od_Support(moment, n);
}

double od_SkinPair_Reach(const od_Sim* sim, int i)
{
	double ellipsoid = od_ParticleReach(sim, i);
	return od_MeetsBodies(sim) && sim->skinShape.reach[i] > ellipsoid ? sim->skinShape.reach[i] : ellipsoid;
}

// The point of particle i's shape farthest along unit n, from its centre: its skin point's at its current
// rotation, or its ellipsoid's (moment M: M n / sqrt(nᵀ M n)).
static od_Vec3 od_PairPoint(const od_Sim* sim, int i, const od_Mat3* moment, od_Vec3 n)
{
	if (!od_MeetsBodies(sim))
	{
		od_Vec3 m = od_M3MulV(moment, n);
		double s = sqrt(od_Dot(n, m));
		return s > 0.0 ? od_Scale(1.0 / s, m) : od_V3(0, 0, 0);
	}
	int k;
	od_SkinShape_Support(sim, i, sim->state.R + 9 * i, od_Scale(-1.0, n), &k);
	od_Mat3 r = od_M3Load(sim->state.R + 9 * i);
	return od_M3MulV(&r, od_V3Load(sim->skinShape.offset + 4 * k));
}

// How far apart the pair's shapes are along unit n (d·n less their supports towards each other), and in *w the
// vector between their supporting points less d: the gradient of their overlap n·w in n.
static double od_Apart(const od_SkinPair* q, od_Vec3 n, od_Vec3* w)
{
	od_Vec3 pa = od_PairPoint(q->a, q->i, q->ma, n), pb = od_PairPoint(q->b, q->j, q->mb, od_Scale(-1.0, n));
	*w = od_Sub(od_Sub(pa, pb), q->d);
	return -od_Dot(n, *w);
}

// Unit u, or false where it has no length.
static bool od_MakeUnit(od_Vec3* u)
{
	double length = od_Length(*u);
	*u = length > 0.0 ? od_Scale(1.0 / length, *u) : *u;
	return length > 0.0;
}

// Refinement steps of a pair's normal (od_SkinPair_Normal), and how far apart along its centre line (of its
// ellipsoids' largest radii, beyond the thickness) a pair is taken along it at once: farther than contact and than
// the forces' near pairs (body_contact.c, OD_NEAR_SLACK: 0.25). The bars at rest on each other took 6.0 ms a step
// without it, 5.3 with it (0.60 on the ellipsoids; scripts/skin_pairs.py --cost). Where only whether a pair is in
// contact matters (body_contact.c, od_Measure), a pair apart beyond the thickness along its centre line or last
// normal settles there: the add-on's two Suzannes at rest on each other on their skins (7,958 vertices, 10 steps a
// frame), the projection's measures 912 -> 327 M instructions (callgrind).
#define OD_NORMAL_STEPS 4
#define OD_CLEAR 0.5

od_Vec3 od_SkinPair_Normal(const od_SkinPair* q, const od_Vec3* directions, int count)
{
	od_Vec3 best = directions[0], w;
	double farthest = od_Apart(q, best, &w);
	if (farthest > q->thickness + OD_CLEAR * (od_ParticleReach(q->a, q->i) + od_ParticleReach(q->b, q->j)))
	{
		return best;
	}
	for (int k = 1; k < count && !(q->settle && farthest > q->thickness); ++k)
	{
		od_Vec3 n = directions[k], wk;
		double apart = od_MakeUnit(&n) ? od_Apart(q, n, &wk) : -INFINITY;
		if (apart > farthest)
		{
			farthest = apart;
			best = n;
			w = wk;
		}
	}
	if (q->settle && farthest > q->thickness)
	{
		return best;
	}
	// Then along the distance's gradient (the overlap's, tangential, negated), the step halved until it gains.
	double rate = 1.0 / (od_SkinPair_Reach(q->a, q->i) + od_SkinPair_Reach(q->b, q->j));
	for (int step = 0; step < OD_NORMAL_STEPS; ++step)
	{
		od_Vec3 n = od_MulAdd(best, -rate, od_MulAdd(w, -od_Dot(w, best), best)), wn;
		if (!od_MakeUnit(&n))
		{
			break;
		}
		double apart = od_Apart(q, n, &wn);
		if (apart > farthest)
		{
			farthest = apart;
			best = n;
			w = wn;
		}
		else
		{
			rate *= 0.5;
		}
	}
	return best;
}
