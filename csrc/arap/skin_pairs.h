// The skin as the contact shape between the bodies of a group (skin_pairs.c).
#pragma once

#include "math3.h"
#include "sim.h"

#include <stdbool.h>

// Contact between the bodies of a group (body_contact.c): whether a pair of particles of sims a and b meets on
// a member's skin (two bodies, either with a contact skin; self-contact keeps the ellipsoids).
bool od_SkinPair_Used(const od_Sim* a, const od_Sim* b);
// How far particle i's shape reaches along unit n in such a pair: its skin points' at its current rotation, or
// its ellipsoid's (moment M) where its simulation has no contact skin.
double od_SkinPair_Support(const od_Sim* sim, int i, const od_Mat3* moment, od_Vec3 n);
// The farthest from its centre either of particle i's shapes reaches (the broad phase's spheres).
double od_SkinPair_Reach(const od_Sim* sim, int i);
// A pair of particles of two bodies: i of a (moment ma), j of b (mb), b's centre at d from a's, in contact
// within `thickness`.
typedef struct od_SkinPair
{
	const od_Sim *a, *b;
	int i, j;
	const od_Mat3 *ma, *mb;
	od_Vec3 d;
	double thickness;
	bool settle; // any direction along which the pair is apart beyond the thickness will do (od_SkinPair_Normal)
} od_SkinPair;
// The pair's normal, as a separating axis: of `count` directions (directions[0] unit, the others of any length, 0
// for none), the one along which the pair is the farthest apart (d·n less their supports towards each other), then
// refined along that distance's gradient. A pair clear of contact along directions[0] (farther than the thickness
// and half its ellipsoids' largest radii) is taken along it at once; with q->settle, so is one apart beyond the
// thickness along any of the directions (no refinement).
od_Vec3 od_SkinPair_Normal(const od_SkinPair* q, const od_Vec3* directions, int count);
