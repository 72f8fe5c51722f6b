// Contact of the particles' ellipsoids with the scene colliders (docs/contact.md), after a step's iterations
// as the floor's (floor.c), and the push-out of skinned points.
//
// Ellipsoid against a signed distance φ with normal n: with M = E diag(a², b², c²) Eᵀ (E = R Ē, the current
// frame) the ellipsoid reaches s = sqrt(nᵀ M n) along n, and its deepest point is x - M n / s. With the
// centre's φ and n, it is thickness + s - φ deep (exact for a plane or a face); a centre outside is refined
// twice at the deepest point's φ and normal (exact for a sphere on a sphere; an ellipsoid on a curved collider
// settles in the second). A centre inside keeps its own normal: the deepest point of a particle in a thin
// collider may be nearer its far side, and alternating between the two sides pushed particles half out. Friction is Coulomb and position based, as the floor's: the
// particle's displacement relative to the collider's surface (the surface point's own motion taken out) is
// cut, tangentially, by at most μ times the push, and the particle's angular velocity by the same ratio.
//
// Moving colliders: the collider goes from its frame at the step's start to that at its end (linear in
// translation, along the shortest arc in rotation), the particle from its start to its solved end. In the
// collider's frame the particle's relative path is sampled every half of its smallest radius (at most 64
// samples); at the first sample in contact the particle is caught: the rest of its relative motion keeps its
// part along the surface there and loses the part into it, so it is carried with the collider to the step's
// end (on the side it touched), where it is pushed out. A resting or sliding contact is caught at the first
// sample, where this is the plain projection. A 30 km/h collider at 24 fps moves 35 cm a step: 7 samples for a
// 10 cm limb of 5 cm particles, where the end frame alone would have put the collider past the limb
// (tests/test_contact.py). Far particles cost one distance query: φ at the end, less the farthest the
// relative path can stray, still beyond the particle's reach.
//
// Thin parts (a 2 cm box top, an open mesh's slab): the side a particle is on is known at the step's start, and its
// path, not only its end, decides which face it met. A contact whose normal turns away from the path, or from the
// side the particle began on, met the far face of a part whose middle it passed; the sweep then seeks its first
// contact between the samples (od_Entry), skin points beyond the middle while their particle began on this side
// are left out, and a centre (not a contact shape with the skin) whose path passes a face and the middle is
// stopped at the face (od_CentreStop, sphere tracing the distance). Elsewhere (the normal facing the path) all is
// as before, to the bit. The blob of scripts/thin_colliders.py dropped on a 2 cm box top at 24 fps: 100 of its
// 100 particles passed it from 0.1, 0.3 and 1.5 m, now 2-3.
//
// With goals carrying the rest (docs/goals.md, "Contact with goals") contact acts on the deviation from the
// animation: a particle whose ellipsoid at its goal frame (g_i, G_i) is already p_i deep in a collider (at its
// end frame) meets that collider with the thickness less p_i, so it is pushed only by what it is deeper than
// its goal, friction only on that excess, and a body on its animation is left where it is.
//
// With the skin as the contact shape (skin_shape.c, od_Sim_SetContactSkin) the particle's carried skin points
// stand for its ellipsoid everywhere above: the deepest point and its normal give the depth (od_PointsDepth),
// the centre is pushed by it, the rest (sweep, recovery, goals, friction) is the same.
//
// A particle that begins a step inside (placed there, or a collider that appeared over it) leaves at 1 m/s
// at most, as PhysX's depenetration velocity: pushed out, never shot out. Measured on the blob of
// tests/test_contact.py placed half inside a box: its fastest particle moves at 1.0 m/s while it comes out
// (10 steps); out in one step, the squashed half rebounded at 7.8 m/s.
#include "contact.h"

#include "check.h"
#include "goal.h"
#include "math3.h"
#include "skin_shape.h"

#include <math.h>

#define OD_SWEEP_MAX 64       // samples of a particle's path relative to a collider at most
#define OD_PUSH_PASSES 8      // moves along a sampled mesh's gradient that push a point out at most
#define OD_RECOVERY_SPEED 1.0 // m/s: how fast a particle that began a step inside a collider leaves it
#define OD_ENTRY_HALVINGS 8  // of the sample interval where a path met a face behind (od_Entry)
#define OD_TRACE_MOVES 32    // along a centre's path towards a surface at most (od_CentreStop)
#define OD_TRACE_NEAR 0.1    // of the thickness: how near the surface a traced centre stops

double od_CoulombKeep(double slide, double limit)
{
	return slide > limit ? 1.0 - limit / slide : 0.0;
}

double od_Support(const od_Mat3* M, od_Vec3 n)
{
	return sqrt(od_Dot(n, od_M3MulV(M, n)));
}

// The centre l's distance to the collider, what `centre` knows of it (NULL: looked up into *own, with the normal
// where `normal` asks: a sampled mesh's normal is its cell's gradient, most particles are clear of it).
static od_Centre* od_CentreAt(const od_Collider* body, od_Vec3 l, od_Centre* centre, bool normal, od_Centre* own)
{
	if (centre)
	{
		return centre;
	}
	own->phi = od_Collider_LocalDistance(body, l, normal ? &own->normal : NULL);
	own->known = normal;
	return own;
}

// The normal at centre l, looked up once.
static od_Vec3 od_CentreNormal(const od_Collider* body, od_Vec3 l, od_Centre* centre)
{
	if (!centre->known)
	{
		od_Collider_LocalDistance(body, l, &centre->normal);
		centre->known = true;
	}
	return centre->normal;
}

// How deep an ellipsoid (centre l, moment M, both in the collider's frame) is within `thickness` of the
// collider's surface (<= 0: clear of it), with the normal along which to push it out. From the centre's
// distance and normal; a centre outside is refined at the deepest point, unless the normal there turns away
// (the far side of a thin collider). The normal of a particle clear of the collider only when `clearNormal`
// (most particles are clear).
static double od_Depth(const od_Collider* body, const od_Mat3* M, od_Vec3 l, double thickness, double reach,
					   od_Vec3* n, bool clearNormal, od_Centre* centre)
{
	od_Centre own;
	centre = od_CentreAt(body, l, centre, clearNormal, &own);
	double phi = centre->phi;
	if (phi >= reach + thickness)
	{
		if (clearNormal)
		{
			*n = od_CentreNormal(body, l, centre);
		}
		return thickness + reach - phi;
	}
	*n = od_CentreNormal(body, l, centre);
	double depth = thickness + od_Support(M, *n) - phi;
	od_Vec3 centreNormal = *n, m;
	for (int pass = 0; pass < 2 && phi > 0.0; ++pass)
	{
		od_Vec3 deepest = od_MulAdd(l, -1.0 / od_Support(M, *n), od_M3MulV(M, *n));
		double d = thickness - od_Collider_LocalDistance(body, deepest, &m);
		if (od_Dot(m, centreNormal) <= 0.0)
		{
			break;
		}
		depth = d;
		*n = m;
	}
	return depth;
}

// Whether the collider's normal at point p does not turn away from `side` (a point beyond the middle of a thin
// part, its far face nearer, does).
static bool od_Faces(const od_Collider* body, od_Vec3 p, od_Vec3 side)
{
	od_Vec3 m;
	od_Collider_LocalDistance(body, p, &m);
	return od_Dot(m, side) >= 0.0;
}

// od_Depth for particle i's skin points (skin_shape.c) turned by its rotation `turn` and placed at centre l in
// the collider's frame R: the deepest point's, with the normal there, or `least` when none is deeper. A distance
// is 1-Lipschitz, so a group of points is passed over when the centre's distance, then its own centre's,
// proves it no deeper than that (a particle resting on a collider looks up the groups near it), and so is a
// point by its group centre's or by the point last looked up, its neighbour along the group's Morton order
// (od_Beyond: the colliders bench's 1,000-particle Suzanne on the sphere looked up 7,570 points a step, 6,100 so). With `side`, only points whose normal does not turn away from it count. A centre
// already known (`centre`) is not looked up again, and its normal only where it is the answer.
// Whether every point within `radius` of offset q is at least `clear` from the surface, by the distance refPhi
// looked up at offset ref of the same particle (a distance is 1-Lipschitz, and the offsets turn together).
static bool od_Beyond(od_Vec3 q, double radius, od_Vec3 ref, double refPhi, double clear)
{
	od_Vec3 apart = od_Sub(q, ref);
	double gap = refPhi - radius - clear;
	return gap > 0.0 && od_Dot(apart, apart) <= gap * gap;
}

static double od_PointsDepth(const od_Collider* body, const od_SkinShape* skin, int i, const od_Mat3* turn,
							 const od_Mat3* R, od_Vec3 l, double thickness, double least, od_Vec3* n,
							 bool clearNormal, const od_Vec3* side, od_Centre* centre)
{
	od_Centre own;
	centre = od_CentreAt(body, l, centre, clearNormal, &own);
	double phi = centre->phi;
	if (phi >= skin->reach[i] + thickness)
	{
		if (clearNormal)
		{
			*n = od_CentreNormal(body, l, centre);
		}
		return thickness + skin->reach[i] - phi;
	}
	double depth = least;
	if (thickness + skin->reach[i] - phi <= least)
	{
		// No point can be deeper than `least` (a start's depth, sought beyond the recovery): each group's bound
		// would pass over it, the same answer (the colliders bench's 1,000-particle Suzanne on the sphere: 0.11 M
		// instructions a step, its 1,175 start depths' group loops).
		if (clearNormal)
		{
			*n = od_CentreNormal(body, l, centre);
		}
		return depth;
	}
	od_Mat3 local = od_M3MulTN(R, turn);
	od_Vec3 deepest = l, last = od_V3(0, 0, 0); // the offset last looked up and its distance
	double lastPhi = phi;
	for (int g = skin->start[i]; g < skin->start[i + 1]; ++g)
	{
		const double* c = skin->group + 5 * g;
		if (thickness - phi + c[4] <= depth || od_Beyond(od_V3Load(c), c[3], last, lastPhi, thickness - depth))
		{
			continue;
		}
		last = od_V3Load(c);
		double near = od_Collider_LocalDistance(body, od_Add(l, od_M3MulV(&local, last)), NULL);
		lastPhi = near;
		for (int k = skin->first[g]; k < skin->first[g + 1]; ++k)
		{
			const double* o = skin->offset + 4 * k;
			od_Vec3 q = od_V3Load(o);
			if (thickness - near + o[3] <= depth || od_Beyond(q, 0.0, last, lastPhi, thickness - depth))
			{
				continue;
			}
			od_Vec3 p = od_Add(l, od_M3MulV(&local, q));
			lastPhi = od_Collider_LocalDistance(body, p, NULL);
			last = q;
			double d = thickness - lastPhi;
			if (d > depth && (!side || od_Faces(body, p, *side)))
			{
				depth = d;
				deepest = p;
			}
		}
	}
	if (depth > least)
	{
		od_Collider_LocalDistance(body, deepest, n);
	}
	else if (clearNormal)
	{
		*n = od_CentreNormal(body, l, centre);
	}
	return depth;
}

// M in the frame R: Rᵀ M R.
static od_Mat3 od_InFrame(const od_Mat3* M, const od_Mat3* R)
{
	od_Mat3 mr = od_M3Mul(M, R);
	return od_M3MulTN(R, &mr);
}

// A particle: its moment M (world), reach (largest radius), sampling step (half its smallest radius), how
// far it may leave a collider it began the step inside and, with goals carrying the rest, its ellipsoid at
// its goal frame (moment goalM, centre goalX). With the skin as the contact shape (skin: NULL for the
// ellipsoid): its index i, rotation R (goalR at its goal frame), and reach its points' farthest.
typedef struct od_Body
{
	od_Mat3 M;
	double reach, step, recovery;
	double hold;  // the friction the forces inside the iterations left unused (surface_contact.c), on one collider
	double given; // the lift whose friction its piece's turn took (od_SurfaceContact_Given), on that collider
	bool near;    // that collider, in the iterations (od_SurfaceContact_Near): not swept when it is still
	od_Vec3 side; // the normal of the surface it was near then (world; zero when not near)
	bool goal;
	od_Mat3 goalM;
	od_Vec3 goalX;
	const od_SkinShape* skin;
	int i;
	od_Mat3 R, goalR;
} od_Body;

od_Mat3 od_EllipsoidMoment(const od_Sim* sim, int i, const double* rotation)
{
	const double* r = sim->graph->radii + 3 * i;
	od_Mat3 rot = od_M3Load(rotation), e0 = od_M3Load(sim->graph->axes + 9 * i);
	od_Mat3 e = od_M3Mul(&rot, &e0), es = e;
	for (int k = 0; k < 9; ++k)
	{
		es.m[k] *= r[k % 3] * r[k % 3];
	}
	return od_M3MulNT(&es, &e);
}

od_Mat3 od_ParticleMoment(const od_Sim* sim, int i)
{
	return od_EllipsoidMoment(sim, i, sim->state.R + 9 * i);
}

double od_ContactReach(const od_Sim* sim, int i)
{
	return od_SkinShape_Used(sim) ? od_SkinShape_Reach(sim, i) : od_ParticleReach(sim, i);
}

double od_RecoveryLimit(const od_Sim* sim)
{
	return OD_RECOVERY_SPEED * sim->def.dt;
}

// Particle i's shape turned by `rotation` (its centre aside), written field by field into *b: built as a value,
// its zeroing and copy (rep stos / rep movs of 368 bytes) were 3.3 % of the colliders bench's 1,000-particle
// Suzanne's step on the sphere, called once a particle in the projection and twice in the gathering. With the
// skin as the shape, the ellipsoid's moments are left zero: od_BodyDepth does not read them (building them cost
// the contact inside the iterations' gathering 0.1 ms a step on the same Suzanne).
static void od_BodyAt(const od_Sim* sim, int i, const double* rotation, od_Body* b)
{
	const double* r = sim->graph->radii + 3 * i;
	double least = r[0] < r[1] ? r[0] : r[1]; // not fmin: a call to libm
	bool skin = od_SkinShape_Used(sim);
	b->M = skin ? (od_Mat3){ { 0 } } : od_EllipsoidMoment(sim, i, rotation);
	b->reach = skin ? od_SkinShape_Reach(sim, i) : od_ParticleReach(sim, i);
	b->step = 0.5 * (least < r[2] ? least : r[2]);
	b->recovery = od_RecoveryLimit(sim);
	b->hold = 0.0;
	b->given = 0.0;
	b->near = false;
	b->side = od_V3(0, 0, 0);
	b->goal = od_Goals_CarryRest(sim);
	b->goalM = b->goal && !skin ? od_EllipsoidMoment(sim, i, sim->goals.R + 9 * i) : b->M;
	b->goalX = b->goal ? od_V3Load(sim->goals.x + 3 * i) : od_V3(0, 0, 0);
	b->skin = skin ? &sim->skinShape : NULL;
	b->i = i;
	b->R = od_M3Load(rotation);
	b->goalR = b->goal ? od_M3Load(sim->goals.R + 9 * i) : b->R;
}

// od_Depth of the particle's shape (its goal frame's with `goal`) centred at l in the collider's frame R: its
// ellipsoid (moment M in that frame) or its skin points, whose depth is only sought beyond `least` (>= 0); what
// is known of l's distance in `centre` (NULL: nothing).
static double od_BodyDepth(const od_Collider* body, const od_Body* b, bool goal, const od_Mat3* R, const od_Mat3* M,
						   od_Vec3 l, double thickness, double least, od_Vec3* n, bool clearNormal, od_Centre* centre)
{
	if (b->skin)
	{
		return od_PointsDepth(body, b->skin, b->i, goal ? &b->goalR : &b->R, R, l, thickness, least, n, clearNormal,
							  NULL, centre);
	}
	return od_Depth(body, M, l, thickness, b->reach, n, clearNormal, centre);
}

// How deep the particle's ellipsoid at its goal frame is in collider c at its end frame, thickness included
// (0: clear of it, or no goals carrying the rest): the part of a contact that the animation itself makes.
static double od_GoalDepth(const od_SimCollider* c, const od_Body* b)
{
	if (!b->goal)
	{
		return 0.0;
	}
	od_Mat3 M = od_InFrame(&b->goalM, &c->Rb);
	od_Vec3 n, l = od_M3MulTV(&c->Rb, od_Sub(b->goalX, c->tb));
	return fmax(od_BodyDepth(&c->body, b, true, &c->Rb, &M, l, c->thickness, 0.0, &n, false, NULL), 0.0);
}

double od_ColliderDepth(const od_Sim* sim, const od_SimCollider* c, int i, const double* rotation, od_Vec3 x, bool end,
						double least, od_Vec3* normal, od_Centre* centre)
{
	const od_Mat3* R = end ? &c->Rb : &c->Ra;
	od_Vec3 n, l = od_M3MulTV(R, od_Sub(x, end ? c->tb : c->ta));
	double depth;
	if (od_SkinShape_Used(sim) && !od_Goals_CarryRest(sim))
	{
		// The skin's points alone, as od_BodyDepth asks them: od_BodyAt's fields (goal frames, moments) took the
		// colliders bench's 1,000-particle Suzanne 0.2 M instructions a step in the gathering (stop 44).
		od_Mat3 turn = od_M3Load(rotation);
		depth = od_PointsDepth(&c->body, &sim->skinShape, i, &turn, R, l, c->thickness, least, &n, true, NULL,
							   end ? centre : NULL);
	}
	else
	{
		od_Body b;
		od_BodyAt(sim, i, rotation, &b);
		double thickness = c->thickness - od_GoalDepth(c, &b);
		od_Mat3 local = b.skin ? b.M : od_InFrame(&b.M, R);
		depth = od_BodyDepth(&c->body, &b, false, R, &local, l, thickness, least, &n, true, end ? centre : NULL);
	}
	*normal = od_M3MulV(R, n);
	return depth;
}

// The gathering's depth of the skin (surface_contact.c, od_Near): the point farthest along the centre's normal
// alone, where the search of all points (od_PointsDepth, the deepest) took 1.59 M instructions a step of the
// colliders bench's 1,000-particle Suzanne on the sphere (807 searches of 1,970: after the step's first solve,
// without forces yet, each particle's bottom sinks and 4-6 points near the deepest are looked up), 0.87 M so.
// The projection after the iterations still searches every point (the skin kept at the thickness). On a plane
// (the ramp) that point is the deepest: the ramp's 47 steps keep their state hash; on the sphere the Suzanne ends
// 0.17 mm lower. A second pass from the normal at that point (as od_Depth refines an ellipsoid's) changed no
// bit of either replay and cost 0.02 M a step.
double od_SkinTouch(const od_Sim* sim, const od_SimCollider* c, int i, od_Vec3 x, od_Vec3* normal, od_Centre* centre)
{
	const od_SkinShape* skin = &sim->skinShape;
	od_Vec3 l = od_M3MulTV(&c->Rb, od_Sub(x, c->tb)), n = od_CentreNormal(&c->body, l, centre), m;
	*normal = od_M3MulV(&c->Rb, n);
	if (centre->phi >= skin->reach[i] + c->thickness)
	{
		return c->thickness + skin->reach[i] - centre->phi; // clear by its reach, as od_PointsDepth's first test
	}
	int k;
	od_SkinShape_Support(sim, i, sim->state.R + 9 * i, *normal, &k);
	od_Mat3 rotation = od_M3Load(sim->state.R + 9 * i), local = od_M3MulTN(&c->Rb, &rotation);
	od_Vec3 p = od_Add(l, od_M3MulV(&local, od_V3Load(skin->offset + 4 * k)));
	double depth = c->thickness - od_Collider_LocalDistance(&c->body, p, &m);
	if (!(depth > 0.0) || od_Dot(m, n) <= 0.0)
	{
		return 0.0; // none deeper than 0 (as the search's `least`), or a thin part's far face: the centre's normal
	}
	*normal = od_M3MulV(&c->Rb, m);
	return depth;
}

od_Centre od_ColliderCentre(const od_SimCollider* c, od_Vec3 x)
{
	od_Vec3 l = od_M3MulTV(&c->Rb, od_Sub(x, c->tb)); // as od_ColliderDepth's at the end frame
	return (od_Centre){ .phi = od_Collider_LocalDistance(&c->body, l, NULL) };
}

// Where this is <= 0 the particle is clear by its reach, and od_Depth's and od_PointsDepth's first test returns
// this less the goal's depth (>= 0): so below any margin < 0 the full depth is too, for any rotation and goal.
double od_ColliderDepthBound(const od_Sim* sim, const od_SimCollider* c, int i, const od_Centre* centre)
{
	return c->thickness + od_ContactReach(sim, i) - centre->phi;
}

void od_ColliderFrames(od_SimCollider* c, double s0, double s1)
{
	od_Collider_FrameAt(&c->body, s0, &c->Ra, &c->ta);
	od_Collider_FrameAt(&c->body, s1, &c->Rb, &c->tb);
	od_Mat3 delta = od_M3MulNT(&c->Rb, &c->Ra);
	c->turn = od_M3LogRotation(&delta);
}

static bool od_Same(od_Vec3 a, od_Vec3 b)
{
	return a.x == b.x && a.y == b.y && a.z == b.z;
}

// The particle's place at fraction s of its path (start -> x) in the collider's frame then (R; its moment M there,
// Ma all along when the collider does not turn).
static inline od_Vec3 od_PathAt(const od_SimCollider* c, const od_Body* b, const od_Mat3* Ma, od_Vec3 start, od_Vec3 x,
								double s, bool turns, od_Mat3* R, od_Mat3* M)
{
	*R = c->Ra;
	*M = *Ma;
	if (turns)
	{
		od_Mat3 turn = od_M3ExpSkew(od_Scale(s, c->turn));
		*R = od_M3Mul(&turn, &c->Ra);
		*M = od_InFrame(&b->M, R);
	}
	od_Vec3 t = od_MulAdd(c->ta, s, od_Sub(c->tb, c->ta));
	return od_M3MulTV(R, od_Sub(od_MulAdd(start, s, od_Sub(x, start)), t));
}

// Where the path first meets the collider between fractions lo (clear, or the step's start) and hi, where it is
// in contact at l with normal *n: l itself when *n faces the path from lo (met from the front) or the path began
// in contact on that side (the start, with its normal, when it began on the other); otherwise (it met the face
// behind the middle of a thin part, its far face nearer: a 2 cm box top passed in one step) halved
// OD_ENTRY_HALVINGS times towards the first contact, whose normal is the face it met.
static od_Vec3 od_Entry(const od_SimCollider* c, const od_Body* b, const od_Mat3* Ma, double thickness, od_Vec3 start,
						od_Vec3 x, double lo, double hi, od_Vec3 l, od_Vec3* n)
{
	bool turns = c->turn.x != 0.0 || c->turn.y != 0.0 || c->turn.z != 0.0;
	od_Mat3 R, M;
	od_Vec3 m, before = od_PathAt(c, b, Ma, start, x, lo, turns, &R, &M);
	if (od_Dot(od_Sub(l, before), *n) < 0.0)
	{
		return l;
	}
	if (lo == 0.0 && od_BodyDepth(&c->body, b, false, &R, &M, before, thickness, 0.0, &m, false, NULL) > 0.0)
	{
		bool same = od_Dot(m, *n) >= 0.0;
		*n = same ? *n : m;
		return same ? l : before;
	}
	for (int h = 0; h < OD_ENTRY_HALVINGS; ++h)
	{
		double s = 0.5 * (lo + hi);
		od_Vec3 p = od_PathAt(c, b, Ma, start, x, s, turns, &R, &M);
		if (od_BodyDepth(&c->body, b, false, &R, &M, p, thickness, 0.0, &m, false, NULL) > 0.0)
		{
			hi = s;
			l = p;
			*n = m;
		}
		else
		{
			lo = s;
		}
	}
	return l;
}

// Where the particle's path (start -> x) ends relative to the collider, in the collider's frame at the step's
// end: lb, less the part of its motion after its first contact that went into the surface along the normal
// there (the motion along the surface stays, so that sliding is not slowed); *last: the fraction of the last
// sample before the end (od_Touch meets the end).
// Ma: the particle's moment in the start frame, the moment all along when the collider does not turn.
// A sample whose centre is clear of the collider by its reach is clear (od_Depth's and od_PointsDepth's first
// test); where the collider does not turn, the samples are evenly spaced on a line in its frame, and those
// nearer than its centre's margin are passed over (a trilinear sample of a mesh's distances, each within one
// spacing of its neighbours, changes by at most |Δ|₁ <= √3 |Δ|; but for the jump in sign an open mesh's distance
// makes behind its rim, where a path may so be caught a sample or two later, as by od_Touch's first test). The projection of
// the colliders bench's 1,000-particle Suzanne on the ramp (scripts/colliders_replay.py) took 2.78 M instructions
// a step, 1.98 M so.
static od_Vec3 od_FirstContact(const od_SimCollider* c, const od_Body* b, const od_Mat3* Ma, double thickness,
							   od_Vec3 start, od_Vec3 x, od_Vec3 la, od_Vec3 lb, double* last)
{
	int samples = (int)fmin(ceil(od_Length(od_Sub(lb, la)) / b->step), OD_SWEEP_MAX);
	bool turns = c->turn.x != 0.0 || c->turn.y != 0.0 || c->turn.z != 0.0;
	double apart = sqrt(3.0) * od_Length(od_Sub(od_Sub(x, start), od_Sub(c->tb, c->ta))) / samples;
	*last = (double)(samples - 1) / samples;
	for (int k = 1; k < samples; ++k)
	{
		double s = (double)k / samples;
		od_Mat3 R, M;
		od_Vec3 n, l = od_PathAt(c, b, Ma, start, x, s, turns, &R, &M);
		od_Centre centre = { .phi = od_Collider_LocalDistance(&c->body, l, NULL) };
		double skip = (centre.phi - (b->reach + thickness)) / apart;
		if (centre.phi >= b->reach + thickness)
		{
			k += turns ? 0 : skip < samples ? (int)skip : samples; // not fmin: a call to libm
			continue;
		}
		if (od_BodyDepth(&c->body, b, false, &R, &M, l, thickness, 0.0, &n, false, &centre) > 0.0)
		{
			od_Vec3 met = od_Entry(c, b, Ma, thickness, start, x, (double)(k - 1) / samples, s, l, &n);
			return od_MulAdd(lb, -fmin(od_Dot(od_Sub(lb, met), n), 0.0), n);
		}
	}
	return lb;
}

// The collider's normal at the particle's centre at the step's start (la): the side it began on.
static od_Vec3 od_StartSide(const od_SimCollider* c, od_Vec3 la)
{
	od_Vec3 n;
	od_Collider_LocalDistance(&c->body, la, &n);
	return n;
}

// Where a centre whose path (la -> lb, in the collider's frame) went through a face and beyond the part's middle
// (where it ends, the nearest face turns away from the one it met: a thin part's far side) stops: at that face,
// lb less the part of its motion beyond it into the surface there; one that began on the surface or inside, at
// its start's depth. lb for one that stays clear or on the side it met (a centre may end inside a thick collider
// with the skin out). Sphere tracing: moves of φ / √3 along the path never pass a face (a trilinear sample of a
// mesh's distances changes by at most √3 |Δ|). Only a path whose end the collider's normal turns away from its
// start's (`side`: the surface it was held against, or its start's normal) is traced: one lookup where the end
// alone proves the path clear, two or three where it ends on its side (a slide along a ramp). `end`: lb's distance.
static od_Vec3 od_CentreStop(const od_SimCollider* c, od_Vec3 la, od_Vec3 lb, od_Centre* end, od_Vec3 side)
{
	od_Vec3 path = od_Sub(lb, la), n;
	if (od_Dot(path, side) > 0.0 || (end->phi > 0.0 && end->phi * end->phi > 3.0 * od_Dot(path, path)))
	{
		return lb; // moving away from the surface it was held against, or proven clear by its end
	}
	double length = od_Length(path), near = OD_TRACE_NEAR * c->thickness, t = 0.0;
	od_Vec3 m = od_CentreNormal(&c->body, lb, end);
	if (od_Dot(m, od_Dot(side, side) > 0.0 ? side : od_StartSide(c, la)) >= 0.0)
	{
		return lb;
	}
	for (int k = 0; k < OD_TRACE_MOVES && t < length; ++k)
	{
		od_Vec3 p = od_MulAdd(la, t / length, path);
		double phi = od_Collider_LocalDistance(&c->body, p, NULL);
		if (!(phi >= near))
		{
			od_Collider_LocalDistance(&c->body, p, &n);
			return od_Dot(m, n) >= 0.0 ? lb : od_MulAdd(lb, -fmin(od_Dot(od_Sub(lb, p), n), 0.0), n);
		}
		t += phi / sqrt(3.0);
	}
	return lb;
}

// What is known of l's distance: lb's (centre), where l is lb (the projection's depth where nothing moved it).
static od_Centre* od_Known(od_Vec3 l, od_Vec3 lb, od_Centre* centre)
{
	return od_Same(l, lb) ? centre : NULL;
}

// One particle against one collider over the step: *x caught, pushed out (if it began inside, by at most
// its recovery beyond where it began) and slowed by friction; *keep scaled by the friction's ratio; *lift
// summing what it was pushed out along the normal (the normal times the distance). The collider's thickness less
// the goal's depth in it (od_GoalDepth) is where the contact begins.
static void od_Touch(const od_SimCollider* c, const od_Body* b, od_Vec3 start, od_Vec3* x, double* keep, od_Vec3* lift)
{
	od_Vec3 n, lb = od_M3MulTV(&c->Rb, od_Sub(*x, c->tb));
	double travel = od_Length(od_Sub(*x, start)) + od_Length(od_Sub(c->tb, c->ta)) +
					od_Length(c->turn) * (od_Length(od_Sub(*x, c->tb)) + od_Length(od_Sub(*x, start)));
	od_Centre centre = { .phi = od_Collider_LocalDistance(&c->body, lb, NULL) };
	if (centre.phi >= b->reach + c->thickness + travel)
	{
		return;
	}
	double thickness = c->thickness - od_GoalDepth(c, b);
	od_Mat3 Ma = b->skin ? b->M : od_InFrame(&b->M, &c->Ra), Mb = b->skin ? b->M : od_InFrame(&b->M, &c->Rb);
	od_Vec3 la = od_M3MulTV(&c->Ra, od_Sub(start, c->ta));
	// With the skin as its shape the centre is not met by the collider: a thin part may pass between its points.
	od_Vec3 side = b->near ? od_M3MulTV(&c->Rb, b->side) : od_V3(0, 0, 0); // the side it began on (zero: sought)
	od_Vec3 stop = b->skin ? od_CentreStop(c, la, lb, &centre, side) : lb;
	od_Vec3 end = od_Same(stop, lb) ? *x : od_Add(od_M3MulV(&c->Rb, stop), c->tb);
	// A particle near a still collider since the step's first solve (held by the forces inside the iterations)
	// met it where it ends: sweeping its slide cost a 1,000-particle Suzanne sliding down a mesh ramp 1.5 ms a step
	// (the forces keep it a hair outside, so no sample found the contact). A moving one is swept: it may pass. So
	// is one that ends in contact by a face turned away from the one it was held against (a thin part's far face).
	bool still = c->ta.x == c->tb.x && c->ta.y == c->tb.y && c->ta.z == c->tb.z && od_Length(c->turn) == 0.0;
	bool swept = !(b->near && still);
	double last = 0.0;
	od_Vec3 l = swept ? od_FirstContact(c, b, &Ma, thickness, start, end, la, stop, &last) : stop;
	double depth = od_BodyDepth(&c->body, b, false, &c->Rb, &Mb, l, thickness, 0.0, &n, true, od_Known(l, lb, &centre));
	if (!swept && depth > 0.0 && od_Dot(n, side) < 0.0)
	{
		l = od_FirstContact(c, b, &Ma, thickness, start, end, la, stop, &last);
		depth = od_BodyDepth(&c->body, b, false, &c->Rb, &Mb, l, thickness, 0.0, &n, true, od_Known(l, lb, &centre));
		swept = true;
	}
	bool atEnd = swept && depth > 0.0 && od_Same(l, stop); // met at the end alone, perhaps through a face behind
	od_Vec3 met = atEnd ? od_Entry(c, b, &Ma, thickness, start, end, last, 1.0, l, &n) : l;
	if (!od_Same(met, l))
	{
		l = od_MulAdd(stop, -fmin(od_Dot(od_Sub(stop, met), n), 0.0), n);
		depth = od_BodyDepth(&c->body, b, false, &c->Rb, &Mb, l, thickness, 0.0, &n, true, od_Known(l, lb, &centre));
	}
	// Skin points beyond the middle of a thin part, their far face nearer, while the particle began on this side
	// (the surface it was held against, or its centre's) do not count: they would push it through.
	if (b->skin && depth > 0.0)
	{
		side = b->near ? side : od_StartSide(c, la);
		if (od_Dot(n, side) < 0.0)
		{
			depth = od_PointsDepth(&c->body, b->skin, b->i, &b->R, &c->Rb, l, thickness, 0.0, &n, true, &side,
								   od_Known(l, lb, &centre));
		}
	}
	if (depth <= 0.0 && od_Same(l, lb) && !(b->hold > 0.0))
	{
		return;
	}
	od_Vec3 m; // began inside (what it is not beyond its recovery does not count); sought only here, where it counts
	double left = od_BodyDepth(&c->body, b, false, &c->Ra, &Ma, la, thickness, b->recovery, &m, false, NULL) -
				  b->recovery;
	l = od_MulAdd(l, fmax(depth - fmax(left, 0.0), 0.0), n);
	od_Vec3 moved = od_Add(od_M3MulV(&c->Rb, l), c->tb);
	od_Vec3 nb = od_M3MulV(&c->Rb, n);
	double push = od_Dot(od_Sub(moved, *x), nb);
	*lift = od_MulAdd(*lift, fmax(push, 0.0), nb);
	if (c->friction > 0.0 && (push > 0.0 || b->hold > 0.0))
	{
		// The motion relative to the surface, in the collider's end frame: measured in its start frame (Ra), a
		// collider turned 60 degrees in a step put the friction's correction across it and the particle through
		// a 2 cm box (an outside review, 2026-11-24).
		od_Vec3 slip = od_M3MulV(&c->Rb, od_Sub(l, la));
		slip = od_MulAdd(slip, -od_Dot(slip, nb), nb);
		double k = od_CoulombKeep(od_Length(slip), c->friction * fmax(push - b->given, 0.0) + b->hold);
		moved = od_MulAdd(moved, k - 1.0, slip);
		*keep *= k;
	}
	*x = moved;
}

// Particle i's lifts by the floor (lifted[i], written by floor.c) and by the colliders (lift: the directions
// times the distances) as one: the distance in lifted[i], the direction times it in its surface's normal slot;
// their friction times the distance added to rub[0], the distance to rub[1].
static void od_Lifted(od_Sim* sim, int i, od_Vec3 lift, double friction, double* lifted, double* rub)
{
	double up = sim->hasFloor ? lifted[i] : 0.0;
	lifted[i] = up + od_Length(lift);
	rub[0] += sim->floorFriction * up + friction;
	rub[1] += lifted[i];
	od_V3Store(sim->surface.normal + 3 * i, od_MulAdd(lift, up, od_V3(0, 0, 1)));
}

void od_ContactStep(od_Sim* sim, const od_State* before, double s0, double s1, double* lifted)
{
	for (int k = 0; k < sim->colliders.count; ++k)
	{
		od_SimCollider* c = &sim->colliders.items[k];
		od_ColliderFrames(c, s0, s1);
		od_Collider_Place(&c->body, s1);
	}
	double rub[2] = { 0.0, 0.0 };
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Body b;
		od_BodyAt(sim, i, sim->state.R + 9 * i, &b);
		od_Vec3 start = od_V3Load(before->x + 3 * i), x = od_V3Load(sim->state.x + 3 * i), lift = od_V3(0, 0, 0);
		double keep = sim->hasFloor ? sim->angularScale[i] : 1.0, friction = 0.0;
		for (int k = 0; k < sim->colliders.count; ++k)
		{
			b.hold = od_SurfaceContact_Hold(sim, i, k);
			b.given = od_SurfaceContact_Given(sim, i, k);
			b.near = od_SurfaceContact_Near(sim, i, k);
			b.side = b.near ? od_V3Load(sim->surface.normal + 3 * i) : od_V3(0, 0, 0);
			od_Vec3 by = od_V3(0, 0, 0);
			od_Touch(&sim->colliders.items[k], &b, start, &x, &keep, &by);
			if (lifted)
			{
				lift = od_Add(lift, by);
				friction += sim->colliders.items[k].friction * od_Length(by);
			}
		}
		od_V3Store(sim->state.x + 3 * i, x);
		sim->angularScale[i] = keep;
		if (lifted)
		{
			od_Lifted(sim, i, lift, friction, lifted, rub);
		}
	}
	sim->surface.rollFriction = rub[1] > 0.0 ? rub[0] / rub[1] : sim->surface.rollFriction;
}

// The signed distance of world point p to collider c at its placed frame and the local point (the normal is
// the caller's to ask for: a sampled mesh's is one more read of its cell, and most points are clear of it).
static double od_PlacedDistance(const od_SimCollider* c, od_Vec3 p, od_Vec3* local)
{
	*local = od_M3MulTV(&c->body.R, od_Sub(p, c->body.t));
	return od_Collider_LocalDistance(&c->body, *local, NULL);
}

od_Status od_Sim_PushOut(const od_Sim* sim, double* points, int count, int* moved)
{
	od_Status status = od_CheckFinite("points", points, 3 * count);
	if (status != OD_OK)
	{
		return status;
	}
	int changed = 0;
	for (int i = 0; i < count; ++i)
	{
		od_Vec3 p = od_V3Load(points + 3 * i), before = p, l, n;
		for (int k = 0; k < sim->colliders.count; ++k)
		{
			const od_SimCollider* c = &sim->colliders.items[k];
			double phi = od_PlacedDistance(c, p, &l);
			if (!(phi < 0.0))
			{
				continue;
			}
			phi = od_Collider_LocalDistance(&c->body, l, &n);
			// A sampled mesh's surface: again until out (twice left a bar's skin vertex 2e-5 m inside from 0.023 m
			// deep in the sphere of tests/test_addon_colliders.py), at most OD_PUSH_PASSES times.
			for (int pass = 0; pass < OD_PUSH_PASSES && phi < 0.0; ++pass)
			{
				l = od_MulAdd(l, -phi, n);
				phi = od_Collider_LocalDistance(&c->body, l, &n);
			}
			p = od_Add(od_M3MulV(&c->body.R, l), c->body.t);
		}
		p.z = sim->hasFloor ? fmax(p.z, sim->floorHeight) : p.z;
		changed += p.x != before.x || p.y != before.y || p.z != before.z;
		od_V3Store(points + 3 * i, p);
	}
	if (moved)
	{
		*moved = changed;
	}
	return OD_OK;
}

od_Status od_Sim_GetColliderDistances(const od_Sim* sim, const double* points, int count, double* distances)
{
	od_Status status = od_CheckFinite("points", points, 3 * count);
	if (status != OD_OK)
	{
		return status;
	}
	for (int i = 0; i < count; ++i)
	{
		od_Vec3 p = od_V3Load(points + 3 * i), l;
		double d = sim->hasFloor ? p.z - sim->floorHeight : INFINITY;
		for (int k = 0; k < sim->colliders.count; ++k)
		{
			d = fmin(d, od_PlacedDistance(&sim->colliders.items[k], p, &l));
		}
		distances[i] = d;
	}
	return OD_OK;
}
