// Gauss-Seidel shape matching with oriented particles (Müller and Chentanez, "Solid simulation with
// oriented particles", SIGGRAPH 2011): the baseline the ARAP solver is compared against (issue 5).
//
// Design.
// - Groups. Particle i and its graph neighbours N_i form group i. Its rest centre c̄ is volume weighted;
//   the model keeps, per member j, the rest arm X̄_j - c̄ (CSR over groups, member i first). Masses enter
//   only as ratios, so volumes stand in for masses and the density drops out of every formula.
// - Generalized shape matching. The moment matrix of group i integrates every member's ellipsoid:
//       A = Σ_j [ R_j Ā_j + v_j (x_j - c)(X̄_j - c̄)ᵀ ],   c = Σ_j v_j x_j / Σ_j v_j,
//   with Ā_j = Ē_j 0.2 v_j diag(a², b², c²) Ē_jᵀ (graph->moments). The R_j Ā_j terms keep A full rank
//   for chains and sheets. The group's rotation R maximizes tr(Rᵀ A) (od_PolarRotationWarm, warm-started
//   from particle i's orientation, which then becomes R); the members move `stiffness` of the way to
//   their goals R (X̄_j - c̄) + c. Groups are visited in index order and see each other's updates
//   (Gauss-Seidel); a projection keeps the group's centre of mass, so it conserves momentum.
// - Position constraints are hard PBD projections of the skinned point p = Σ_k w_k (R_k a_k + x_k),
//   a_k = p̄ - X̄_k (Sumner weights), onto its target t, through the translations and the rotations of
//   the skinning particles with generalized inverse masses: with r_k = R_k a_k and J_k the inertia,
//       K = Σ_k w_k² (I / v_k - [r_k]x J_k⁻¹ [r_k]x),  λ = K⁻¹ (t - p),
//       x_k += w_k λ / v_k,  R_k <- exp([w_k J_k⁻¹ (r_k x λ)]x) R_k,
//   so the first-order change of p is exactly t - p. With J_k = R_k J̄_k R_kᵀ and r_k = R_k a_k, K's terms
//   are R_k N_k R_kᵀ with N_k = w_k² (I / v_k + [a_k]xᵀ J̄_k⁻¹ [a_k]x) fixed per constraint (kept with it). Rotating, not only translating, lets a pinned face
//   hold the bar's end against bending (a face of points pins the rotation as well as the position).
// - A step (PBD): v <- (1 - c) v + h g, ω <- (1 - c) ω, x <- x + h v, R <- exp(h ω) R; `iterations`
//   sweeps of (all groups, all constraints, floor); then v = (x - x⁽¹⁾)/h, ω = log(R R⁽¹⁾ᵀ)/h. The floor
//   lifts a particle's lowest point onto the plane every sweep; after the sweeps its tangential motion in
//   the step is cut by friction times the total lift (as the ARAP solver's floor does).
// - Memory. Create allocates the model, the state (one block: x, R, v, ω), a saved copy of it for failed
//   calls and the step scratch; adding constraints grows their array; a step allocates nothing.
#include "opdeform/shape_matching.h"

#include "core.h"
#include "graph.h"
#include "interrupt.h"
#include "math3.h"
#include "polar.h"

#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <string.h>

typedef struct od_SmConstraint
{
	double point[3];  // p̄, rest space
	double target[3]; // t
	int count;
	int idx[OD_MAX_SKIN];
	double w[OD_MAX_SKIN];
	double arm[OD_MAX_SKIN][3];      // a_k = p̄ - X̄_k
	double response[OD_MAX_SKIN][9]; // w_k² (I / v_k + [a_k]xᵀ J̄_k⁻¹ [a_k]x): K's term before turning by R_k
} od_SmConstraint;

struct od_ShapeMatching
{
	const od_Graph* graph;
	od_ShapeMatchingDef def;

	// Model: groups (CSR, member i first), per-particle inverse inertia per unit density in rest space.
	int* groupStart;         // n+1
	int* groupMember;        // n + 2*edgeCount
	double* groupArm;        // 3 per member: X̄_j - c̄ of its group
	double* groupInvVolume;  // n, 1 / Σ_j v_j
	double* restInvInertia;  // n*9, Ē diag(1 / J_a) Ēᵀ with J_a = 0.2 v (r_b² + r_c²)
	od_SmConstraint* constraints;
	int constraintCount, constraintCapacity;
	bool hasFloor;
	double floorHeight, floorFriction;

	// State: one block of 18n doubles, x (3n), R (9n), v (3n), ω (3n); `saved` has the same layout.
	double* state;
	double *x, *R, *v, *omega;
	double* saved;

	// Step scratch: x⁽¹⁾ (3n), R⁽¹⁾ (9n), and per particle the floor's lift, then its angular scale.
	double* start;
	double* contact;

	od_ShapeMatchingCounters counters;
	_Atomic int busy;
};

od_ShapeMatchingDef od_DefaultShapeMatchingDef(void)
{
	// Full stiffness, the paper's h and iteration count, no damping; zero-initialised padding.
	return (od_ShapeMatchingDef){ .stiffness = 1.0, .density = 1000.0, .dt = 1.0 / 60.0, .iterations = 10,
								  .gravity = { 0.0, 0.0, -9.81 }, .damping = 0.0, .skinNeighbors = 4 };
}

typedef struct od_SmRange
{
	const char* name;
	double value, low, high;
	bool openLow;
	const char* range;
} od_SmRange;

static od_Status od_SmCheckDef(const od_ShapeMatchingDef* d)
{
	const od_SmRange ranges[] = {
		{ "stiffness", d->stiffness, 0.0, 1.0, true, "in (0, 1]" },
		{ "density", d->density, 0.0, DBL_MAX, true, "finite and > 0" },
		{ "dt", d->dt, 0.0, DBL_MAX, true, "finite and > 0" },
		{ "iterations", d->iterations, 1.0, DBL_MAX, false, ">= 1" },
		{ "damping", d->damping, 0.0, 1.0, false, "in [0, 1]" },
		{ "skin_neighbors", d->skinNeighbors, 1.0, OD_MAX_SKIN, false, "in [1, 16]" },
	};
	for (size_t k = 0; k < sizeof ranges / sizeof ranges[0]; ++k)
	{
		const od_SmRange* r = ranges + k;
		bool aboveLow = r->openLow ? r->value > r->low : r->value >= r->low;
		if (!aboveLow || !(r->value <= r->high))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "%s = %g must be %s", r->name, r->value, r->range);
		}
	}
	return od_IsFinite3(d->gravity) ? OD_OK : od_Fail(OD_ERROR_ARGUMENT, "gravity must be three finite numbers");
}

// Groups and their rest arms; the inverse inertias. Returns false when out of memory.
static bool od_SmBuildModel(od_ShapeMatching* sm)
{
	const od_Graph* g = sm->graph;
	int n = g->n, members = n + 2 * g->edgeCount;
	sm->groupStart = od_Alloc(sizeof(int) * ((size_t)n + 1));
	sm->groupMember = od_Alloc(sizeof(int) * (size_t)members);
	sm->groupArm = od_Alloc(sizeof(double) * 3 * (size_t)members);
	sm->groupInvVolume = od_Alloc(sizeof(double) * (size_t)n);
	sm->restInvInertia = od_Alloc(sizeof(double) * 9 * (size_t)n);
	if (!sm->groupStart || !sm->groupMember || !sm->groupArm || !sm->groupInvVolume || !sm->restInvInertia)
	{
		return false;
	}
	int e = 0;
	for (int i = 0; i < n; ++i)
	{
		sm->groupStart[i] = e;
		sm->groupMember[e++] = i;
		for (int k = g->adjStart[i]; k < g->adjStart[i + 1]; ++k)
		{
			sm->groupMember[e++] = g->adj[k];
		}
		double volume = 0.0;
		od_Vec3 rest = od_V3(0, 0, 0);
		for (int k = sm->groupStart[i]; k < e; ++k)
		{
			int j = sm->groupMember[k];
			volume += g->volumes[j];
			rest = od_MulAdd(rest, g->volumes[j], od_V3Load(g->centers + 3 * j));
		}
		sm->groupInvVolume[i] = 1.0 / volume;
		rest = od_Scale(1.0 / volume, rest);
		for (int k = sm->groupStart[i]; k < e; ++k)
		{
			od_V3Store(sm->groupArm + 3 * k, od_Sub(od_V3Load(g->centers + 3 * sm->groupMember[k]), rest));
		}
	}
	sm->groupStart[n] = e;
	for (int i = 0; i < n; ++i)
	{
		const double* r = g->radii + 3 * i;
		double r2[3] = { r[0] * r[0], r[1] * r[1], r[2] * r[2] };
		od_Mat3 frame = od_M3Load(g->axes + 9 * i), inv = od_M3Zero();
		for (int a = 0; a < 3; ++a)
		{
			double principal = 0.2 * g->volumes[i] * (r2[(a + 1) % 3] + r2[(a + 2) % 3]);
			od_Vec3 axis = od_V3(frame.m[a], frame.m[3 + a], frame.m[6 + a]);
			od_M3AddOuter(&inv, 1.0 / principal, axis, axis);
		}
		od_M3Store(sm->restInvInertia + 9 * i, &inv);
	}
	return true;
}

static void od_SmSetStatePointers(od_ShapeMatching* sm)
{
	size_t n = (size_t)sm->graph->n;
	sm->x = sm->state;
	sm->R = sm->state + 3 * n;
	sm->v = sm->state + 12 * n;
	sm->omega = sm->state + 15 * n;
}

od_Status od_ShapeMatching_Create(const od_Graph* graph, const od_ShapeMatchingDef* def, od_ShapeMatching** out)
{
	*out = NULL;
	if (!graph || !def)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "graph and def are required");
	}
	od_Status status = od_SmCheckDef(def);
	if (status != OD_OK)
	{
		return status;
	}
	size_t n = (size_t)graph->n;
	od_ShapeMatching* sm = od_AllocZero(1, sizeof *sm);
	if (!sm)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory creating a shape-matching solver");
	}
	sm->graph = graph;
	sm->def = *def;
	sm->state = od_AllocZero(18 * n, sizeof(double));
	sm->saved = od_Alloc(sizeof(double) * 18 * n);
	sm->start = od_Alloc(sizeof(double) * 12 * n);
	sm->contact = od_Alloc(sizeof(double) * n);
	if (!sm->state || !sm->saved || !sm->start || !sm->contact || !od_SmBuildModel(sm))
	{
		od_ShapeMatching_Destroy(sm);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for shape matching on %d particles", graph->n);
	}
	od_SmSetStatePointers(sm);
	memcpy(sm->x, graph->centers, sizeof(double) * 3 * n);
	const od_Mat3 eye = od_M3Identity();
	for (size_t i = 0; i < n; ++i)
	{
		od_M3Store(sm->R + 9 * i, &eye);
	}
	*out = sm;
	return OD_OK;
}

void od_ShapeMatching_Destroy(od_ShapeMatching* sm)
{
	if (!sm)
	{
		return;
	}
	od_Free(sm->groupStart);
	od_Free(sm->groupMember);
	od_Free(sm->groupArm);
	od_Free(sm->groupInvVolume);
	od_Free(sm->restInvInertia);
	od_Free(sm->constraints);
	od_Free(sm->state);
	od_Free(sm->saved);
	od_Free(sm->start);
	od_Free(sm->contact);
	od_Free(sm);
}

// Skinning weights, arms and the rotation-free part of K (R_k turns it: R_k N_k R_kᵀ) of a constraint.
static void od_SmBind(const od_ShapeMatching* sm, od_SmConstraint* c, int neighbors)
{
	const od_Graph* g = sm->graph;
	c->count = od_Graph_SkinWeights(g, c->point, neighbors, c->idx, c->w);
	for (int k = 0; k < c->count; ++k)
	{
		int j = c->idx[k];
		od_Vec3 arm = od_Sub(od_V3Load(c->point), od_V3Load(g->centers + 3 * j));
		od_Mat3 skew = od_M3Skew(arm), inv = od_M3Load(sm->restInvInertia + 9 * j);
		od_Mat3 js = od_M3Mul(&inv, &skew);
		od_Mat3 n = od_M3MulTN(&skew, &js);
		for (int d = 0; d < 9; d += 4)
		{
			n.m[d] += 1.0 / g->volumes[j];
		}
		for (int d = 0; d < 9; ++d)
		{
			c->response[k][d] = c->w[k] * c->w[k] * n.m[d];
		}
		od_V3Store(c->arm[k], arm);
	}
}

od_Status od_ShapeMatching_SetDef(od_ShapeMatching* sm, const od_ShapeMatchingDef* def)
{
	od_Status status = od_SmCheckDef(def);
	for (int s = 0; status == OD_OK && def->skinNeighbors != sm->def.skinNeighbors && s < sm->constraintCount; ++s)
	{
		od_SmBind(sm, sm->constraints + s, def->skinNeighbors);
	}
	if (status == OD_OK)
	{
		sm->def = *def;
	}
	return status;
}

// ---------------------------------------------------------------------------------------------------------
// Constraints

// The skinned point Σ_k w_k (R_k a_k + x_k).
static od_Vec3 od_SmSkinnedPoint(const od_ShapeMatching* sm, const od_SmConstraint* c)
{
	od_Vec3 p = od_V3(0, 0, 0);
	for (int k = 0; k < c->count; ++k)
	{
		int j = c->idx[k];
		od_Mat3 r = od_M3Load(sm->R + 9 * j);
		p = od_MulAdd(p, c->w[k], od_Add(od_M3MulV(&r, od_V3Load(c->arm[k])), od_V3Load(sm->x + 3 * j)));
	}
	return p;
}

static od_Status od_SmCheckVector(const char* name, const double* p)
{
	return p && od_IsFinite3(p) ? OD_OK : od_Fail(OD_ERROR_ARGUMENT, "%s must be three finite numbers", name);
}

od_Status od_ShapeMatching_AddPositionConstraint(od_ShapeMatching* sm, const double point[3], const double* target,
												 int* id)
{
	od_Status status = od_SmCheckVector("point", point);
	if (status == OD_OK && target)
	{
		status = od_SmCheckVector("target", target);
	}
	if (status != OD_OK)
	{
		return status;
	}
	if (sm->constraintCount == sm->constraintCapacity)
	{
		int capacity = sm->constraintCapacity ? 2 * sm->constraintCapacity : 16;
		od_SmConstraint* grown = od_Realloc(sm->constraints, sizeof(od_SmConstraint) * (size_t)capacity);
		if (!grown)
		{
			return od_Fail(OD_ERROR_MEMORY, "out of memory adding a constraint");
		}
		sm->constraints = grown;
		sm->constraintCapacity = capacity;
	}
	od_SmConstraint* c = sm->constraints + sm->constraintCount;
	memset(c, 0, sizeof *c);
	memcpy(c->point, point, sizeof c->point);
	od_SmBind(sm, c, sm->def.skinNeighbors);
	if (target)
	{
		memcpy(c->target, target, sizeof c->target);
	}
	else
	{
		od_V3Store(c->target, od_SmSkinnedPoint(sm, c));
	}
	if (id)
	{
		*id = sm->constraintCount;
	}
	sm->constraintCount++;
	return OD_OK;
}

od_Status od_ShapeMatching_SetConstraintTarget(od_ShapeMatching* sm, int id, const double target[3])
{
	if (id < 0 || id >= sm->constraintCount)
	{
		return od_Fail(OD_ERROR_NOT_FOUND, "no constraint with id %d", id);
	}
	od_Status status = od_SmCheckVector("target", target);
	if (status == OD_OK)
	{
		memcpy(sm->constraints[id].target, target, sizeof(double) * 3);
	}
	return status;
}

int od_ShapeMatching_GetConstraintCount(const od_ShapeMatching* sm)
{
	return sm->constraintCount;
}

// k⁻¹ b for a symmetric 3x3 k through its adjugate; false when k is singular.
static bool od_SmSolveSymmetric(const od_Mat3* k, od_Vec3 b, od_Vec3* out)
{
	od_Vec3 r0 = od_V3Load(k->m), r1 = od_V3Load(k->m + 3), r2 = od_V3Load(k->m + 6);
	od_Vec3 c0 = od_Cross(r1, r2), c1 = od_Cross(r2, r0), c2 = od_Cross(r0, r1);
	double det = od_Dot(r0, c0);
	if (!(fabs(det) > 0.0))
	{
		return false;
	}
	*out = od_Scale(1.0 / det, od_Add(od_Add(od_Scale(b.x, c0), od_Scale(b.y, c1)), od_Scale(b.z, c2)));
	return true;
}

static void od_SmProject(od_ShapeMatching* sm, const od_SmConstraint* c)
{
	const od_Graph* g = sm->graph;
	od_Vec3 error = od_Sub(od_V3Load(c->target), od_SmSkinnedPoint(sm, c));
	od_Mat3 k = od_M3Zero();
	for (int s = 0; s < c->count; ++s)
	{
		od_Mat3 r = od_M3Load(sm->R + 9 * c->idx[s]), n = od_M3Load(c->response[s]);
		od_Mat3 rn = od_M3Mul(&r, &n);
		od_Mat3 term = od_M3MulNT(&rn, &r);
		od_M3AddScaled(&k, 1.0, &term);
	}
	od_Vec3 lambda;
	if (!od_SmSolveSymmetric(&k, error, &lambda))
	{
		return;
	}
	for (int s = 0; s < c->count; ++s)
	{
		int j = c->idx[s];
		od_V3Store(sm->x + 3 * j, od_MulAdd(od_V3Load(sm->x + 3 * j), c->w[s] / g->volumes[j], lambda));
		// w J⁻¹ (r x λ) with J = R J̄ Rᵀ and r = R a: w R J̄⁻¹ (a x Rᵀλ).
		od_Mat3 r = od_M3Load(sm->R + 9 * j), inv = od_M3Load(sm->restInvInertia + 9 * j);
		od_Vec3 local = od_M3MulV(&inv, od_Cross(od_V3Load(c->arm[s]), od_M3MulTV(&r, lambda)));
		od_Mat3 dr = od_M3ExpSkew(od_Scale(c->w[s], od_M3MulV(&r, local)));
		od_Mat3 turned = od_M3Mul(&dr, &r);
		od_M3Store(sm->R + 9 * j, &turned);
	}
}

// ---------------------------------------------------------------------------------------------------------
// Floor

od_Status od_ShapeMatching_SetFloor(od_ShapeMatching* sm, double height, double friction)
{
	bool heightOk = isfinite(height), frictionOk = friction >= 0.0 && isfinite(friction);
	if (heightOk && frictionOk)
	{
		sm->hasFloor = true;
		sm->floorHeight = height;
		sm->floorFriction = friction;
		return OD_OK;
	}
	return od_Fail(OD_ERROR_ARGUMENT, heightOk ? "friction = %g must be finite and >= 0" : "height = %g must be finite",
				   heightOk ? friction : height);
}

void od_ShapeMatching_ClearFloor(od_ShapeMatching* sm)
{
	sm->hasFloor = false;
}

// Lifts every particle's lowest point onto the floor; contact[i] adds up the lifts of the step.
static void od_SmFloorProject(od_ShapeMatching* sm)
{
	const od_Graph* g = sm->graph;
	for (int i = 0; i < g->n; ++i)
	{
		// The z row of the frame R Ē, scaled by the radii, is the support vector along -z.
		od_Mat3 rest = od_M3Load(g->axes + 9 * i);
		od_Vec3 up = od_M3MulTV(&rest, od_V3Load(sm->R + 9 * i + 6));
		const double* radius = g->radii + 3 * i;
		double reach = od_Length(od_V3(radius[0] * up.x, radius[1] * up.y, radius[2] * up.z));
		double depth = sm->floorHeight + reach - sm->x[3 * i + 2];
		if (depth > 0.0)
		{
			sm->x[3 * i + 2] += depth;
			sm->contact[i] += depth;
		}
	}
}

// Friction after the sweeps: the tangential move of the step shrinks by μ times the lift (to zero at
// most); contact[i] becomes the factor on the particle's angular velocity.
static void od_SmFloorFriction(od_ShapeMatching* sm)
{
	const double* x0 = sm->start;
	for (int i = 0; i < sm->graph->n; ++i)
	{
		double lift = sm->contact[i];
		sm->contact[i] = 1.0;
		if (!(lift > 0.0) || !(sm->floorFriction > 0.0))
		{
			continue;
		}
		od_Vec3 move = od_Sub(od_V3Load(sm->x + 3 * i), od_V3Load(x0 + 3 * i));
		move.z = 0.0;
		double slide = od_Length(move), allowance = sm->floorFriction * lift;
		double keep = slide > allowance ? 1.0 - allowance / slide : 0.0;
		od_V3Store(sm->x + 3 * i, od_MulAdd(od_V3Load(sm->x + 3 * i), keep - 1.0, move));
		sm->contact[i] = keep;
	}
}

// ---------------------------------------------------------------------------------------------------------
// Step

static void od_SmPredict(od_ShapeMatching* sm)
{
	double h = sm->def.dt, keep = 1.0 - sm->def.damping;
	od_Vec3 gravity = od_V3Load(sm->def.gravity);
	for (int i = 0; i < sm->graph->n; ++i)
	{
		od_Vec3 v = od_MulAdd(od_Scale(keep, od_V3Load(sm->v + 3 * i)), h, gravity);
		od_Vec3 w = od_Scale(keep, od_V3Load(sm->omega + 3 * i));
		od_V3Store(sm->v + 3 * i, v);
		od_V3Store(sm->omega + 3 * i, w);
		od_V3Store(sm->x + 3 * i, od_MulAdd(od_V3Load(sm->x + 3 * i), h, v));
		od_Mat3 spin = od_M3ExpSkew(od_Scale(h, w)), r = od_M3Load(sm->R + 9 * i);
		od_Mat3 turned = od_M3Mul(&spin, &r);
		od_M3Store(sm->R + 9 * i, &turned);
	}
}

// One group: its rotation (which particle i takes) and the move of its members towards their goals.
static void od_SmMatchGroup(od_ShapeMatching* sm, int i)
{
	const od_Graph* g = sm->graph;
	int begin = sm->groupStart[i], end = sm->groupStart[i + 1];
	od_Vec3 centre = od_V3(0, 0, 0);
	for (int k = begin; k < end; ++k)
	{
		int j = sm->groupMember[k];
		centre = od_MulAdd(centre, g->volumes[j], od_V3Load(sm->x + 3 * j));
	}
	centre = od_Scale(sm->groupInvVolume[i], centre);
	od_Mat3 a = od_M3Zero();
	for (int k = begin; k < end; ++k)
	{
		int j = sm->groupMember[k];
		od_Mat3 r = od_M3Load(sm->R + 9 * j), moment = od_M3Load(g->moments + 9 * j);
		od_Mat3 rm = od_M3Mul(&r, &moment);
		od_M3AddScaled(&a, 1.0, &rm);
		od_M3AddOuter(&a, g->volumes[j], od_Sub(od_V3Load(sm->x + 3 * j), centre), od_V3Load(sm->groupArm + 3 * k));
	}
	od_Mat3 rotation = od_M3Load(sm->R + 9 * i);
	sm->counters.polarFallbacks += od_PolarRotationWarm(&a, &rotation);
	od_M3Store(sm->R + 9 * i, &rotation);
	double s = sm->def.stiffness;
	for (int k = begin; k < end; ++k)
	{
		double* x = sm->x + 3 * sm->groupMember[k];
		od_Vec3 goal = od_Add(od_M3MulV(&rotation, od_V3Load(sm->groupArm + 3 * k)), centre);
		od_V3Store(x, od_MulAdd(od_V3Load(x), s, od_Sub(goal, od_V3Load(x))));
	}
}

static void od_SmSweep(od_ShapeMatching* sm)
{
	for (int i = 0; i < sm->graph->n; ++i)
	{
		od_SmMatchGroup(sm, i);
	}
	sm->counters.groupSolves += sm->graph->n;
	for (int c = 0; c < sm->constraintCount; ++c)
	{
		od_SmProject(sm, sm->constraints + c);
	}
	if (sm->hasFloor)
	{
		od_SmFloorProject(sm);
	}
}

// Velocities from the step's change of position and orientation; re-orthonormalizes the rotations.
static void od_SmFinishStep(od_ShapeMatching* sm)
{
	size_t n = (size_t)sm->graph->n;
	const double *x0 = sm->start, *r0 = sm->start + 3 * n;
	double rate = 1.0 / sm->def.dt;
	for (size_t i = 0; i < n; ++i)
	{
		od_V3Store(sm->v + 3 * i, od_Scale(rate, od_Sub(od_V3Load(sm->x + 3 * i), od_V3Load(x0 + 3 * i))));
	}
	for (size_t i = 0; i < n; ++i)
	{
		od_Mat3 r = od_M3Load(sm->R + 9 * i), before = od_M3Load(r0 + 9 * i);
		od_Orthonormalize(&r);
		od_M3Store(sm->R + 9 * i, &r);
		od_Mat3 change = od_M3MulNT(&r, &before);
		double scale = sm->hasFloor ? rate * sm->contact[i] : rate;
		od_V3Store(sm->omega + 3 * i, od_Scale(scale, od_M3LogRotation(&change)));
	}
}

static bool od_SmStateIsFinite(const od_ShapeMatching* sm)
{
	for (size_t k = 0; k < 18 * (size_t)sm->graph->n; ++k)
	{
		if (!isfinite(sm->state[k]))
		{
			return false;
		}
	}
	return true;
}

od_Status od_ShapeMatching_Step(od_ShapeMatching* sm, int steps)
{
	if (steps < 1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "steps = %d must be >= 1", steps);
	}
	if (atomic_exchange(&sm->busy, 1))
	{
		return od_Fail(OD_ERROR_BUSY, "the shape-matching solver is being used by another thread");
	}
	size_t n = (size_t)sm->graph->n;
	memcpy(sm->saved, sm->state, sizeof(double) * 18 * n);
	od_Status status = OD_OK;
	for (int step = 0; step < steps; ++step)
	{
		memcpy(sm->start, sm->state, sizeof(double) * 12 * n); // x and R, adjacent in the state block
		memset(sm->contact, 0, sizeof(double) * n);
		od_SmPredict(sm);
		for (int it = 0; it < sm->def.iterations; ++it)
		{
			od_SmSweep(sm);
		}
		if (sm->hasFloor)
		{
			od_SmFloorFriction(sm);
		}
		od_SmFinishStep(sm);
		sm->counters.steps++;
		status = od_SmStateIsFinite(sm) ? od_CheckInterrupt()
										: od_Fail(OD_ERROR_NOT_FINITE, "the step produced a non-finite state; the "
																	   "previous state was kept");
		if (status != OD_OK)
		{
			memcpy(sm->state, sm->saved, sizeof(double) * 18 * n);
			break;
		}
	}
	atomic_store(&sm->busy, 0);
	return status;
}

// ---------------------------------------------------------------------------------------------------------
// State

static od_Status od_SmCheckArray(const char* name, const double* values, int n)
{
	for (int k = 0; values && k < 3 * n; ++k)
	{
		if (!isfinite(values[k]))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "%s[%d][%d] is not finite", name, k / 3, k % 3);
		}
	}
	return OD_OK;
}

static od_Status od_SmCheckRotation(const double* rotation, int i)
{
	const od_Mat3 r = od_M3Load(rotation), eye = od_M3Identity();
	od_Mat3 gram = od_M3MulTN(&r, &r);
	od_M3AddScaled(&gram, -1.0, &eye);
	double err = od_M3Inner(&gram, &gram), det = od_M3Det(&r);
	return err < 1e-12 && det > 0.0 ? OD_OK
									: od_Fail(OD_ERROR_ARGUMENT,
											  "rotations[%d] is not a proper rotation (|RᵀR - I|² = %.3g, det = %.6g)",
											  i, err, det);
}

od_Status od_ShapeMatching_SetState(od_ShapeMatching* sm, const double* positions, const double* rotations,
									const double* velocities, const double* angularVelocities)
{
	int n = sm->graph->n;
	if (!positions || !rotations)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "positions and rotations are required");
	}
	od_Status status = od_SmCheckArray("positions", positions, n);
	for (int i = 0; i < n && status == OD_OK; ++i)
	{
		status = od_SmCheckRotation(rotations + 9 * i, i);
	}
	if (status == OD_OK)
	{
		status = od_SmCheckArray("velocities", velocities, n);
	}
	if (status == OD_OK)
	{
		status = od_SmCheckArray("angular_velocities", angularVelocities, n);
	}
	if (status != OD_OK)
	{
		return status;
	}
	const double* sources[4] = { positions, rotations, velocities, angularVelocities };
	double* targets[4] = { sm->x, sm->R, sm->v, sm->omega };
	const size_t widths[4] = { 3, 9, 3, 3 };
	for (int a = 0; a < 4; ++a)
	{
		size_t bytes = sizeof(double) * widths[a] * (size_t)n;
		if (sources[a])
		{
			memcpy(targets[a], sources[a], bytes);
		}
		else
		{
			memset(targets[a], 0, bytes);
		}
	}
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 r = od_M3Load(sm->R + 9 * i);
		od_Orthonormalize(&r);
		od_M3Store(sm->R + 9 * i, &r);
	}
	return OD_OK;
}

const double* od_ShapeMatching_GetPositions(const od_ShapeMatching* sm)
{
	return sm->x;
}

const double* od_ShapeMatching_GetRotations(const od_ShapeMatching* sm)
{
	return sm->R;
}

const double* od_ShapeMatching_GetVelocities(const od_ShapeMatching* sm)
{
	return sm->v;
}

const double* od_ShapeMatching_GetAngularVelocities(const od_ShapeMatching* sm)
{
	return sm->omega;
}

od_ShapeMatchingDef od_ShapeMatching_GetDef(const od_ShapeMatching* sm)
{
	return sm->def;
}

od_ShapeMatchingCounters od_ShapeMatching_GetCounters(const od_ShapeMatching* sm)
{
	return sm->counters;
}
