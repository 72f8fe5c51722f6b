// Contact with the scene colliders (contact.c): the particles' ellipsoids after a step's iterations, the
// friction rule the floor shares, and the push-out of skinned points (opdeform/colliders.h).
#pragma once

#include "opdeform/colliders.h"
#include "math3.h"
#include "sim.h"

// What a depth query knows of a centre's distance to a collider: φ, and the normal there (in the collider's frame)
// once looked up. The gathering and the projection asked both two or three times at the same centre.
typedef struct od_Centre
{
	double phi;
	od_Vec3 normal;
	bool known; // the normal
} od_Centre;

// The fraction of a tangential slide that Coulomb friction keeps when it may take at most `limit` of it.
double od_CoulombKeep(double slide, double limit);
// Contact over the fraction [s0, s1] of the current call (before: the state at the step's start): moves the
// particles out of the colliders, with friction (scaling angularScale). lifted (NULL: none): where a group member
// rolling on its patch after the projections (od_SurfaceContact_GroupRoll) takes each particle's lift, the floor's
// there before, and its direction (surface.normal), and the lifts' mean friction (surface.rollFriction).
void od_ContactStep(od_Sim* sim, const od_State* before, double s0, double s1, double* lifted);
// Collider c's frames at the fractions s0 and s1 of the call (Ra, ta, Rb, tb and the turn between them).
void od_ColliderFrames(od_SimCollider* c, double s0, double s1);
// How deep particle i's shape (its ellipsoid or its skin points, skin_shape.c) turned by `rotation` and centred at
// x is within the thickness of collider c at its frame at the step's end (end) or start, less what its goal frame
// is (goals carrying the rest); the world normal. Skin points are only sought deeper than `least` (>= 0; `least`
// when none is).
// `centre`: x's at the end frame (od_ColliderCentre), its normal kept there once looked up; NULL: looked up.
double od_ColliderDepth(const od_Sim* sim, const od_SimCollider* c, int i, const double* rotation, od_Vec3 x, bool end,
						double least, od_Vec3* normal, od_Centre* centre);
// The same at the end frame for the skin without goals, at particle i's current rotation, from its point farthest
// along the centre's normal (not a search of its points: the gathering's, surface_contact.c).
double od_SkinTouch(const od_Sim* sim, const od_SimCollider* c, int i, od_Vec3 x, od_Vec3* normal, od_Centre* centre);
// Collider c's at world point x at its end frame: φ alone, one lookup.
od_Centre od_ColliderCentre(const od_SimCollider* c, od_Vec3 x);
// Collider c's thickness plus particle i's contact reach less the distance of its centre at c's end frame
// (od_ColliderCentre): where it is <= 0, no less than what od_ColliderDepth gives there, whatever the rotation or goal.
double od_ColliderDepthBound(const od_Sim* sim, const od_SimCollider* c, int i, const od_Centre* centre);
// Particle i's ellipsoid as its moment M = E diag(a², b², c²) Eᵀ (current frame), its largest radius, and how
// far a particle that began a step inside something may leave it per step (1 m/s).
od_Mat3 od_ParticleMoment(const od_Sim* sim, int i);
// Particle i's ellipsoid turned by `rotation`: (rotation Ē) diag(a², b², c²) (rotation Ē)ᵀ.
od_Mat3 od_EllipsoidMoment(const od_Sim* sim, int i, const double* rotation);
// Inline: the forces' updates ask it for each pressing particle (surface_contact.c, od_Push), as a call 0.07 M
// instructions a step of the colliders bench's 1,000-particle Suzanne on the sphere (27 M).
static inline double od_ParticleReach(const od_Sim* sim, int i)
{
	const double* r = sim->graph->radii + 3 * i;
	double largest = r[0] > r[1] ? r[0] : r[1]; // not fmax: a call to libm (the contact forces' updates ask often)
	return largest > r[2] ? largest : r[2];
}
// The farthest particle i's contact shape reaches from its centre: its skin points' (skin_shape.c) or its ellipsoid's.
double od_ContactReach(const od_Sim* sim, int i);
double od_RecoveryLimit(const od_Sim* sim);
// How far an ellipsoid of moment M reaches along unit n: sqrt(nᵀ M n).
double od_Support(const od_Mat3* M, od_Vec3 n);
