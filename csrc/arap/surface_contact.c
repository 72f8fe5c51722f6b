// Contact with the floor and the scene colliders inside a step's iterations (issue 27, docs/contact.md).
//
// Design: as between the bodies of a contact group (body_contact.c), each particle near a surface carries a
// normal force f >= 0 along the surface's normal and a friction force t, |t| <= μ f, on the right side of
// every global solve (sim->surface.force, global_solve.c): the objective gains -F·x, the matrix is unchanged,
// nothing is refactored. After each solve the forces move towards the constraints (dual ascent): f grows by a
// rate times the depth of the particle's ellipsoid in the surface (beyond what one that began inside may keep)
// and shrinks while it is clear; t grows against the particle's displacement along the surface since the
// step's start (relative to the surface's own motion), so that friction holds the whole step, not one
// iteration. The local step then fits the rotations to centres that already hold the contact; the projection
// after the iterations (floor.c, contact.c) stays, for what the forces leave (at rest nearly nothing) and for
// fast particles (its sweep keeps them from tunnelling; the forces see the step's end only).
//
// Why not the other designs the brief names, measured or reasoned on the same scenes: a projection target
// with a weight folded into the matrix for the active particles re-analyses and refactors the matrix at
// every change of the set (global_solve.c refactors from the triplets: a body landing changes it every
// step); one weight added to the diagonal of every particle once drags every free particle towards its last
// iterate (a falling body's centres converge as w / (w + m/h²) per iteration: for a stiff contact, w >> m/h²,
// barely at all). The forces cost a right side only.
//
// Warm start (fixed counts): each particle that pressed a surface at a step's end carries its normal force to
// the next step (carried, part of the state: od_Sim_GetSurfaceForces / RestoreSurfaceForces, pickles, the
// add-on's frame cache, a shot's checkpoint), and starts the dual ascent from it when it is near the same surface
// after the first solve; friction starts from zero. Without it a stiff body at rest had ten updates a step to
// rebuild its weight's support from zero: a k = 1e15 capsule on the floor stayed 6.1 mm (1 %) off its rigid
// shape at 1/24 s, 3.8 at 1/60; with it 1.3 and 0.0. The first solve still sees no force (the carried forces
// there too turned the Rubber cube sliding down a 30-degree ramp 21 degrees at 1/60 s), and carrying the
// friction forces too locked a stiff body's shape (6.45 mm). Under a tolerance (3 updates, then held) nothing
// is carried: there the warm start rolled the add-on's Suzanne off a mesh sphere within 3 s, which stays on
// without it.
//
// Turn (od_SurfaceContact_Turn, after the iterations, before the projections): the forces move a stiff body
// only as a whole within a step (the global solves hold the rotations, and k = 1e15 lets a force at one particle
// move it only with the body), so the pose it lands in left one particle of the capsule 1.35 mm deep, lifted
// alone by the projection every step and put back by the next step's rotations, fitted before the lift. So each
// piece with a particle still inside its surface's plane is turned as a rigid body would be to come out: the
// translation and rotation about its centre of mass that bring its near particles out with impulses >= 0
// (projected Gauss-Seidel, OD_TURN_SWEEPS sweeps), its rotation applied to centres and rotations (the translation
// is the forces' share's and the projection's: applied as well, it took the projection's lift, and with it the
// friction the projection gives, and the cube slid 4.7 m at μ = 0.3 against Coulomb's 3.90). The capsule then
// stays within 0.73 mm at 1/24 s. Each particle's depth there, and in the rolling resistance's turn, is its
// held point's (od_HeldDepth), not a search of its skin points: the search was 5.7 % of the colliders bench's
// 1,000-particle Suzanne's step on the sphere. The support the projection then gives (its lift) carries its
// friction to the piece as a whole too (od_TurnFriction): on single particles of a stiff body it was undone, and
// the colliders bench's Suzanne (k = 1e6) slid down the ramp at 0.89 m/s² (Coulomb 0.66; its forces inside the
// iterations carry 0.90-0.94 of its weight); now 0.79, 0.70 from 1.2 s on; the soft cube's projection keeps its
// own friction as well, 3.79-3.96 m against Coulomb's 3.90.
//
// The rate is that of a free particle, m / h² (the group's OD_FORCE_RATE 1): a particle bound to its body
// moves less, so this under-relaxes: with c of a body's N particles touching, its rigid motion closes only
// c/N of the remaining depth per solve. So each pressing particle also takes its share (by mass) of what moves
// its connected piece, rigid, by the pressing particles' mean depth. A soft piece moves more than that where
// it is pushed (a 100-particle creature resting on a sphere swung 3 cm between solves, every solve): when the
// mean depth changes sign between updates, the piece's share is halved for the rest of the step.
// A piece whose inertia outweighs its edges within a step (a slab of 1e8 kg/m³ at 1/240 s) does not move rigid:
// its share is scaled by how far they do (od_Rigidity).
//
// A particle counts as near a surface after the step's first solve (within a quarter of its largest radius);
// a collider it began clear of counts only on the side it began (a fast particle beyond a thin collider is the
// sweep's). Its surface is the deepest of the floor and the colliders then, taken for the rest of the step as
// its tangent plane there (normal n, level): the depth at an update is level + (reach of its ellipsoid along n
// at its current rotation) - n·x, and its slide is measured from where its step began, carried with the surface
// (anchor). One distance query a step, not one per solve: the creature on a sphere at 100 particles went from
// 1.72x to 1.44x free fall; the surface moves a few millimetres within a step at rest.
//
// Under a tolerance (the add-on's and the presets' solver) the forces are updated after the step's first
// OD_SURFACE_UPDATES solves only, then held, and the step's plan starts again from that iterate (step.c: auto
// probes and turns Chebyshev on where the pairs contract slowly). Updated after every solve, they kept the
// iteration plain (an accelerator would extrapolate their changes) and a body that deforms in contact contracts
// slowly under plain pairs (a resting Suzanne's residual fell about 1 % a pair): 92-94 pairs a step, nearly every
// step at the cap; held after 10 updates with the plan left plain, still 88-97. Held after 3 with the plan
// restarted: 25-27 in contact, as the projection alone; the cube on the ramp still holds at μ = 1 and slides
// within 0.3 % of the earlier figures at μ = 0.3 (docs/contact.md). Fixed counts update them after every solve.
//
// Rolling resistance (od_SurfaceContact_Roll, after the projections). Rolling without slipping costs a round
// elastic body no work, so friction cannot stop it: a soft blob dropped on a sphere rolled off in 2 s (a rigid
// ball balanced there does, at the same rate). What holds a real one is its contact patch: the pressure moves
// towards the patch's front edge, a moment of at most N a (a the patch's size). Each piece pressing a surface
// has its spin over the step (angular momentum about its centre of mass, so a piece that slides without
// turning is left alone) taken back by at most μ N a h per step (N its particles' normal forces, Σ μ f their
// friction, a the force-weighted spread of their centres along the surface), turned about the patch centre as
// far as the friction its forces left unused allows (so the patch stays put, as in rolling), never so that the
// kinetic energy rises. Pieces held by a goal or a constraint are left as they are.
// A group member whose floor acts after the iterations (body_contact.c) has no forces here: where its skin meets
// its floor (the add-on's default) the patch is the floor's lifts in the step's projection, each lifted particle's
// normal force m l / h² (od_SurfaceContact_GroupRoll), and the colliders' lifts the same way along their normals
// (contact.c, od_ContactStep; the scene colliders act after the iterations on every member); for a member resting
// on such a one, its pairs' normal forces there (s->push, s->normal, written by body_contact.c). Their friction is all taken as unused (the
// projections' acts on the step before), and a bearing particle the turn moves into what it bears on is put back
// along its normal. A member meeting everything with its ellipsoids (body_contact.c: at steps longer than 1/60 s)
// rolls back on a round patch alone (od_Round: a slab lying on its face has no roll to take back; taken back, its
// spin's jolts let a Stiff slab twice as dense as the one below slide off it at 1/24 s, 0.088 m aside and 0.079 m/s
// with the floor's patch alone), and across the patch's normal alone (its twist is the pairs' friction's: taken
// back too, a Jelly sphere slid off a like one, 0.27 m aside at 13 s).
#include "surface_contact.h"

#include "check.h"
#include "contact.h"
#include "core.h"
#include "energy.h"
#include "floor.h"
#include "goal.h"
#include "math3.h"
#include "polar.h"
#include "skin_shape.h"

#include <math.h>
#include <string.h>

#define OD_SURFACE_RATE 1.0 // over m / h², a free particle's
#define OD_SURFACE_SLACK 0.25 // of the largest radius: how far beyond contact a particle after the first solve is near
#define OD_FLOOR OD_SURFACE_FLOOR
#define OD_SURFACE_UPDATES 3 // under a tolerance, the forces' updates in a step (then held: see the top of the file)
#define OD_SHARE_MOVE 0.5 // of the largest radius: how far a piece's share moves a pressing particle at most (od_Push)
#define OD_TURN_SWEEPS 10 // of the pieces' rigid corrections after the iterations (od_SurfaceContact_Turn)
#define OD_TURN_ROW 8 // per near particle in od_SurfaceContact_Turn: impulse, 1 / (its rigid response), r × n, I⁻¹ (r × n)
// A group member meeting everything with its ellipsoids rolls back on a patch narrower than this times its centre
// of mass's height above it (od_Round; see the top of the file). Measured at 1/24 s on the stacking bench (a the
// patch's spread, c that height, every step of 13 s): spheres a/c 1.1-1.9 on the floor and 0-0.4 on the sphere below,
// creatures 1.7-3.2 and 0.7-0.9, slabs 16-19 on the floor and 4.9-14 on the slab below.
#define OD_ROUND 4.0
#define OD_PIECE 5 // per connected piece: mass, pressing mass, Σ m excess, the last update's mean excess, relaxation

// A connected piece's contact patch at a step's end (its pressing particles: their normal force N, Σ μ f,
// force-weighted centre, normal and spread) and its particles' mass, momentum and second moments (rolling).
typedef struct od_Patch
{
	double force, friction, spare, spread; // N, Σ μ f, Σ (μ f - |t|), a²
	od_Vec3 centre, normal;                // force-weighted
	double mass;                           // of the piece
	bool held;                             // by a goal or a constraint: not turned
	od_Vec3 moment, lever, drift;          // Σ m r × d, Σ m r, Σ m d (r = x - centre, d the step's displacement)
	od_Mat3 second;                        // Σ m r rᵀ
	od_Mat3 turn;                          // Roll's x -> centre + turn (x - centre) + shift; Turn's rotation
	od_Vec3 shift;
	od_Mat3 inverse;                       // od_SurfaceContact_Turn: the inverse inertia about the centre of mass,
	od_Vec3 middle, move, spin;            // the centre of mass, the rigid correction's translation and rotation,
	od_Vec3 slip;                          // Σ m l s over its particles lifted by l after the iterations (the
	double lifted, grip;                   // projection's, the turn's keep-out), s their slide; Σ m l and Σ μ m l
} od_Patch;

void od_SurfaceContact_Destroy(od_SurfaceContact* s)
{
	od_Free(s->force);
	od_Free(s->normal);
	od_Free(s->tangent);
	od_Free(s->push);
	od_Free(s->level);
	od_Free(s->anchor);
	od_Free(s->excess);
	od_Free(s->hold);
	od_Free(s->given);
	od_Free(s->piece);
	od_Free(s->patch);
	od_Free(s->source);
	od_Free(s->point);
	od_Free(s->near);
	od_Free(s->carried);
	od_Free(s->carriedSource);
	od_Free(s->keptCarried);
	od_Free(s->keptSource);
	od_Free(s->impulse);
	*s = (od_SurfaceContact){ 0 };
}

od_Status od_SurfaceContact_Reserve(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	if (s->force || !(sim->hasFloor || sim->colliders.count))
	{
		return OD_OK;
	}
	size_t n = (size_t)sim->graph->n;
	s->force = od_AllocZero(3 * n, sizeof(double));
	s->normal = od_AllocZero(3 * n, sizeof(double));
	s->tangent = od_AllocZero(3 * n, sizeof(double));
	s->push = od_AllocZero(n, sizeof(double));
	s->level = od_AllocZero(n, sizeof(double));
	s->anchor = od_AllocZero(3 * n, sizeof(double));
	s->excess = od_AllocZero(n, sizeof(double));
	s->hold = od_AllocZero(n, sizeof(double));
	s->given = od_AllocZero(n, sizeof(double));
	s->piece = od_AllocZero(OD_PIECE * (size_t)sim->graph->pieceCount, sizeof(double));
	s->patch = od_AllocZero((size_t)sim->graph->pieceCount, sizeof(od_Patch));
	s->source = od_AllocZero(n, sizeof(int));
	s->point = od_AllocZero(n, sizeof(int));
	s->near = od_AllocZero(n, sizeof(int));
	s->carried = od_AllocZero(3 * n, sizeof(double));
	s->carriedSource = od_AllocZero(n, sizeof(int));
	s->keptCarried = od_AllocZero(3 * n, sizeof(double));
	s->keptSource = od_AllocZero(n, sizeof(int));
	s->impulse = od_AllocZero(OD_TURN_ROW * n, sizeof(double));
	if (!s->force || !s->normal || !s->tangent || !s->push || !s->level || !s->anchor || !s->excess || !s->hold || !s->given ||
		!s->piece || !s->patch || !s->source || !s->point || !s->near || !s->carried || !s->carriedSource ||
		!s->keptCarried || !s->keptSource || !s->impulse)
	{
		od_SurfaceContact_Destroy(s);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the contact of %d particles", sim->graph->n);
	}
	od_SurfaceContact_Forget(sim);
	return OD_OK;
}

void od_SurfaceContact_Forget(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	for (int i = 0; s->carried && i < sim->graph->n; ++i)
	{
		od_V3Store(s->carried + 3 * i, od_V3(0, 0, 0));
		s->carriedSource[i] = -2;
	}
}

void od_Sim_GetSurfaceForces(const od_Sim* sim, double* forces, int* surfaces)
{
	const od_SurfaceContact* s = &sim->surface;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_V3Store(forces + 3 * i, s->carried ? od_V3Load(s->carried + 3 * i) : od_V3(0, 0, 0));
		surfaces[i] = s->carried ? s->carriedSource[i] : -2;
	}
}

od_Status od_Sim_RestoreSurfaceForces(od_Sim* sim, const double* forces, const int* surfaces)
{
	int n = sim->graph->n;
	if (!forces || !surfaces)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "surface forces: forces and surfaces are required");
	}
	od_Status status = od_CheckFinite("surface forces", forces, 3 * n);
	for (int i = 0; status == OD_OK && i < n; ++i)
	{
		bool known = surfaces[i] == -2 || (surfaces[i] == OD_FLOOR && sim->hasFloor) ||
					 (surfaces[i] >= 0 && surfaces[i] < sim->colliders.count);
		status = known ? OD_OK
					   : od_Fail(OD_ERROR_ARGUMENT, "surface forces: particle %d presses surface %d, which is not there "
													"(-2 none, -1 the floor, 0..%d the colliders)",
								 i, surfaces[i], sim->colliders.count - 1);
	}
	status = status == OD_OK ? od_SurfaceContact_Reserve(sim) : status;
	if (status != OD_OK || !sim->surface.carried)
	{
		return status; // no floor and no collider: every surface is -2, nothing to carry
	}
	for (int i = 0; i < n; ++i)
	{
		bool pressed = surfaces[i] != -2;
		od_V3Store(sim->surface.carried + 3 * i, pressed ? od_V3Load(forces + 3 * i) : od_V3(0, 0, 0));
		sim->surface.carriedSource[i] = surfaces[i];
	}
	return OD_OK;
}

void od_SurfaceContact_BeginCall(od_Sim* sim, int steps)
{
	sim->surface.after = false;
	sim->surface.rolls = OD_ROLL_NONE;
	sim->surface.callSteps = steps;
	sim->surface.callStep = 0;
	if (sim->surface.carried)
	{
		memcpy(sim->surface.keptCarried, sim->surface.carried, sizeof(double) * 3 * (size_t)sim->graph->n);
		memcpy(sim->surface.keptSource, sim->surface.carriedSource, sizeof(int) * (size_t)sim->graph->n);
	}
}

void od_SurfaceContact_EndCall(od_Sim* sim, bool ok)
{
	if (!ok && sim->surface.carried)
	{
		memcpy(sim->surface.carried, sim->surface.keptCarried, sizeof(double) * 3 * (size_t)sim->graph->n);
		memcpy(sim->surface.carriedSource, sim->surface.keptSource, sizeof(int) * (size_t)sim->graph->n);
	}
}

// Whether particle i may touch a surface in this step: its predicted centre within its largest radius, the
// thickness and its predicted motion of one (conservative: a sphere about the ellipsoid).
static bool od_MayTouch(const od_Sim* sim, int i)
{
	od_Vec3 y = od_V3Load(sim->y + 3 * i);
	double reach = od_ContactReach(sim, i) + od_Length(od_Sub(y, od_V3Load(sim->state.x + 3 * i)));
	if (sim->hasFloor && y.z - sim->floorHeight < reach)
	{
		return true;
	}
	for (int k = 0; k < sim->colliders.count; ++k)
	{
		const od_SimCollider* c = &sim->colliders.items[k];
		od_Vec3 l = od_M3MulTV(&c->Rb, od_Sub(y, c->tb));
		double moved = od_Length(od_Sub(c->tb, c->ta)) + od_Length(c->turn) * od_Length(l); // its surface's motion
		if (od_Collider_LocalDistance(&c->body, l, NULL) < reach + c->thickness + moved)
		{
			return true;
		}
	}
	return false;
}

// Each piece's share's relaxation at a step's start (od_Push): how far its elastic edges outweigh its inertia on
// the global matrix's diagonal (Σ k w_ij (u_i + u_j) over Σ m / h²), at most 1. A piece whose inertia outweighs its
// edges does not move rigid within a step, so the share, the rigid piece's Newton step put on its pressing
// particles, threw them: a Stiff slab of 1e8 kg/m³ dropped 0.05 m onto the floor at 240 steps a second gained
// 2.0e8 J (its centres' kinetic and potential energy above its start), a Rubber one of 1e5 kg/m³ 13 kJ.
static void od_Rigidity(od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	const double* u = od_ElasticVolumes(sim);
	double* piece = sim->surface.piece;
	for (int i = 0; i < g->n; ++i)
	{
		for (int k = g->adjStart[i]; k < g->adjStart[i + 1]; ++k)
		{
			piece[OD_PIECE * g->piece[i] + 4] += sim->def.stiffness * od_EdgeVolume(sim, u, i, k);
		}
	}
	double h2 = sim->def.dt * sim->def.dt;
	for (int p = 0; p < g->pieceCount; ++p)
	{
		double ratio = piece[OD_PIECE * p + 4] * h2 / piece[OD_PIECE * p];
		piece[OD_PIECE * p + 4] = ratio < 1.0 ? ratio : 1.0;
	}
}

bool od_SurfaceContact_Start(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	s->gathered = false;
	s->nearCount = 0;
	s->updates = 0;
	if (s->force)
	{
		memset(s->hold, 0, sizeof(double) * (size_t)sim->graph->n);
		memset(s->given, 0, sizeof(double) * (size_t)sim->graph->n);
	}
	if (!s->force || s->after)
	{
		s->gathered = s->force != NULL; // nothing near: no forces
		return false;
	}
	double s0 = (double)s->callStep / s->callSteps, s1 = (double)(s->callStep + 1) / s->callSteps;
	for (int k = 0; k < sim->colliders.count; ++k)
	{
		od_ColliderFrames(&sim->colliders.items[k], s0, s1);
	}
	memset(s->piece, 0, sizeof(double) * OD_PIECE * (size_t)sim->graph->pieceCount);
	memset(s->push, 0, sizeof(double) * (size_t)sim->graph->n);
	memset(s->tangent, 0, sizeof(double) * 3 * (size_t)sim->graph->n);
	bool touching = false;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		s->piece[OD_PIECE * sim->graph->piece[i]] += sim->def.density * sim->graph->volumes[i];
		touching = touching || s->carriedSource[i] != -2 || od_MayTouch(sim, i);
	}
	if (touching)
	{
		od_Rigidity(sim);
	}
	return touching;
}

// Where particle i (centre x, moment M) meets a surface: how deep (<= 0: clear) and the normal; where the
// particle's step started on it, carried with the surface to its end frame (its slide is measured from there).
typedef struct od_Touch
{
	double depth;
	od_Vec3 normal, anchor;
} od_Touch;

static od_Touch od_FloorTouch(const od_Sim* sim, int i, od_Vec3 x)
{
	double centre[3] = { x.x, x.y, x.z };
	return (od_Touch){ .depth = od_FloorDepth(sim, i, sim->state.R + 9 * i, centre),
					   .normal = od_V3(0, 0, 1),
					   .anchor = od_V3Load(sim->previous.x + 3 * i) };
}

static od_Touch od_ColliderTouch(const od_Sim* sim, const od_SimCollider* c, int i, od_Vec3 x, od_Centre* centre)
{
	od_Touch t = { 0 };
	t.depth = od_SkinShape_Used(sim) && !od_Goals_CarryRest(sim)
				  ? od_SkinTouch(sim, c, i, x, &t.normal, centre)
				  : od_ColliderDepth(sim, c, i, sim->state.R + 9 * i, x, true, 0.0, &t.normal, centre);
	od_Vec3 la = od_M3MulTV(&c->Ra, od_Sub(od_V3Load(sim->previous.x + 3 * i), c->ta));
	t.anchor = od_Add(od_M3MulV(&c->Rb, la), c->tb);
	return t;
}

// The deepest surface particle i meets at its current centre and rotation (source: OD_FLOOR or a collider's
// index; -2 and depth -inf when there is none). A collider that the particle is surely more than `slack` clear of
// is passed over by one distance lookup (od_ColliderDepthBound): its depth and normal, with the goal frame's
// depth, took 15 % of a step of the character bench's 1,000-particle creature, nearly all of it clear of its floor.
static od_Touch od_Deepest(const od_Sim* sim, int i, double slack, int* source)
{
	od_Vec3 x = od_V3Load(sim->state.x + 3 * i);
	od_Touch best = { .depth = -INFINITY };
	*source = -2;
	if (sim->hasFloor)
	{
		best = od_FloorTouch(sim, i, x);
		*source = OD_FLOOR;
	}
	for (int k = 0; k < sim->colliders.count; ++k)
	{
		od_Centre centre = od_ColliderCentre(&sim->colliders.items[k], x);
		if (!(od_ColliderDepthBound(sim, &sim->colliders.items[k], i, &centre) > -slack))
		{
			continue; // its depth is no more: it cannot make the particle near
		}
		od_Touch t = od_ColliderTouch(sim, &sim->colliders.items[k], i, x, &centre);
		if (t.depth > best.depth)
		{
			best = t;
			*source = k;
		}
	}
	return best;
}

// How deep particle i began the step in its surface (previous centre and rotation, the collider's start frame),
// and that surface's normal there; skin points only sought deeper than `least`.
static double od_StartDepth(const od_Sim* sim, int i, int source, double least, od_Vec3* normal)
{
	const double* x0 = sim->previous.x + 3 * i;
	if (source == OD_FLOOR)
	{
		*normal = od_V3(0, 0, 1);
		return od_FloorDepth(sim, i, sim->previous.R + 9 * i, x0);
	}
	return od_ColliderDepth(sim, &sim->colliders.items[source], i, sim->previous.R + 9 * i, od_V3Load(x0), false, least,
							normal, NULL);
}

// How far particle i's ellipsoid reaches along -n at its current rotation R: |diag(r) Ēᵀ Rᵀ n|.
static double od_EllipsoidReach(const od_Sim* sim, int i, od_Vec3 n)
{
	od_Mat3 rotation = od_M3Load(sim->state.R + 9 * i), axes = od_M3Load(sim->graph->axes + 9 * i);
	od_Vec3 w = od_M3MulTV(&axes, od_M3MulTV(&rotation, n));
	const double* r = sim->graph->radii + 3 * i;
	return sqrt(r[0] * r[0] * w.x * w.x + r[1] * r[1] * w.y * w.y + r[2] * r[2] * w.z * w.z);
}

// The same for its contact shape: the ellipsoid, or its skin points' largest -n·R o (skin_shape.c), that point
// written to *point (NULL: not wanted).
static double od_Reach(const od_Sim* sim, int i, od_Vec3 n, int* point)
{
	return od_SkinShape_Used(sim) ? od_SkinShape_Support(sim, i, sim->state.R + 9 * i, n, point)
								  : od_EllipsoidReach(sim, i, n);
}

// The same in the forces' updates: the skin's point found at the gathering (od_Near), at the current rotation.
// Within a step a particle turns little, so the point that reaches farthest stays the same or another reaches
// about as far; the search over all its points took 0.17 ms a step of the colliders bench's 1,000-particle
// Suzanne on the ramp (2.3 ms).
static inline __attribute__((always_inline)) double od_HeldReach(const od_Sim* sim, int i, od_Vec3 n)
{
	return od_SkinShape_Used(sim) ? od_SkinShape_PointSupport(sim, sim->surface.point[i], sim->state.R + 9 * i, n)
								  : od_EllipsoidReach(sim, i, n);
}

// Particle i's depth beyond the allowed one in its plane, by the point held for the step (od_HeldReach).
static inline __attribute__((always_inline)) double od_HeldDepth(const od_Sim* sim, int i)
{
	const od_SurfaceContact* s = &sim->surface;
	od_Vec3 n = od_V3Load(s->normal + 3 * i);
	return s->level[i] + od_HeldReach(sim, i, n) - od_Dot(n, od_V3Load(sim->state.x + 3 * i));
}

// Whether particle i is near a surface at its current centre (see the top of the file); if so, that surface
// taken as its tangent plane for the step: the depth beyond what it may keep (one that began inside leaves at
// the recovery speed) is then level + reach along the normal - normal·x.
static bool od_Near(od_Sim* sim, int i)
{
	od_SurfaceContact* s = &sim->surface;
	int source;
	double slack = OD_SURFACE_SLACK * od_ParticleReach(sim, i);
	od_Touch t = od_Deepest(sim, i, slack, &source);
	if (!(t.depth > -slack))
	{
		return false;
	}
	// Only what it began deeper than the recovery counts (it may keep the rest), so the skin's points are sought
	// beyond that alone: sought beyond 0, the start's depth took 0.16 ms a step of the colliders bench's
	// 1,000-particle Suzanne on the ramp (2.2 ms), its 870 particles near.
	od_Vec3 n0;
	double recovery = od_RecoveryLimit(sim), began = od_StartDepth(sim, i, source, recovery, &n0);
	if (began <= recovery && od_Dot(n0, t.normal) <= 0.0)
	{
		return false; // passed a thin collider in the first solve: the sweep's
	}
	double allowed = fmax(began - recovery, 0.0);
	s->source[i] = source;
	s->level[i] = t.depth - allowed - od_Reach(sim, i, t.normal, s->point + i) +
				  od_Dot(t.normal, od_V3Load(sim->state.x + 3 * i));
	od_V3Store(s->normal + 3 * i, t.normal);
	od_V3Store(s->anchor + 3 * i, t.anchor);
	return true;
}

// After the step's first solve: the particles near a surface (no force yet).
static void od_Gather(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	s->nearCount = 0;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		if (od_Near(sim, i))
		{
			s->near[s->nearCount++] = i; // it keeps its warm start while it presses the same surface
			s->push[i] = s->carriedSource[i] == s->source[i] ? od_Length(od_V3Load(s->carried + 3 * i)) : 0.0;
		}
		else
		{
			s->source[i] = -2; // none (od_SurfaceContact_Near)
		}
	}
	s->gathered = true;
}

// Whether particle i presses its surface or would: inside its plane, or pushed by the last update.
static bool od_Pressing(const od_SurfaceContact* s, int i)
{
	return s->excess[i] > 0.0 || s->push[i] > 0.0;
}

// Particle i's depth beyond the allowed one in its plane (s->excess) and, where it presses, its slide along it
// since the step's start (s->force, until od_Push writes the force); a pressing particle's mass and excess summed
// per piece.
static void od_Measure(od_Sim* sim, int i)
{
	od_SurfaceContact* s = &sim->surface;
	s->excess[i] = od_HeldDepth(sim, i);
	if (!od_Pressing(s, i))
	{
		return;
	}
	od_Vec3 x = od_V3Load(sim->state.x + 3 * i), n = od_V3Load(s->normal + 3 * i);
	od_Vec3 slip = od_Sub(x, od_V3Load(s->anchor + 3 * i));
	od_V3Store(s->force + 3 * i, od_MulAdd(slip, -od_Dot(slip, n), n));
	double m = sim->def.density * sim->graph->volumes[i], *piece = s->piece + OD_PIECE * sim->graph->piece[i];
	piece[1] += m;
	piece[2] += m * s->excess[i];
}

static double od_FrictionOf(const od_Sim* sim, int source)
{
	return source == OD_FLOOR ? sim->floorFriction : sim->colliders.items[source].friction;
}

// One update of particle i's forces (dual ascent, see the top of the file): its own step, m/h² times its
// excess, and its share (by mass) of its piece's: what moves the piece, rigid, by its pressing particles' mean
// excess, less what their own steps do. That share moves the particle by at most OD_SHARE_MOVE of its largest
// radius: the first few particles of a landing body took the whole piece's and were pushed through their
// neighbours (their local matrices inverted: 221-293 SVD fallbacks of the local step in a 1,000-particle Suzanne's
// landing on the colliders bench's ramp and sphere, 0 so).
// A particle that does not press (od_Pressing) gets f = 0, so no friction either (at most μ f): its forces are
// zeroed, not computed, and its slide not measured (the ten updates of the colliders bench's 1,000-particle
// Suzanne on the ramp, about half of its near particles clear, took 2.20 M instructions a step, 1.73 M so). Computed,
// they were zeros too, of either sign: added to the global solve's right side they change nothing (the replay's
// state hashes are the same).
static void od_Push(od_Sim* sim, int i, double h2)
{
	od_SurfaceContact* s = &sim->surface;
	if (!od_Pressing(s, i))
	{
		s->push[i] = 0.0;
		memset(s->tangent + 3 * i, 0, sizeof(double) * 3);
		memset(s->force + 3 * i, 0, sizeof(double) * 3);
		return;
	}
	double m = sim->def.density * sim->graph->volumes[i];
	const double* piece = s->piece + OD_PIECE * sim->graph->piece[i];
	double f = s->push[i] + OD_SURFACE_RATE * m * s->excess[i] / h2;
	double share = piece[4] * m / piece[1] * (piece[0] - piece[1]) * (piece[2] / piece[1]);
	double most = OD_SHARE_MOVE * m * od_ParticleReach(sim, i); // as a move of the particle: times m / h²
	f += (share > most ? most : share < -most ? -most : share) / h2; // not fmin / fmax: calls to libm
	f = f > 0.0 ? f : 0.0;
	od_Vec3 n = od_V3Load(s->normal + 3 * i), slip = od_V3Load(s->force + 3 * i);
	od_Vec3 tangent = od_MulAdd(od_V3Load(s->tangent + 3 * i), -OD_SURFACE_RATE * m / h2, slip);
	tangent = od_MulAdd(tangent, -od_Dot(tangent, n), n);
	double length = od_Length(tangent), limit = od_FrictionOf(sim, s->source[i]) * f;
	tangent = length > limit ? od_Scale(length > 0.0 ? limit / length : 0.0, tangent) : tangent;
	s->push[i] = f;
	od_V3Store(s->tangent + 3 * i, tangent);
	od_V3Store(s->force + 3 * i, od_MulAdd(tangent, f, n));
}

od_SurfaceUpdate od_SurfaceContact_Update(od_Sim* sim, bool tolerance)
{
	od_SurfaceContact* s = &sim->surface;
	if (!s->force || s->after)
	{
		return OD_SURFACE_NONE;
	}
	if (!s->gathered)
	{
		od_Gather(sim);
	}
	if (!s->nearCount || (tolerance && s->updates > OD_SURFACE_UPDATES))
	{
		return OD_SURFACE_NONE;
	}
	if (tolerance && ++s->updates > OD_SURFACE_UPDATES)
	{
		return OD_SURFACE_HELD;
	}
	for (int p = 0; p < sim->graph->pieceCount; ++p)
	{
		double* piece = s->piece + OD_PIECE * p;
		piece[3] = piece[1] > 0.0 ? piece[2] / piece[1] : 0.0;
		piece[1] = piece[2] = 0.0;
	}
	for (int k = 0; k < s->nearCount; ++k)
	{
		od_Measure(sim, s->near[k]);
	}
	for (int p = 0; p < sim->graph->pieceCount; ++p)
	{
		double* piece = s->piece + OD_PIECE * p; // overshot: the piece's share halved for the rest of the step
		piece[4] *= piece[1] > 0.0 && piece[2] * piece[3] < 0.0 ? 0.5 : 1.0;
	}
	double h2 = sim->def.dt * sim->def.dt;
	for (int k = 0; k < s->nearCount; ++k)
	{
		od_Push(sim, s->near[k], h2);
	}
	return OD_SURFACE_MOVED;
}

void od_SurfaceContact_Finish(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	double h2 = sim->def.dt * sim->def.dt;
	bool fixed = !(sim->solverDef.tolerance > 0.0); // under a tolerance none (see the top of the file)
	od_SurfaceContact_Forget(sim);
	for (int k = 0; s->force && k < s->nearCount; ++k)
	{
		int i = s->near[k];
		double spare = od_FrictionOf(sim, s->source[i]) * s->push[i] - od_Length(od_V3Load(s->tangent + 3 * i));
		s->hold[i] = fmax(spare, 0.0) * h2 / (sim->def.density * sim->graph->volumes[i]);
		memset(s->force + 3 * i, 0, sizeof(double) * 3);
		if (s->push[i] > 0.0 && fixed) // carried to the next step (warm start)
		{
			od_V3Store(s->carried + 3 * i, od_Scale(s->push[i], od_V3Load(s->normal + 3 * i)));
			s->carriedSource[i] = s->source[i];
		}
	}
	s->callStep++;
}

// Rolling resistance (see the top of the file), first: the patches of the pieces that press a surface. False
// when none presses.
static bool od_Patches(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	memset(s->patch, 0, sizeof(od_Patch) * (size_t)sim->graph->pieceCount);
	bool any = false;
	for (int k = 0; k < s->nearCount; ++k)
	{
		int i = s->near[k];
		double f = s->push[i], mu = od_FrictionOf(sim, s->source[i]);
		od_Patch* p = &s->patch[sim->graph->piece[i]];
		if (f > 0.0)
		{
			p->force += f;
			p->friction += mu * f;
			p->spare += fmax(mu * f - od_Length(od_V3Load(s->tangent + 3 * i)), 0.0);
			p->centre = od_MulAdd(p->centre, f, od_V3Load(sim->state.x + 3 * i));
			p->normal = od_MulAdd(p->normal, f, od_V3Load(s->normal + 3 * i));
			any = true;
		}
	}
	for (int p = 0; any && p < sim->graph->pieceCount; ++p)
	{
		od_Patch* patch = &s->patch[p];
		if (patch->force > 0.0)
		{
			patch->centre = od_Scale(1.0 / patch->force, patch->centre);
			patch->normal = od_Scale(1.0 / od_Length(patch->normal), patch->normal);
		}
	}
	for (int k = 0; k < s->nearCount; ++k)
	{
		int i = s->near[k];
		od_Patch* p = &s->patch[sim->graph->piece[i]];
		od_Vec3 d = od_Sub(od_V3Load(sim->state.x + 3 * i), p->centre);
		d = od_MulAdd(d, -od_Dot(d, p->normal), p->normal);
		p->spread += s->push[i] > 0.0 ? s->push[i] * od_Dot(d, d) / p->force : 0.0;
	}
	return any;
}

// Second: each pressing piece's mass and moments about its patch centre; whether a goal or a constraint holds
// it (it is then left as it is: turned, it would leave them).
static void od_PatchMoments(od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	for (int c = 0; c < sim->constraints.count; ++c)
	{
		const od_Constraint* con = &sim->constraints.items[c];
		for (int k = 0; k < con->count; ++k)
		{
			sim->surface.patch[g->piece[con->idx[k]]].held = true;
		}
	}
	for (int i = 0; i < g->n; ++i)
	{
		od_Patch* p = &sim->surface.patch[g->piece[i]];
		p->held = p->held || od_Goals_Hold(sim, i);
		if (p->force > 0.0)
		{
			double m = sim->def.density * g->volumes[i];
			od_Vec3 x = od_V3Load(sim->state.x + 3 * i), r = od_Sub(x, p->centre);
			od_Vec3 d = od_Sub(x, od_V3Load(sim->previous.x + 3 * i));
			p->mass += m;
			p->moment = od_MulAdd(p->moment, m, od_Cross(r, d));
			p->lever = od_MulAdd(p->lever, m, r);
			p->drift = od_MulAdd(p->drift, m, d);
			od_M3AddOuter(&p->second, m, r, r);
		}
	}
}

// The inertia tensor of point masses of second moment S: tr(S) I - S.
static od_Mat3 od_Inertia(od_Mat3 second)
{
	double trace = od_M3Trace(&second);
	for (int k = 0; k < 9; ++k)
	{
		second.m[k] = (k % 4 == 0 ? trace : 0.0) - second.m[k];
	}
	return second;
}

// The most of `level` (the turn across the patch's normal) that can be taken back from a spin whose whole turn is
// `turn` (I turn = spin): the kinetic energy ½ (turn - k level)·I (turn - k level) / h² is least at
// k = level·spin / (level·I level), 1 when level is the whole turn; none when the roll goes against the spin.
static double od_LevelShare(const od_Mat3* inertia, od_Vec3 spin, od_Vec3 level)
{
	double along = od_Dot(level, od_M3MulV(inertia, level));
	return along > 0.0 ? fmax(od_Dot(level, spin), 0.0) / along : 0.0;
}

// Third: piece p's turn over the step about its centre of mass c (its spin: a piece that slides without
// turning has none) taken back by at most the patch's moment μ N a times the step, and by no more than leaves the
// spin's kinetic energy least (k ≤ 1 of the whole turn; of a level one, od_LevelShare: it only drops), then
// shifted so that the patch stays where it was, by at most what the friction its forces left unused moves the
// piece in a step (spare h² / M) and never so that the energy rises.
// Level: only its turn across the patch's normal (a roll, not a twist: od_RollPieces).
static void od_RollBack(od_Patch* p, double h, bool level)
{
	od_Vec3 c = od_Scale(1.0 / p->mass, p->lever); // from the patch centre
	od_Mat3 second = p->second;
	od_M3AddOuter(&second, -p->mass, c, c);
	od_Mat3 inertia = od_Inertia(second);
	od_Vec3 spin = od_Sub(p->moment, od_Cross(c, p->drift)), turn; // angular momentum about c, times h
	double size = od_Length(spin);
	p->turn = od_M3ExpSkew(od_V3(0, 0, 0));
	p->shift = od_V3(0, 0, 0);
	if (!(size > 0.0) || !od_SolveSpd3(&inertia, spin, 1e-12 * od_M3Trace(&inertia), &turn))
	{
		return;
	}
	turn = level ? od_MulAdd(turn, -od_Dot(turn, p->normal), p->normal) : turn;
	double most = level ? fmin(1.0, od_LevelShare(&inertia, spin, turn)) : 1.0;
	double k = fmin(most, h * h * sqrt(p->spread) * p->friction / size);
	p->turn = od_M3ExpSkew(od_Scale(-k, turn));
	// The turn is about c: x -> centre + turn (x - centre) + (c - turn c); the shift that keeps the patch centre
	// is turn c - c, cut to the spare friction's reach and to lowering the energy (drift·s + M |s|² / 2 <= 0).
	od_Vec3 keep = od_Sub(od_M3MulV(&p->turn, c), c);
	double reach = od_Length(keep), along = reach > 0.0 ? -od_Dot(p->drift, keep) / reach : 0.0;
	double cut = fmin(fmin(reach, p->spare * h * h / p->mass), fmax(along, 0.0) / p->mass);
	od_Vec3 shift = reach > 0.0 ? od_Scale(cut / reach, keep) : keep;
	p->shift = od_Add(od_Sub(c, od_M3MulV(&p->turn, c)), shift);
}

// Particle i's part, m l, of its piece's support by a lift l along its surface's normal after the iterations, and its
// slide along the surface since the step's start, summed for od_SlideBack.
static void od_AddLift(od_Sim* sim, int i, double l)
{
	od_SurfaceContact* s = &sim->surface;
	od_Patch* p = &s->patch[sim->graph->piece[i]];
	double weight = l * sim->def.density * sim->graph->volumes[i];
	od_Vec3 n = od_V3Load(s->normal + 3 * i);
	od_Vec3 slide = od_Sub(od_V3Load(sim->state.x + 3 * i), od_V3Load(s->anchor + 3 * i));
	p->slip = od_MulAdd(p->slip, weight, od_MulAdd(slide, -od_Dot(slide, n), n));
	p->lifted += weight;
	p->grip += od_FrictionOf(sim, s->source[i]) * weight;
}

// The friction of the lifts summed by od_AddLift, for each piece as a whole (p->move): its mean slide, weighted by
// m l, taken back by at most Σ μ m l / M (Coulomb's bound on that support, as a move of the piece). Taken back
// from the lifted particles alone (the keep-out's, od_KeepOut), it bent the k = 1e15 capsule at rest 1.6 mm off
// its rigid shape at 1/24 s (0.73 mm as a move of the piece; tests/test_contact.py).
static void od_SlideBack(od_Sim* sim)
{
	for (int q = 0; q < sim->graph->pieceCount; ++q)
	{
		od_Patch* p = &sim->surface.patch[q];
		od_Vec3 mean = p->lifted > 0.0 ? od_Scale(1.0 / p->lifted, p->slip) : od_V3(0, 0, 0);
		double size = od_Length(mean), cut = p->lifted > 0.0 ? p->grip / p->mass : 0.0;
		p->move = size > cut ? od_Scale(-cut / size, mean) : od_Scale(-1.0, mean);
	}
}

// The turn may not take a particle deeper into its surface's plane than the projections left it (turned
// about the patch centre, the skin of a Suzanne on the floor went 0.14 mm into it): lifted back by the
// difference along the normal; that lift is part of the piece's support, and has its friction (od_SlideBack):
// without it, 3-8 % of the weight of the colliders bench's Suzanne sliding down the 30-degree ramp was held by these
// lifts, with no friction, and it slid at 0.93 m/s² at 60 Hz with μ = 0.5 (Coulomb 0.66; docs/contact.md).
static void od_KeepOut(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	bool any = false;
	for (int k = 0; k < s->nearCount; ++k)
	{
		int i = s->near[k];
		double lift = od_HeldDepth(sim, i) - fmax(s->excess[i], 0.0);
		if (s->patch[sim->graph->piece[i]].force > 0.0 && lift > 0.0)
		{
			od_V3Store(sim->state.x + 3 * i, od_MulAdd(od_V3Load(sim->state.x + 3 * i), lift, od_V3Load(s->normal + 3 * i)));
			od_AddLift(sim, i, lift);
			any = true;
		}
	}
	if (!any)
	{
		return;
	}
	od_SlideBack(sim);
	for (int i = 0; i < sim->graph->n; ++i)
	{
		const od_Patch* p = &s->patch[sim->graph->piece[i]];
		if (p->force > 0.0 && p->lifted > 0.0)
		{
			od_V3Store(sim->state.x + 3 * i, od_Add(od_V3Load(sim->state.x + 3 * i), p->move));
		}
	}
}

// The turn's frame for piece p (its centre of mass and inverse inertia about it); false when there is none (a
// piece of one particle on a line).
static bool od_TurnFrame(od_Patch* p)
{
	od_Vec3 c = od_Scale(1.0 / p->mass, p->lever), column[3];
	od_Mat3 second = p->second;
	od_M3AddOuter(&second, -p->mass, c, c);
	od_Mat3 inertia = od_Inertia(second);
	for (int k = 0; k < 3; ++k)
	{
		if (!od_SolveSpd3(&inertia, od_V3(k == 0, k == 1, k == 2), 1e-12 * od_M3Trace(&inertia), &column[k]))
		{
			return false;
		}
	}
	p->inverse = (od_Mat3){ { column[0].x, column[1].x, column[2].x, column[0].y, column[1].y, column[2].y,
							  column[0].z, column[1].z, column[2].z } };
	p->middle = od_Add(p->centre, c);
	p->move = p->spin = od_V3(0, 0, 0);
	return true;
}

// The pieces with a particle left inside its surface's plane after the iterations; false when there is none.
static bool od_TurnPieces(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	const od_Graph* g = sim->graph;
	memset(s->patch, 0, sizeof(od_Patch) * (size_t)g->pieceCount);
	bool any = false;
	for (int k = 0; k < s->nearCount; ++k)
	{
		int i = s->near[k];
		od_Patch* p = &s->patch[g->piece[i]];
		s->excess[i] = od_HeldDepth(sim, i); // the point held for the step: the projection takes the rest
		if (s->excess[i] > 0.0 && !(p->force > 0.0))
		{
			p->force = 1.0; // marks it (od_PatchMoments); the centre only keeps the moments' sums small
			p->centre = od_V3Load(sim->state.x + 3 * i);
			any = true;
		}
	}
	if (any)
	{
		od_PatchMoments(sim);
	}
	for (int p = 0; any && p < g->pieceCount; ++p)
	{
		od_Patch* patch = &s->patch[p];
		patch->force = patch->force > 0.0 && !patch->held && od_TurnFrame(patch) ? 1.0 : 0.0;
	}
	for (int k = 0; any && k < s->nearCount; ++k)
	{
		int i = s->near[k];
		const od_Patch* p = &s->patch[g->piece[i]];
		double* row = s->impulse + OD_TURN_ROW * k;
		od_Vec3 r = od_Sub(od_V3Load(sim->state.x + 3 * i), p->middle);
		od_Vec3 u = od_Cross(r, od_V3Load(s->normal + 3 * i)), turned = od_M3MulV(&p->inverse, u);
		row[0] = 0.0;
		row[1] = p->force > 0.0 ? 1.0 / (1.0 / p->mass + od_Dot(u, turned)) : 0.0;
		od_V3Store(row + 2, u);
		od_V3Store(row + 5, turned);
	}
	return any;
}

// One projected Gauss-Seidel sweep of the pieces' rigid corrections (see od_SurfaceContact_Turn).
static void od_TurnSweep(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	for (int k = 0; k < s->nearCount; ++k)
	{
		int i = s->near[k];
		od_Patch* p = &s->patch[sim->graph->piece[i]];
		double* row = s->impulse + OD_TURN_ROW * k;
		if (!(row[1] > 0.0))
		{
			continue;
		}
		od_Vec3 n = od_V3Load(s->normal + 3 * i); // n·(move + spin × r) = n·move + spin·(r × n)
		double gap = s->excess[i] - od_Dot(n, p->move) - od_Dot(p->spin, od_V3Load(row + 2));
		double next = row[0] + gap * row[1];
		next = next > 0.0 ? next : 0.0; // not fmax: a call to libm
		if (next == row[0])
		{
			continue; // adds zeros (the sums, begun at +0, are never -0): a clear particle's in every sweep
		}
		p->move = od_MulAdd(p->move, (next - row[0]) / p->mass, n);
		p->spin = od_MulAdd(p->spin, next - row[0], od_V3Load(row + 5));
		row[0] = next;
	}
}

// The friction of what the projection will lift (its part of the support), for each turned piece as a whole
// (od_SlideBack, l the lift after the turn). The projection's own friction, μ l on each particle alone, is what a
// stiff body's next step undoes (docs/contact.md, the Suzanne on the ramp).
static void od_TurnFriction(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	for (int k = 0; k < s->nearCount; ++k)
	{
		int i = s->near[k];
		const od_Patch* p = &s->patch[sim->graph->piece[i]];
		double lift = s->excess[i] - od_Dot(p->spin, od_V3Load(s->impulse + OD_TURN_ROW * k + 2));
		if (p->force > 0.0 && lift > 0.0)
		{
			od_AddLift(sim, i, lift);
			s->given[i] = lift;
		}
	}
	od_SlideBack(sim);
}

void od_SurfaceContact_Turn(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	if (!s->force || s->after || !s->nearCount || !od_TurnPieces(sim))
	{
		return;
	}
	for (int sweep = 0; sweep < OD_TURN_SWEEPS; ++sweep)
	{
		od_TurnSweep(sim);
	}
	od_TurnFriction(sim);
	const od_Graph* g = sim->graph;
	for (int q = 0; q < g->pieceCount; ++q)
	{
		s->patch[q].turn = od_M3ExpSkew(s->patch[q].spin); // once a piece (od_SurfaceContact_Roll makes its own)
	}
	for (int i = 0; i < g->n; ++i)
	{
		const od_Patch* p = &s->patch[g->piece[i]];
		if (p->force > 0.0)
		{
			od_Mat3 r = od_M3Load(sim->state.R + 9 * i);
			od_Vec3 x = od_Sub(od_V3Load(sim->state.x + 3 * i), p->middle);
			od_V3Store(sim->state.x + 3 * i, od_Add(od_Add(p->middle, od_M3MulV(&p->turn, x)), p->move));
			r = od_M3Mul(&p->turn, &r);
			od_M3Store(sim->state.R + 9 * i, &r);
		}
	}
}

// Each pressing piece's turn (od_RollBack) applied to its particles' centres and rotations.
static void od_ApplyRolls(od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	for (int i = 0; i < g->n; ++i)
	{
		const od_Patch* p = &sim->surface.patch[g->piece[i]];
		if (p->force > 0.0)
		{
			od_Vec3 x = od_Sub(od_V3Load(sim->state.x + 3 * i), p->centre);
			od_V3Store(sim->state.x + 3 * i, od_Add(od_Add(p->centre, od_M3MulV(&p->turn, x)), p->shift));
			od_Mat3 r = od_M3Load(sim->state.R + 9 * i);
			r = od_M3Mul(&p->turn, &r);
			od_M3Store(sim->state.R + 9 * i, &r);
		}
	}
}

// Whether piece p's patch is round (od_RollPieces): narrower (its spread a) than OD_ROUND times the height of the
// piece's centre of mass above it.
static bool od_Round(const od_Patch* p)
{
	return sqrt(p->spread) < OD_ROUND * od_Dot(od_Scale(1.0 / p->mass, p->lever), p->normal);
}

// Each pressing piece not held by a goal or a constraint rolled back (od_RollBack). A group member meeting everything
// with its ellipsoids (`ellipsoids`: body_contact.c rolls it at steps longer than 1/60 s only) on a round patch alone
// (od_Round), across its normal alone: see the top of the file.
static void od_RollPieces(od_Sim* sim, bool ellipsoids)
{
	od_PatchMoments(sim);
	for (int p = 0; p < sim->graph->pieceCount; ++p)
	{
		od_Patch* patch = &sim->surface.patch[p];
		patch->force = patch->held || (ellipsoids && !od_Round(patch)) ? 0.0 : patch->force;
		if (patch->force > 0.0)
		{
			od_RollBack(patch, sim->def.dt, ellipsoids);
		}
	}
}

void od_SurfaceContact_Roll(od_Sim* sim)
{
	od_SurfaceContact* s = &sim->surface;
	if (!s->force || s->after || !s->nearCount || !od_Patches(sim))
	{
		return;
	}
	od_RollPieces(sim, false);
	for (int k = 0; k < s->nearCount; ++k)
	{
		s->excess[s->near[k]] = od_HeldDepth(sim, s->near[k]);
	}
	od_ApplyRolls(sim);
	od_KeepOut(sim);
}

double* od_SurfaceContact_Lifts(od_Sim* sim)
{
	const od_SurfaceContact* s = &sim->surface;
	bool under = sim->hasFloor || sim->colliders.count;
	return s->force && s->after && s->rolls == OD_ROLL_FLOOR && under ? s->push : NULL;
}

// Whether a group member's given patch (od_GivenPatches) is its floor's alone, straight up (else the colliders'
// lifts give each particle's normal, contact.c).
static bool od_Upward(const od_Sim* sim, const double* lifted)
{
	return lifted && !sim->colliders.count;
}

// Particle i's normal force in a group member's given patch: its lift's m l / h² (lifted), else its pairs' (s->push).
static double od_GivenForce(const od_Sim* sim, int i, const double* lifted, double h2)
{
	return lifted ? sim->def.density * sim->graph->volumes[i] * lifted[i] / h2 : sim->surface.push[i];
}

// The patches of a group member's pieces (od_Patches' for the forces): on its floor and colliders from their lifts,
// each lifted particle's normal force m l / h² along its lift (up on the floor alone); on another member from its
// pairs' forces there (s->push, s->normal).
static bool od_GivenPatches(od_Sim* sim, const double* lifted)
{
	od_SurfaceContact* s = &sim->surface;
	const od_Graph* g = sim->graph;
	memset(s->patch, 0, sizeof(od_Patch) * (size_t)g->pieceCount);
	double h2 = sim->def.dt * sim->def.dt, mu = od_Upward(sim, lifted) ? sim->floorFriction : s->rollFriction;
	bool any = false;
	for (int i = 0; i < g->n; ++i)
	{
		double f = od_GivenForce(sim, i, lifted, h2);
		od_Patch* p = &s->patch[g->piece[i]];
		if (f > 0.0)
		{
			p->force += f;
			p->friction += mu * f;
			p->spare += mu * f;
			p->centre = od_MulAdd(p->centre, f, od_V3Load(sim->state.x + 3 * i));
			p->normal = od_Upward(sim, lifted) ? od_V3(0, 0, 1) : od_Add(p->normal, od_V3Load(s->normal + 3 * i));
			any = true;
		}
	}
	for (int p = 0; any && p < g->pieceCount; ++p)
	{
		od_Patch* patch = &s->patch[p];
		if (patch->force > 0.0)
		{
			patch->centre = od_Scale(1.0 / patch->force, patch->centre);
			patch->normal = od_Scale(1.0 / od_Length(patch->normal), patch->normal);
		}
	}
	for (int i = 0; any && i < g->n; ++i)
	{
		od_Patch* p = &s->patch[g->piece[i]];
		double f = od_GivenForce(sim, i, lifted, h2);
		od_Vec3 d = od_Sub(od_V3Load(sim->state.x + 3 * i), p->centre);
		d = od_MulAdd(d, -od_Dot(d, p->normal), p->normal);
		p->spread += f > 0.0 ? f * od_Dot(d, d) / p->force : 0.0;
	}
	return any;
}

// The normal of particle i's share of a given patch (od_GivenPatches): up on the floor alone, else its lifts' or
// its pairs' mean.
static od_Vec3 od_GivenNormal(const od_Sim* sim, int i, const double* lifted)
{
	od_Vec3 n = od_V3Load(sim->surface.normal + 3 * i);
	return od_Upward(sim, lifted) ? od_V3(0, 0, 1) : od_Scale(1.0 / od_Length(n), n);
}

void od_SurfaceContact_GroupRoll(od_Sim* sim, const double* lifted)
{
	od_SurfaceContact* s = &sim->surface;
	if (s->rolls == OD_ROLL_NONE || !s->after || !od_GivenPatches(sim, lifted))
	{
		return;
	}
	od_RollPieces(sim, !od_SkinShape_Used(sim));
	const double* bears = lifted ? lifted : s->push;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		s->excess[i] = bears[i] > 0.0 ? od_Dot(od_GivenNormal(sim, i, lifted), od_V3Load(sim->state.x + 3 * i)) : 0.0;
	}
	od_ApplyRolls(sim);
	for (int i = 0; i < sim->graph->n; ++i) // a bearing particle not turned into what it bears on
	{
		od_Vec3 n = bears[i] > 0.0 ? od_GivenNormal(sim, i, lifted) : od_V3(0, 0, 0);
		double back = s->excess[i] - od_Dot(n, od_V3Load(sim->state.x + 3 * i));
		od_V3Store(sim->state.x + 3 * i, od_MulAdd(od_V3Load(sim->state.x + 3 * i), back > 0.0 ? back : 0.0, n));
	}
}
