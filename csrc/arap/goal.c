// Goals: each particle pulled toward an animated frame (Soft Body's Goal, nCloth's Input Mesh Attract, in
// ARAP form). The only file that holds their maths.
//
// Particle i with goal centre g_i, goal rotation G_i and angular frequency ω_i = 2π f_i adds
//   E_goal,i = ½ ρ ω_i² (v_i |x_i - g_i|² + tr((R_i - G_i) Ā_i (R_i - G_i)ᵀ)),
// the inertia term of implicit Euler with (R̃, y, 1/h²) replaced by (G, g, ω²): a spring whose frequency,
// not its stiffness, is the setting, so it means the same at any size, mass and frame rate. It adds
// ρ v_i ω_i² to the global matrix's diagonal (refactored once per change of frequencies, tracked by
// goals.version), ρ v_i ω_i² g_i to the right side and ρ ω_i² G_i Ā_i to C_i of the local step; a new
// goal frame per frame changes only the right side and that term. Without goals (frequencies NULL)
// nothing here runs.
//
// Goals carrying the rest (od_Sim_SetGoalRest, docs/goals.md): the elastic energy is measured against the
// animated shape instead of the rest shape, so the animation is the equilibrium and only its acceleration
// drives the body. Ellipsoid j seen from particle i's frame follows the rigid map y -> x_i + R_i G_iᵀ (y - g_i)
// of the goal shape (the rest point X̄_j + u sits at g_j + G_j u there), so its term of eq. 3 becomes
//   s_j (v_j |x_j - x_i - R_i d_ij|² + tr((R_j - R_i Q_ij) Ā_j (R_j - R_i Q_ij)ᵀ)),  d_ij = G_iᵀ (g_j - g_i),
//   Q_ij = G_iᵀ G_j,
// zero at x = g, R = G, and today's term when G = I, g = X̄ (or the goal is one rigid motion). Positions enter
// as before (v_j |x_j - x_i - ..|²): the global matrix is unchanged, its right side takes R_i d_ij for
// R_i (X̄_j - X̄_i). R_i enters C_i linearly (the quadratic part is tr(Q Ā Qᵀ), constant), through
// k Σ_j [R_j (s_j Ā_j Q_ji + s_i Q_ji Ā_i) + s_j v_j (x_j - x_i) d_ijᵀ]: the local step stays an exact
// block minimization. The edges' terms are made again from each new goal frame (O(edges), no refactor).
// The goals' velocity u_i and angular velocity Ω_i, measured between successive frames over the steps taken
// between them, let the prediction damp only the motion relative to the goals (energy.c).
#include "goal.h"

#include "check.h"
#include "core.h"
#include "math3.h"

#include <limits.h>
#include <math.h>
#include <string.h>

#define OD_TWO_PI 6.283185307179586

// The arrays of goals carrying the rest; the setting stays.
static void od_FreeMotion(od_Goals* goals)
{
	od_Free(goals->edgeRest);
	od_Free(goals->edgeTurn);
	od_Free(goals->velocity);
	od_Free(goals->spin);
	od_Free(goals->frameX);
	od_Free(goals->frameR);
	goals->edgeRest = goals->edgeTurn = goals->velocity = goals->spin = goals->frameX = goals->frameR = NULL;
	goals->placed = false;
}

void od_Goals_Destroy(od_Goals* goals)
{
	od_Free(goals->omega2);
	od_Free(goals->x);
	od_Free(goals->R);
	od_Free(goals->term);
	goals->omega2 = goals->x = goals->R = goals->term = NULL; // the version stays: it keys the factor
	od_FreeMotion(goals);
}

// The arrays of goals carrying the rest, when the setting is on and goals exist; the goals start at rest.
static od_Status od_AllocateMotion(od_Sim* sim)
{
	od_Goals* goals = &sim->goals;
	if (!goals->carryRest || !goals->omega2 || goals->edgeRest)
	{
		return OD_OK;
	}
	size_t n = (size_t)sim->graph->n;
	goals->edgeRest = od_Alloc(sizeof(double) * 12 * (size_t)sim->graph->edgeCount);
	goals->edgeTurn = od_Alloc(sizeof(double) * 18 * (size_t)sim->graph->edgeCount);
	goals->velocity = od_AllocZero(3 * n, sizeof(double));
	goals->spin = od_AllocZero(3 * n, sizeof(double));
	goals->frameX = od_Alloc(sizeof(double) * 3 * n);
	goals->frameR = od_Alloc(sizeof(double) * 9 * n);
	if (!goals->edgeRest || !goals->edgeTurn || !goals->velocity || !goals->spin || !goals->frameX || !goals->frameR)
	{
		od_FreeMotion(goals);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the goal shape of %zu particles", n);
	}
	memcpy(goals->frameX, goals->x, sizeof(double) * 3 * n);
	memcpy(goals->frameR, goals->R, sizeof(double) * 9 * n);
	goals->framed = false;
	sim->edgeStiffness = 0.0; // the edges' terms are made again (local_step.c)
	return OD_OK;
}

// ρ ω_i² G_i Ā_i for every particle.
static void od_UpdateTerms(od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	od_Goals* goals = &sim->goals;
	for (int i = 0; i < g->n; ++i)
	{
		od_Mat3 r = od_M3Load(goals->R + 9 * i), a = od_M3Load(g->moments + 9 * i);
		od_Mat3 ra = od_M3Mul(&r, &a);
		for (int k = 0; k < 9; ++k)
		{
			goals->term[9 * i + k] = sim->def.density * goals->omega2[i] * ra.m[k];
		}
	}
}

// Goal frames start at the rest frames.
static od_Status od_Allocate(od_Sim* sim)
{
	int n = sim->graph->n;
	od_Goals* goals = &sim->goals;
	goals->omega2 = od_Alloc(sizeof(double) * n);
	goals->x = od_Alloc(sizeof(double) * 3 * n);
	goals->R = od_Alloc(sizeof(double) * 9 * n);
	goals->term = od_Alloc(sizeof(double) * 9 * n);
	if (!goals->omega2 || !goals->x || !goals->R || !goals->term)
	{
		od_Goals_Destroy(goals);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the goals of %d particles", n);
	}
	memcpy(goals->x, sim->graph->centers, sizeof(double) * 3 * n);
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 eye = od_M3Identity();
		od_M3Store(goals->R + 9 * i, &eye);
	}
	od_Status status = od_AllocateMotion(sim);
	if (status != OD_OK)
	{
		od_Goals_Destroy(goals);
	}
	return status;
}

od_Status od_Sim_SetGoalFrequencies(od_Sim* sim, const double* frequencies)
{
	int n = sim->graph->n;
	for (int i = 0; frequencies && i < n; ++i)
	{
		if (!(frequencies[i] >= 0.0) || !isfinite(frequencies[i]))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "goal frequencies[%d] = %g must be finite and >= 0", i, frequencies[i]);
		}
	}
	sim->goals.version++;
	if (!frequencies)
	{
		od_Goals_Destroy(&sim->goals);
		return OD_OK;
	}
	if (!sim->goals.omega2)
	{
		od_Status status = od_Allocate(sim);
		if (status != OD_OK)
		{
			return status;
		}
	}
	for (int i = 0; i < n; ++i)
	{
		double omega = OD_TWO_PI * frequencies[i];
		sim->goals.omega2[i] = omega * omega;
	}
	od_UpdateTerms(sim);
	return OD_OK;
}

// V(w) = ∫₀¹ exp(s [w]×) ds = I + (1 - cos t)/t² [w]× + (t - sin t)/t³ [w]×², t = |w|: a point riding a screw
// motion of angular velocity Ω whose velocity is v at time 0 is at τ V(τ Ω) v at time τ, its velocity there
// exp(τ [Ω]×) v. Series below t = 0.1, where the closed form cancels.
static od_Mat3 od_ScrewMatrix(od_Vec3 w)
{
	double t2 = od_Dot(w, w);
	if (t2 < 1e-2)
	{
		return od_M3SkewSeries(w, 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0)),
							   1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0)));
	}
	double t = sqrt(t2);
	return od_M3SkewSeries(w, (1.0 - cos(t)) / t2, (t - sin(t)) / (t2 * t));
}

// V(w)⁻¹ = I - ½ [w]× + (1 - (t/2) cot(t/2))/t² [w]×², for t < 2π.
static od_Mat3 od_ScrewMatrixInverse(od_Vec3 w)
{
	double t2 = od_Dot(w, w);
	if (t2 < 1e-2)
	{
		return od_M3SkewSeries(w, -0.5, 1.0 / 12.0 + t2 / 720.0 * (1.0 + t2 / 42.0));
	}
	double t = sqrt(t2);
	return od_M3SkewSeries(w, -0.5, (1.0 - 0.5 * t * sin(t) / (1.0 - cos(t))) / t2);
}

// A turn between two frames within this of a half turn could have gone either way: the goal fits of a rig
// turning 180 degrees a frame are a half turn up to rounding, which alone chose each particle's way, so that
// neighbours turned opposite ways between the frames (docs/goals.md, "A rig turning half a turn a frame").
#define OD_HALF_TURN_BAND 0.1

static od_Vec3 od_FrameTurn(const double* rotations, const od_Goals* goals, int i)
{
	od_Mat3 to = rotations ? od_M3Load(rotations + 9 * i) : od_M3Identity(), from = od_M3Load(goals->R + 9 * i);
	od_Mat3 turn = od_M3MulNT(&to, &from);
	return od_M3LogRotation(&turn);
}

// The way the body turns: the turns clearly less than a half turn and the goals' last angular velocities; when
// there are none, the first near half turn's.
static od_Vec3 od_TurnWay(const od_Sim* sim, const double* rotations)
{
	const od_Goals* goals = &sim->goals;
	od_Vec3 way = od_V3(0, 0, 0), first = way;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Vec3 turn = od_FrameTurn(rotations, goals, i);
		bool half = od_Length(turn) > M_PI - OD_HALF_TURN_BAND;
		way = od_Add(way, od_Add(half ? od_V3(0, 0, 0) : turn, od_V3Load(goals->spin + 3 * i)));
		first = half && od_Dot(first, first) == 0.0 ? turn : first;
	}
	return od_Dot(way, way) > 0.0 ? way : first;
}

// The goals' motion from the frame they are leaving to the new one, over the steps taken since it was set, as a
// screw motion per goal: the angular velocity Ω_i of the turn (a turn near a half turn the way the body turns,
// od_TurnWay) and the velocity u_i at the new frame, so that the goal centre went along the arc
// g_i + τ V(τ Ω_i) u_i, τ from -T to 0 (od_ScrewMatrix), not along the chord: at 180 degrees a frame the
// chord of every goal passes through the axis. None taken: the new frame replaces it and the motion stays.
// The edges' terms are made again.
static void od_TrackMotion(od_Sim* sim, const double* positions, const double* rotations)
{
	od_Goals* goals = &sim->goals;
	long long steps = sim->counters.steps - goals->mark;
	double time = goals->framed && steps > 0 ? sim->def.dt * (double)steps : 0.0;
	od_Vec3 way = time > 0.0 ? od_TurnWay(sim, rotations) : od_V3(0, 0, 0);
	for (int i = 0; time > 0.0 && i < sim->graph->n; ++i)
	{
		od_Vec3 turn = od_FrameTurn(rotations, goals, i);
		double angle = od_Length(turn);
		if (angle > M_PI - OD_HALF_TURN_BAND && od_Dot(turn, way) < 0.0)
		{
			turn = od_Scale((angle - 2.0 * M_PI) / angle, turn);
		}
		od_Vec3 chord = od_Scale(1.0 / time, od_Sub(od_V3Load(positions + 3 * i), od_V3Load(goals->x + 3 * i)));
		od_Mat3 back = od_ScrewMatrixInverse(od_Scale(-1.0, turn));
		od_V3Store(goals->velocity + 3 * i, od_M3MulV(&back, chord));
		od_V3Store(goals->spin + 3 * i, od_Scale(1.0 / time, turn));
	}
	goals->mark = sim->counters.steps;
	goals->framed = true;
	sim->edgeStiffness = 0.0;
}

od_Status od_Sim_SetGoals(od_Sim* sim, const double* positions, const double* rotations)
{
	int n = sim->graph->n;
	if (!sim->goals.omega2)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "goals: set the goal frequencies first");
	}
	if (!positions)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "goal positions are required");
	}
	od_Status status = od_CheckFinite("goal positions", positions, 3 * n);
	if (status == OD_OK && rotations)
	{
		status = od_CheckRotations("goal rotations", rotations, n);
	}
	if (status != OD_OK)
	{
		return status;
	}
	if (od_Goals_CarryRest(sim))
	{
		od_TrackMotion(sim, positions, rotations);
	}
	memcpy(sim->goals.x, positions, sizeof(double) * 3 * n);
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 r = rotations ? od_M3Load(rotations + 9 * i) : od_M3Identity();
		od_M3Store(sim->goals.R + 9 * i, &r);
	}
	if (od_Goals_CarryRest(sim))
	{
		memcpy(sim->goals.frameX, sim->goals.x, sizeof(double) * 3 * n);
		memcpy(sim->goals.frameR, sim->goals.R, sizeof(double) * 9 * n);
	}
	od_UpdateTerms(sim);
	return OD_OK;
}

// Goals carrying the rest between frames: in a call made just after a new frame (no step since it was set),
// step k of n places each goal where its measured motion (velocity u_i, angular velocity Ω_i, od_TrackMotion,
// the motion the prediction already damps against) puts it b = n - 1 - k steps before the frame,
// g_i - b h u_i and exp(-b h [Ω_i]×) G_i, so the animation moves across a frame's substeps instead of jumping to
// the frame at the first (docs/goals.md, "Between frames"). The last step has the frame itself. The edges'
// terms stay those of the frame set: a rigid motion of the goals leaves them unchanged.
void od_Goals_Place(od_Sim* sim)
{
	od_Goals* goals = &sim->goals;
	int back = goals->steps - 1 - goals->step;
	if (!od_Goals_CarryRest(sim) || (back <= 0 && !goals->placed))
	{
		return;
	}
	if (back <= 0)
	{
		od_Goals_EndCall(sim);
		return;
	}
	double t = sim->def.dt * back;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Vec3 spin = od_Scale(-t, od_V3Load(goals->spin + 3 * i));
		od_Mat3 screw = od_ScrewMatrix(spin);
		od_V3Store(goals->x + 3 * i, od_MulAdd(od_V3Load(goals->frameX + 3 * i), -t,
											   od_M3MulV(&screw, od_V3Load(goals->velocity + 3 * i))));
		od_Mat3 turn = od_M3ExpSkew(spin), frame = od_M3Load(goals->frameR + 9 * i);
		od_Mat3 r = od_M3Mul(&turn, &frame);
		od_M3Store(goals->R + 9 * i, &r);
	}
	goals->placed = true;
	od_UpdateTerms(sim);
}

od_Vec3 od_Goals_StepVelocity(const od_Sim* sim, int i)
{
	const od_Goals* goals = &sim->goals;
	int back = goals->steps - 1 - goals->step;
	double h = sim->def.dt;
	od_Vec3 spin = od_V3Load(goals->spin + 3 * i);
	od_Mat3 screw = od_ScrewMatrix(od_Scale(-h, spin)), turn = od_M3ExpSkew(od_Scale(-h * (back > 0 ? back : 0), spin));
	od_Mat3 both = od_M3Mul(&turn, &screw);
	return od_M3MulV(&both, od_V3Load(goals->velocity + 3 * i));
}

void od_Goals_BeginCall(od_Sim* sim, int steps)
{
	od_Goals* goals = &sim->goals;
	bool moving = od_Goals_CarryRest(sim) && goals->framed && goals->mark == sim->counters.steps;
	goals->step = 0;
	goals->steps = moving ? steps : 0;
}

void od_Goals_EndCall(od_Sim* sim)
{
	od_Goals* goals = &sim->goals;
	if (!goals->placed)
	{
		return;
	}
	memcpy(goals->x, goals->frameX, sizeof(double) * 3 * (size_t)sim->graph->n);
	memcpy(goals->R, goals->frameR, sizeof(double) * 9 * (size_t)sim->graph->n);
	goals->placed = false;
	od_UpdateTerms(sim);
}

double od_Goals_Diagonal(const od_Sim* sim, int i)
{
	return sim->goals.omega2 ? sim->def.density * sim->graph->volumes[i] * sim->goals.omega2[i] : 0.0;
}

od_Vec3 od_Goals_RhsRow(const od_Sim* sim, int i, bool residual)
{
	od_Vec3 g = od_V3Load(sim->goals.x + 3 * i);
	if (residual)
	{
		g = od_Sub(g, od_V3Load(sim->state.x + 3 * i));
	}
	return od_Scale(od_Goals_Diagonal(sim, i), g);
}

void od_Goals_AddLocal(const od_Sim* sim, int i, double c[9])
{
	const double* t = sim->goals.term + 9 * i;
	for (int k = 0; k < 9; ++k)
	{
		c[k] += t[k];
	}
}

bool od_Goals_Hold(const od_Sim* sim, int i)
{
	return sim->goals.omega2 && sim->goals.omega2[i] > 0.0;
}

double od_Goals_Energy(const od_Sim* sim)
{
	const od_Goals* goals = &sim->goals;
	const od_Graph* g = sim->graph;
	double e = 0.0;
	for (int i = 0; goals->omega2 && i < g->n; ++i)
	{
		od_Mat3 r = od_M3Load(sim->state.R + 9 * i), gr = od_M3Load(goals->R + 9 * i), a = od_M3Load(g->moments + 9 * i);
		od_M3AddScaled(&r, -1.0, &gr);
		od_Mat3 da = od_M3Mul(&r, &a);
		od_Vec3 d = od_Sub(od_V3Load(sim->state.x + 3 * i), od_V3Load(goals->x + 3 * i));
		e += goals->omega2[i] * (od_M3Inner(&da, &r) + g->volumes[i] * od_Dot(d, d));
	}
	return 0.5 * sim->def.density * e;
}

od_Status od_Sim_SetGoalRest(od_Sim* sim, bool enabled)
{
	od_Goals* goals = &sim->goals;
	if (enabled == goals->carryRest)
	{
		return OD_OK;
	}
	goals->carryRest = enabled;
	sim->edgeStiffness = 0.0; // the edges' terms are made again, from the goal shape or the rest shape
	if (!enabled)
	{
		od_FreeMotion(goals);
		return OD_OK;
	}
	od_Status status = od_AllocateMotion(sim);
	goals->carryRest = status == OD_OK;
	return status;
}

bool od_Sim_GetGoalRest(const od_Sim* sim)
{
	return sim->goals.carryRest;
}

od_Status od_Sim_GetGoalMotion(const od_Sim* sim, double* velocities, double* angularVelocities, int* steps)
{
	const od_Goals* goals = &sim->goals;
	if (!od_Goals_CarryRest(sim))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "goal motion: the goals do not carry the rest (or there are none)");
	}
	size_t bytes = sizeof(double) * 3 * (size_t)sim->graph->n;
	memcpy(velocities, goals->velocity, bytes);
	memcpy(angularVelocities, goals->spin, bytes);
	long long since = sim->counters.steps - goals->mark;
	*steps = !goals->framed ? -1 : (int)(since < INT_MAX ? since : INT_MAX);
	return OD_OK;
}

od_Status od_Sim_RestoreGoalMotion(od_Sim* sim, const double* velocities, const double* angularVelocities, int steps)
{
	od_Goals* goals = &sim->goals;
	int n = sim->graph->n;
	if (!od_Goals_CarryRest(sim))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "goal motion: the goals do not carry the rest (or there are none)");
	}
	if (!velocities || !angularVelocities || steps < -1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "goal motion: velocities, angular velocities and steps >= -1 are required");
	}
	od_Status status = od_CheckFinite("goal velocities", velocities, 3 * n);
	if (status == OD_OK)
	{
		status = od_CheckFinite("goal angular velocities", angularVelocities, 3 * n);
	}
	if (status != OD_OK)
	{
		return status;
	}
	memcpy(goals->velocity, velocities, sizeof(double) * 3 * (size_t)n);
	memcpy(goals->spin, angularVelocities, sizeof(double) * 3 * (size_t)n);
	goals->framed = steps >= 0;
	goals->mark = sim->counters.steps - steps;
	return OD_OK;
}

void od_Goals_EdgeRest(const od_Sim* sim, int i, int j, od_Vec3* arm, od_Mat3* turn)
{
	const od_Goals* goals = &sim->goals;
	od_Mat3 gi = od_M3Load(goals->R + 9 * i), gj = od_M3Load(goals->R + 9 * j);
	*arm = od_M3MulTV(&gi, od_Sub(od_V3Load(goals->x + 3 * j), od_V3Load(goals->x + 3 * i)));
	*turn = od_M3MulTN(&gj, &gi);
}

void od_Goals_PrepareEdge(const od_Sim* sim, int i, int e, double si, double sj, od_Mat3* moment, od_Vec3* arm)
{
	const od_Graph* g = sim->graph;
	int j = g->adj[e];
	od_Mat3 q, ai = od_M3Load(g->moments + 9 * i), aj = od_M3Load(g->moments + 9 * j);
	od_Goals_EdgeRest(sim, i, j, arm, &q);
	od_M3Store(sim->goals.edgeTurn + 9 * e, &q);
	od_Mat3 left = od_M3Mul(&aj, &q), right = od_M3Mul(&q, &ai);
	*moment = od_M3Zero();
	od_M3AddScaled(moment, sj, &left);
	od_M3AddScaled(moment, si, &right);
	od_Mat3 gj = od_M3Load(sim->goals.R + 9 * j);
	od_Vec3 back = od_Scale(-1.0, *arm); // g_i - g_j in i's goal frame, exactly
	od_V3Store(sim->goals.edgeRest + 6 * e, back);
	od_V3Store(sim->goals.edgeRest + 6 * e + 3,
			   od_M3MulTV(&gj, od_Sub(od_V3Load(sim->goals.x + 3 * i), od_V3Load(sim->goals.x + 3 * j))));
}
