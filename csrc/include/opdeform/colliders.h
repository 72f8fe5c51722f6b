// opdeform: scene colliders of an ARAP simulation (docs/contact.md), the public C API.
//
// A collider is a signed distance (collide/collider.c, the one MPM uses too): a plane, box, sphere, capsule or
// triangle mesh in its own frame. Each particle's ellipsoid touches it at its support along the surface
// normal; contact pushes the particle out to `thickness` from the surface, with Coulomb friction. A collider
// may move and turn (od_Sim_MoveCollider: the frame at the end of the next od_Sim_Step call, reached at
// constant velocity over its steps; contact is tested along the swept motion, so a fast collider does not
// pass through a thin limb) and deform (od_Sim_UpdateColliderVertices re-samples a mesh).
#pragma once

#if defined(OD_LAYER_CHECK) && !defined(OD_USES_ARAP)
#error "opdeform/colliders.h is the arap layer's header, which this layer of csrc/ may not use (docs/architecture.md)"
#endif

#include "opdeform/opdeform.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum od_ColliderShape
{
	OD_COLLIDER_PLANE = 0,   // the half space z < 0 of the collider's frame (any orientation: turn the frame)
	OD_COLLIDER_BOX = 1,     // |x|, |y|, |z| <= halfExtents
	OD_COLLIDER_SPHERE = 2,  // radius
	OD_COLLIDER_CAPSULE = 3, // radius about the segment |z| <= halfLength of the frame's z axis
	OD_COLLIDER_MESH = 4     // triangles: closed (inside by the parity of crossings) or open (inside is behind
	                         // the nearest triangle, whose winding gives its front: counter-clockwise; not
	                         // beyond the rim, the edges of one triangle)
} od_ColliderShape;

typedef struct od_ColliderDef
{
	od_ColliderShape shape;
	double halfExtents[3]; // box
	double radius;         // sphere, capsule
	double halfLength;     // capsule
	int vertexCount;       // mesh, in the collider's frame (copied: not kept)
	const double* vertices;
	int triangleCount;
	const int* triangles;
	int resolution;        // mesh: distance samples along its longest side (8..88, default 64)
	double friction;       // Coulomb coefficient >= 0 (default 0.5)
	double thickness;      // > 0: the particles keep this far from the surface (default 0.005 m)
	double rotation[9];    // the collider's frame in the world (default identity, at the origin)
	double translation[3];
} od_ColliderDef;

od_ColliderDef od_DefaultColliderDef(void);
od_Status od_Sim_AddCollider(od_Sim* sim, const od_ColliderDef* def, int* id);
// The collider's frame at the end of the next od_Sim_Step call; rotation must be proper.
od_Status od_Sim_MoveCollider(od_Sim* sim, int id, const double rotation[9], const double translation[3]);
// New vertices of a mesh collider (vertexCount*3, as many as it has, same triangles, its frame): re-sampled now.
od_Status od_Sim_UpdateColliderVertices(od_Sim* sim, int id, const double* vertices, int vertexCount);
od_Status od_Sim_SetColliderContact(od_Sim* sim, int id, double friction, double thickness);
od_Status od_Sim_RemoveCollider(od_Sim* sim, int id);
int od_Sim_GetColliderCount(const od_Sim* sim);

// The skinned surface as the contact shape of the floor and the colliders (docs/contact.md, "Contact on the
// skin"): point k (points: count*3, rest space, e.g. the skin's vertices) is carried rigidly by particle
// particles[k] (e.g. every particle that skins it), at x_i + R_i (p_k - X̄_i), and those points meet the floor
// and the colliders instead of the particles' ellipsoids (a particle given none: its centre). count 0: the
// ellipsoids again (the default). bodies 1: in a group (below) the points meet the other bodies too; 0: the
// other bodies meet this one's ellipsoids (and it theirs). Self-contact keeps the ellipsoids.
od_Status od_Sim_SetContactSkin(od_Sim* sim, const double* points, const int* particles, int count, int bodies);
int od_Sim_GetContactSkinCount(const od_Sim* sim); // the points given, 0: the ellipsoids

// Moves each point (count*3) that is inside a collider (at its current frame) or below the floor to the
// surface: the skinned mesh shown without passing into them. *moved: how many moved (may be NULL).
od_Status od_Sim_PushOut(const od_Sim* sim, double* points, int count, int* moved);
// The signed distance of each point to the nearest collider or floor (negative inside), INFINITY with none.
od_Status od_Sim_GetColliderDistances(const od_Sim* sim, const double* points, int count, double* distances);

// Contact between particles: of two or more simulations (od_ContactGroup) and of distant parts of one
// (self-contact). Each particle's ellipsoid reaches its support along the line between two centres; a pair
// closer than the sum plus `thickness` is in contact. Between the simulations of a group, contact forces
// (normal, and Coulomb friction against the step's start) act inside the iterations, on the right side of
// every global solve; after the iterations (and before the floor and the colliders) the pairs still in
// contact, and those of self-contact, are pushed apart along that line, mass weighted, with Coulomb friction.
// A pair that was apart at the step's start keeps the start's direction, so a fast pair cannot pass through
// (docs/contact.md).
typedef struct od_BodyContactDef
{
	double thickness;      // > 0: the gap kept between ellipsoids (default 0.005 m)
	double friction;       // Coulomb coefficient >= 0 (default 0.5)
	int exclusionRing;     // self-contact: pairs at most this many edges apart never collide (0..2, default 2)
	double exclusionScale; // self-contact: nor pairs closer at rest than this times the sum of their largest
	                       // radii (>= 0, default 1.5): neighbourhoods that overlap at rest stay at rest; a
	                       // group: pairs of two members whose goals carry the rest, their goal centres closer
	                       // than this times the sum of their largest reaches (a jacket on its body)
	int inIterations;      // a group: 1 (default) contact forces inside the iterations, then the projection;
	                       // 0 the projection after them only (the step then depends on the state alone)
} od_BodyContactDef;

od_BodyContactDef od_DefaultBodyContactDef(void);
// Self-contact of one simulation (def NULL: off); its od_Sim_Step resolves it, as does a group's step.
od_Status od_Sim_SetSelfContact(od_Sim* sim, const od_BodyContactDef* def);
// Whether self-contact is on, and its settings in *def (may be NULL).
int od_Sim_GetSelfContact(const od_Sim* sim, od_BodyContactDef* def);

// Simulations that collide with each other. The group borrows them (keep them alive, one group's step at a
// time): od_ContactGroup_Step steps them all together, each as its od_Sim_Step would, their solves side by
// side with the contact forces between them. They must share the time step. `def`'s exclusionRing is unused
// (different bodies have no shared edges); its exclusionScale leaves out the pairs that the members' goals put
// together (above; docs/contact.md, "Members that overlap at rest").
typedef struct od_ContactGroup od_ContactGroup;
od_Status od_ContactGroup_Create(od_Sim* const* sims, int count, const od_BodyContactDef* def, od_ContactGroup** out);
void od_ContactGroup_Destroy(od_ContactGroup* group);
od_Status od_ContactGroup_SetContact(od_ContactGroup* group, const od_BodyContactDef* def);
od_Status od_ContactGroup_Step(od_ContactGroup* group, int steps);
// What a group keeps from one step to the next besides its members' states: its pairs (global particle
// indices a < b, body-major in the members' order) with their forces (OD_PAIR_VALUES each: the normal force, the
// friction force (3), the normal (3) and the friction's anchor (3): where particle b was from particle a when the
// pair began to stick), the warm start of the next step's forces. Saved with the members' states and
// set back with them, the next step is the one that followed the save, bit for bit (an empty list: a new
// group's). GetPairs writes od_ContactGroup_GetPairCount pairs; SetPairs checks everything before it changes
// anything (indices in range, a < b, finite values, force >= 0, a unit normal, forces that would push their
// particles at most 1 km in one step, an anchor at most 1 km long; |friction| <= friction coefficient × force is
// not checked: the next update bounds it).
#define OD_PAIR_VALUES 10
int od_ContactGroup_GetPairCount(const od_ContactGroup* group);
void od_ContactGroup_GetPairs(const od_ContactGroup* group, int* pairs, double* forces);
od_Status od_ContactGroup_SetPairs(od_ContactGroup* group, int count, const int* pairs, const double* forces);

#ifdef __cplusplus
}
#endif
