// Internal layout of a simulation: the model (graph, parameters, constraints, factorizations), the
// state (centres, rotations, velocities) and preallocated scratch. Every stage of a step is a function
// of (sim) that reads the model and rewrites the state; nothing is allocated per step after warm-up.
// Types only: each stage declares its functions in its own header (constraints.h, local_step.h, ...).
#pragma once

#include "acceleration.h"
#include "opdeform/colliders.h"
#include "collider.h"
#include "field.h"
#include "graph.h"
#include "pool.h"

#include <stdbool.h>

typedef enum od_ConstraintKind
{
	OD_POSITION = 0,
	OD_DIRECTION = 1,
} od_ConstraintKind;

typedef struct od_Constraint
{
	int id;
	od_ConstraintKind kind;
	double point[3];     // p̄, rest space
	double direction[3]; // n̄, unit, rest space (direction constraints)
	double target[3];    // t, or the unit target direction n
	double weight;
	int count;           // skinning particles
	int idx[OD_MAX_SKIN];
	double w[OD_MAX_SKIN];
} od_Constraint;

typedef struct od_ConstraintSet
{
	od_Constraint* items;
	int count, capacity;
	int* slotOfId; // id -> slot, -1 when removed
	int idCapacity, nextId;
	int positionCount, directionCount;
	unsigned matrixVersion; // advances with every change of the global matrix's constraint terms
	bool pairsDirty;        // the position constraints changed: rebuild the pairs below
	bool incidenceDirty;    // the direction constraints (or the slots) changed: rebuild touch*
	bool targetsDirty;      // a position target changed: rebuild targetMoment

	// Direction constraints (direction_constraints.c), per particle i: entries touchStart[i]..touchStart[i+1]-1 of touchSlot
	// (constraint slot) and touchArm (w_i n̄, how R_i turns the skinned direction).
	int* touchStart;
	int* touchSlot;
	double* touchArm;
	int touchCapacity;
	double* current; // per slot: the unnormalised skinned direction Σ w_j R_j n̄, kept current in the local step

	// Position constraints (position_constraints.c) folded into ordered particle pairs (i, j) that share one: row i holds, for each
	// pair, P_ij = Σ_c w w_i w_j a_cj a_ciᵀ (9), Σ_c w w_i w_j a_ci (3) and Σ_c w w_i w_j a_cj (3), with
	// a_cj = p̄_c - X̄_j. Per particle, Σ_c w w_i t_c a_ciᵀ (9) and Σ_c w w_i t_c (3) depend on the targets.
	int* pairStart;
	int* pairCol;
	double* pairData;     // 15 per pair
	double* targetMoment; // 12 per particle
	int pairCapacity;
} od_ConstraintSet;

typedef struct od_State
{
	double* x;     // n*3
	double* R;     // n*9
	double* v;     // n*3
	double* omega; // n*3
} od_State;

// Goals (goal.c): NULL arrays when the simulation has none.
typedef struct od_Goals
{
	double* omega2;   // n, (2π f_i)²
	double* x;        // n*3 goal centres g_i
	double* R;        // n*9 goal rotations G_i
	double* term;     // n*9, ρ ω_i² G_i Ā_i: the goal's term of C_i
	unsigned version; // advances with every change of the frequencies (they enter the global matrix)
	// Goals carrying the rest (od_Sim_SetGoalRest): the elastic energy is measured against the goal shape.
	// The arrays exist while carryRest and the goals do (NULL otherwise).
	bool carryRest;
	double* edgeRest; // 6 per directed edge (i, j): X̄_i - X̄_j of the goal shape in i's goal frame, then in j's
	double* edgeTurn; // 9 per directed edge (i, j): Q_ji = G_jᵀ G_i, kept for the objective (energy.c)
	double* velocity; // n*3, u_i: each goal centre's velocity between the last two frames (0 before the second)
	double* spin;     // n*3, Ω_i: each goal frame's angular velocity, the same
	bool framed;      // a frame was set since the motion was reset (else the next one's velocity is 0)
	long long mark;   // counters.steps at the last od_Sim_SetGoals (framed)
	// Between frames (od_Goals_Place): x and R hold the goals placed for a call's step, the frame set is kept here.
	double* frameX;   // n*3, the goal centres as set
	double* frameR;   // n*9, the goal rotations as set
	int step, steps;  // the call's step being made and its steps, 0 unless a frame was set just before the call
	bool placed;      // x and R differ from the frame set
} od_Goals;

// A scene collider (scene_colliders.c) and, during a step, its frames at the step's start (a) and end (b) and the
// turn between them (contact.c).
typedef struct od_SimCollider
{
	int id;
	od_Collider body; // shape and frames over the current call (collide/collider.c)
	double friction, thickness;
	int vertexCount, triangleCount;
	int* triangles;   // a mesh's, kept for new vertices
	od_Mat3 Ra, Rb;
	od_Vec3 ta, tb, turn;
} od_SimCollider;

typedef struct od_Colliders
{
	od_SimCollider* items;
	int count, capacity, nextId;
} od_Colliders;

// The skinned surface as the particles' contact shape with the floor and the colliders (skin_shape.c): point k
// is carried rigidly by its particle i, at x_i + R_i offset_k, in groups of nearby points (a bounding sphere
// each). count 0 (NULL arrays): the ellipsoids.
typedef struct od_SkinShape
{
	int count, given; // points kept (a particle given none keeps its centre), points given
	int* start;       // n + 1: particle i's groups are [start[i], start[i + 1])
	int* first;       // groups + 1: group g's points are [first[g], first[g + 1])
	double* group;    // 5 per group: its centre's offset, its radius, the farthest it reaches from the particle
	double* offset;   // 4 per point: v - X̄_i at rest, then its distance from its group's centre
	double* reach;    // n: the farthest of particle i's points from its centre
	bool bodies;      // the points meet the other bodies of a group too (skin_pairs.c), else the ellipsoids do
} od_SkinShape;

// Contact with the floor and the colliders inside a step's iterations (surface_contact.c), per particle: the
// force on the right side, its normal part and direction, its friction part, the depth it may keep (began
// inside), the surface it presses (-1 the floor, k collider k); the particles near a surface after a step's
// first solve. Made at the first step with a floor or a collider; NULL before.
enum { OD_ROLL_NONE, OD_ROLL_FLOOR, OD_ROLL_MEMBER }; // OD_ROLL_FLOOR: on its floor's and colliders' lifts
typedef struct od_SurfaceContact
{
	double* force;   // n*3, zero outside a step's iterations
	double* normal;  // n*3
	double* tangent; // n*3
	double* push;    // n
	double* level;   // n, the particle's plane for the step (surface_contact.c, od_Near)
	double* anchor;  // n*3, where its slide is measured from
	double* excess;  // n, the depth beyond the allowed one at the last update
	double* hold;    // n, the friction its forces left unused at the step's end, as a slide: (μ f - |t|) h²/m
	double* given;   // n, the lift after the iterations whose friction its piece's turn took (od_TurnFriction), m
	double* piece;   // 3 per connected piece: its mass, its pressing particles' mass and Σ m_i excess_i of those
	struct od_Patch* patch; // per connected piece: its contact patch and rigid motion at a step's end (rolling)
	int* source;     // n
	int* point;      // n, with the skin as the shape: the point reaching farthest along its normal (od_Near)
	int* near;       // nearCount particles
	// The warm start, part of the simulation's state (od_Sim_GetSurfaceForces): the normal force each particle
	// pressed its surface with at the last step's end, and that surface (-2: none); kept at a call's start.
	double* carried; // n*3
	int* carriedSource; // n
	double* keptCarried; // n*3
	int* keptSource; // n
	double* impulse; // OD_TURN_ROW per near particle, od_SurfaceContact_Turn's (surface_contact.c)
	int nearCount, callSteps, callStep, updates; // updates: the forces' in this step
	bool gathered;
	bool after; // this step's contact after the iterations only (a member of a group with forces, body_contact.c)
	int rolls; // and a patch rolls it back after the projections (od_SurfaceContact_GroupRoll): OD_ROLL_*
	double rollFriction; // that patch's μ
} od_SurfaceContact;

// Particle pairs in contact (body_contact.c): the broad phase's uniform grid over the particles' swept
// bounding spheres (hashed cells, counting sort) and the candidate pairs. Sized for `capacity` particles
// when self-contact is turned on or a group made; the pair list grows in the first steps only.
typedef struct od_ContactPair
{
	int a, b;         // global particle indices (body-major), a < b
	double push;      // accumulated over the passes of a step
	double n[3];      // the normal, a towards b
	double force;     // the normal force on b (N, >= 0; -force on a), inside the iterations, kept step to step
	double tangent[3]; // the friction force on b (N, |tangent| <= μ force)
	double anchor[3];  // where b was from a (x_b - x_a) when the pair last stuck, turned with a's particle since
	                   // (od_BodyContact_TurnAnchors): its friction's measure (od_Slip)
	bool anchored;     // anchor set: the pair sticks; else its next update anchors it at the step's start
	bool resting;      // it carried a force into this step: its slip in its first particle's frame (od_Turning)
	double gap;       // of the last update: how far apart beyond contact (m, < 0: in)
	double allowed;   // self-contact: how deep it may stay this step (od_MeasureSelfPair)
	bool touching;    // near enough for a force in this iteration
	int next;         // the next forced pair of the same first particle (od_CarryForces)
	int interface;    // its interface in a group's update (od_Interfaces), -1: none
	int clear;        // the projection's tick at which it was last measured clear, 0: not (od_ProjectPairs)
} od_ContactPair;

// The contacts between two members of a group in one update of its forces (od_Coarse, body_contact.c): their
// count, mean normal (lower to upper member), mean gap and mean own compliance of their particles, and the
// change of each one's normal force that the members' rigid motions ask for; likewise their mean slip (the
// upper end's tangential displacement since the step's start less the lower's), mean point and the change of each
// one's friction force (od_CoarseFriction).
typedef struct od_Interface
{
	int lower, upper, count;
	double n[3], gap, local, change, slip[3], point[3], shift[3], load;
} od_Interface;

// The rolling couple between two members in contact this step (od_MemberRolls, body_contact.c): on `upper`, its
// negative on `lower` (an interface's members).
typedef struct od_MemberCouple
{
	int lower, upper;
	double couple[3];
} od_MemberCouple;

typedef struct od_PairScratch
{
	int capacity, tableSize;
	int* body;        // per particle: which simulation (index in the call's list)
	int* local;       // its index in that simulation
	int* cell;        // its hashed cell
	int* cellStart;   // tableSize + 1
	int* sorted;      // particles by cell
	double* sphere;   // 4 per particle: centre of the swept path and radius
	int* active;      // per particle: how many pairs pressed it at the last update (their forces share its response)
	int* pressing;    // the same, counted in this update
	int* moved;       // per particle: the projection's tick at which a push last moved it (od_ProjectPairs)
	double* moment;   // 9 per particle: its ellipsoid M = E diag(a², b², c²) Eᵀ at the last measure
	double* outward;  // 3 per particle: how much it is on its body's surface, outwards (od_Outward), the same
	int* grounded;    // per member: whether it bears on its floor at the last od_ApplyForces (a group's)
	int* held;        // per member: whether its floor holds it inside the iterations then (od_Grounded)
	double* bearing;  // per member: how much its particles bear on its floor then (od_Grounded)
	double* mass;     // per member: its mass (od_MemberMasses)
	double comparable; // the largest ratio of two members' masses that counts as comparable this step (od_MemberMasses)
	double* rise;     // 2 per member: how much its pairs with the members below it rise towards it, summed, and
	                  // their count (od_Supports)
	int* supported;   // per member: on its floor or resting on supported members (od_Supports)
	int* climbing;    // per member: rising at the step's start faster than gravity stops in a step (od_MemberMasses)
	int* fast;        // per member: moving up or down at the step's start faster than OD_ROLL_LANDING (od_MemberMasses)
	int* perched;     // per member: its pairs in contact resting on much heavier members (od_CountPerched)
	int* storeys;     // per storey, from the floor up: its member (od_BodyContact_Carry)
	double* load;     // per member: the vertical force of its comparable pairs (od_FloorReaction)
	double* pose;     // 13 per member: its centre of mass at the step's start, the inverse of its inertia about it
	                  // (row-major; zero where it has none) and Σ m r_z² about it (od_MemberMasses)
	double* roll;     // 3 per member: the floor's rolling couple on it this step (od_Rolls)
	double* kept;     // 3 per particle: where it was before its member's finish (od_BodyContact_Carry)
	int* alone;       // per member: far from every other this step, so it steps as alone (od_MarkAlone)
	double* box;      // 6 per member: its particles' bounding box at the step's start, their reach included
	int rollUpdates;  // how many times this step's rolling couples (the floor's, the members') were updated (od_Rolls)
	od_MemberCouple* couples; // the rolling couples between members this step (od_MemberRolls)
	int coupleCount, coupleCapacity;
	od_Interface* interfaces; // of the current update (od_Interfaces; after a step od_BodyContact_Impacts')
	int interfaceCount, interfaceCapacity;
	double* system;   // their rigid system and right side, 2 interfaceCapacity (2 interfaceCapacity + 1) (od_Coarse)
	od_ContactPair* pairs;
	int pairCount, pairCapacity;
	int nearCount;            // the first nearCount pairs get forces in a group's iterations (od_GatherNear)
	bool warmNormals;         // skin pairs' normals sought from their last one (a group's iterations, skin_pairs.c)
	od_ContactPair* previous; // the last step's pairs, sorted: their forces start this step's (warm start)
	int previousCount, previousCapacity;
	struct od_SelfSolve* self; // self-contact's forces in the solves (body_contact.c), made when first needed
} od_PairScratch;

typedef enum od_Mode
{
	OD_DYNAMIC = 0,
	OD_STATIC = 1,
} od_Mode;

typedef struct od_GlobalSolver od_GlobalSolver; // opaque, global_solve.c

// The error estimate under a tolerance (tolerance.c).
typedef struct od_Tolerance
{
	double* x;     // n*3, the centres of the previous iterate
	double* R;     // n*9, its rotations
	double size;   // the rest body's largest extent (m)
} od_Tolerance;

// How the current call's iteration runs (tolerance.c: od_Tolerance_Plan, od_Tolerance_Check).
typedef struct od_StepPlan
{
	bool accelerate; // the next pair is accelerated
	bool probing;    // auto's first two pairs: plain, their contraction decides
	bool plain;      // auto after a fast probe: plain pairs
	int plainLeft;   // auto after a fast probe: plain pairs left before Chebyshev (0: plain to the end)
	double tolerance;
	double last; // the probe's first residual (< 0: none yet)
} od_StepPlan;

// The iteration of the current solve, in stages (step.c: od_IterateStart, od_IterateNext).
typedef struct od_Iteration
{
	int done, limit;
	bool started, finished;
	od_StepPlan plan;
	double accepted, error;
} od_Iteration;

struct od_Sim
{
	const od_Graph* graph;
	od_SimDef def;
	od_ConstraintSet constraints;
	od_GlobalSolver* solver[2]; // per mode
	od_Goals goals;
	bool hasFloor;
	double floorHeight, floorFriction;
	od_Colliders colliders;
	od_SkinShape skinShape; // the floor's and the colliders' contact shape (skin_shape.c)
	od_SurfaceContact surface;
	od_FieldSet fields; // force fields (fields/field.c), entering the prediction (energy.c)
	bool selfContact;
	od_BodyContactDef selfDef;
	od_PairScratch selfPairs; // body_contact.c

	od_State state;
	od_State saved;    // the state at the start of the current call, restored on failure
	od_State previous; // the state at the start of the current step (x⁽¹⁾, R⁽¹⁾)

	// Step scratch and the targets of the current objective.
	od_Mode mode;
	bool predictionValid; // y and Rtilde belong to the current objective
	double* y;            // n*3 predicted centres
	double* Rtilde;       // n*9 predicted rotations
	double* inertiaTerm;  // n*9, (ρ/h²) R̃_i Ā_i: the inertia's term of C_i, fixed during a step
	// What a failed call gives back (od_End): the objective before it (its y, R̃, inertia term, swapped out at
	// the start of the call, and its mode) and the step count, so that energy() and counters are as before.
	double *keptY, *keptRtilde, *keptInertiaTerm;
	bool keptPredictionValid;
	od_Mode keptMode;
	long long keptSteps;
	double* angularScale; // n, friction's scaling of the angular velocity of touching particles (floor, colliders)
	double* damping;      // n, c_i per particle (od_Sim_SetParticleDamping); NULL: def.damping for all
	double* contactForce; // n*3, forces of particle contact on the right side during a step (body_contact.c); NULL
						  // until self-contact or a group needs it, zero outside a step's iterations
	od_Iteration iteration;

	bool traceEnabled;
	double* trace;
	int traceCount, traceCapacity;

	// Per particle i, the scale s_i of its ellipsoid's elastic integral (od_Sim_SetStiffnessScale): every
	// term of the elastic energy integrated over ellipsoid j (v_j and Ā_j) is weighted by s_j. NULL: all 1.
	double* stiffnessScale;
	double* elasticVolumes;    // s_i v_i with a scale (the right side's weights, od_ElasticVolumes), else NULL
	// Per particle i, its link softness r_i in (0, 1] (od_Sim_SetLinkSoftness): both halves of link (i, j) are
	// weighted w_ij = min(r_i, r_j), so the term over ellipsoid j of directed edge (i, j) weighs s_j w_ij.
	double* linkSoftness; // NULL: all 1
	double* linkWeight;   // w_ij per directed edge (CSR order of graph->adj) with a softness, else NULL
	// The stretch bound (od_Sim_SetStretchLimit, stretch_bound.c): 0 off, else the limit L > 1, and the softness
	// the weights were last made from, linkSoftness raised where links stretch past L (n; NULL while off).
	double stretchLimit;
	double* linkRaised;   // OD_STRETCH_SCRATCH n: the raised softness, then the bound's scratch
	double* skinGradient; // per link (graph->edges order): its skin gradient (stretch_bound.c; NULL: none)
	unsigned stiffnessVersion; // advances with every change of the scale or the softness (both enter the matrix)

	// Per directed edge (CSR order of graph->adj), scaled by k, the scale and the link weight; rebuilt when one
	// changes: k w_ij (s_j Ā_j + s_i Ā_i) and k w_ij s_j v_j (X̄_j - X̄_i) of the local step, k w_ij s_j v_j
	// (X̄_i - X̄_j) of the right side.
	double* edgeMoment; // 9 per directed edge
	double* edgeArm;    // 3 per directed edge
	double* rowArm;     // 3 per particle: k Σ_j w_ij s_j v_j (X̄_i - X̄_j), the right side's R_i term (global_solve.c)
	double edgeStiffness; // the k they were made with; 0 when the scale or the softness changed (k > 0)

	od_SolverDef solverDef;
	od_Accelerator accelerator;
	double* RInput; // 9n, the input R_k of an accelerated iteration (then the accelerated matrices)
	double* RPlain; // 9n, its plain iterate local(global(R_k))
	od_Pool* pool;  // local-step threads when solverDef.threads > 1
	// The sweep's order (local_step.c). Threaded: sweepOrder[sweepStart[2b]..sweepStart[2b+1]) is block b's
	// interior, up to sweepStart[2b+2] its border; the last range, up to n, the far border. On one thread (no pool,
	// or a small graph) the whole of sweepOrder. Each range in batches updated together and runs of particles
	// updated one by one: sweepBatch[k] the size of the batch from k, or minus the length of the run; 0 inside
	// either. Rebuilt with the constraint terms.
	int* sweepStart;         // 2 threads + 2
	int* sweepOrder;         // n
	signed char* sweepBatch; // n
	bool partitionDirty;

	od_Tolerance tolerance;
	od_StepReport report;
	od_SimCounters counters;
	_Atomic int busy;
};

#define OD_SURFACE_FLOOR (-1) // the floor as a particle's surface in od_SurfaceContact (a collider's: its index)

// How far particle i's slide along `source` may still be cut after the iterations (floor.c, contact.c): the
// friction the forces inside the iterations (surface_contact.c) held within μ f but did not use (0 when it pressed
// another surface or none).
static inline double od_SurfaceContact_Hold(const od_Sim* sim, int i, int source)
{
	const od_SurfaceContact* s = &sim->surface;
	return s->hold && s->source[i] == source ? s->hold[i] : 0.0;
}

// How much of particle i's lift off `source` after the iterations already had its friction, its piece's as a whole
// (surface_contact.c, od_TurnFriction): the projection's own friction is on the rest of its push.
static inline double od_SurfaceContact_Given(const od_Sim* sim, int i, int source)
{
	const od_SurfaceContact* s = &sim->surface;
	return s->given && s->source[i] == source ? s->given[i] : 0.0;
}

// Whether particle i was near `source` in this step's iterations (from the first solve on, on the side it began:
// the sweep after the iterations need not look for where its path met it).
static inline bool od_SurfaceContact_Near(const od_Sim* sim, int i, int source)
{
	const od_SurfaceContact* s = &sim->surface;
	return s->source && !s->after && s->gathered && s->source[i] == source;
}
