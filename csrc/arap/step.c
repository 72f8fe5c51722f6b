// The stages of a step (step.h) and the iteration they run: Begin takes a simulation for a call and keeps
// its state, Start predicts, Advance runs the global solve and then the local/global pairs, Finish applies the
// floor, the colliders and the velocities, End gives the simulation back. od_Sim_Step (simulation.c) runs
// them for one simulation, od_ContactGroup_Step (contact_group.c, body_contact.c) for several side by side;
// od_Sim_SolveStatic runs the same iteration without the prediction.
//
// Starting with the global solve matters: starting with a local step makes pinned particles rotate to
// absorb the h²g offset of the prediction and the truncated iteration settles elsewhere (measured fact 2),
// which is what makes the stiffness depend on h and the iteration count.
// A call that produces a non-finite state restores the state it started from and fails.
#include "step.h"

#include "constraints.h"
#include "contact.h"
#include "core.h"
#include "energy.h"
#include "floor.h"
#include "global_solve.h"
#include "goal.h"
#include "interrupt.h"
#include "local_step.h"
#include "math3.h"
#include "polar.h"
#include "position_constraints.h"
#include "scene_colliders.h"
#include "stretch_bound.h"
#include "surface_contact.h"
#include "tolerance.h"

#include <math.h>
#include <stdatomic.h>
#include <string.h>

static void od_CopyState(od_State* dst, const od_State* src, int n)
{
	memcpy(dst->x, src->x, sizeof(double) * 3 * n);
	memcpy(dst->R, src->R, sizeof(double) * 9 * n);
	memcpy(dst->v, src->v, sizeof(double) * 3 * n);
	memcpy(dst->omega, src->omega, sizeof(double) * 3 * n);
}

static void od_Trace(od_Sim* sim)
{
	if (!sim->traceEnabled)
	{
		return;
	}
	if (sim->traceCount == sim->traceCapacity)
	{
		int cap = sim->traceCapacity ? 2 * sim->traceCapacity : 64;
		double* t = od_Realloc(sim->trace, sizeof(double) * cap);
		if (!t)
		{
			return; // tracing is diagnostic: drop the sample rather than fail the step
		}
		sim->trace = t;
		sim->traceCapacity = cap;
	}
	sim->trace[sim->traceCount++] = od_Energy(sim);
}

static bool od_StateIsFinite(const od_State* s, int n)
{
	double sum = 0.0;
	for (int k = 0; k < 3 * n; ++k)
	{
		sum += s->x[k] * 0.0 + s->v[k] * 0.0 + s->omega[k] * 0.0;
	}
	for (int k = 0; k < 9 * n; ++k)
	{
		sum += s->R[k] * 0.0;
	}
	return sum == 0.0; // any NaN or infinity makes the sum NaN
}

// With an accelerator the iteration is seen as a fixed-point map on the rotations, R -> local(global(R)),
// with the objective Ê(R) = E(global(R), R). The slow modes of a long chain (bending) are smooth fields of
// rotation angles, which extrapolate well; extrapolating the centres alone with stale rotations does not.
// Each iteration takes the plain iterate g = local(x_k) (x_k = global(R_k)), forms the accelerated R_acc,
// projects each particle's matrix to the nearest rotation, solves its centres and keeps it when its
// objective is below the last accepted one (Peng et al. 2018); otherwise it goes back to g and restarts the
// history. The objective never rises from one accepted iterate to the next; the trace holds those.
static od_Status od_AcceleratedIteration(od_Sim* sim, double* accepted)
{
	int n = sim->graph->n;
	double* rot = sim->state.R;
	memcpy(sim->RInput, rot, sizeof(double) * 9 * n);
	od_LocalStep(sim);
	memcpy(sim->RPlain, rot, sizeof(double) * 9 * n);
	od_Accelerator_Apply(&sim->accelerator, sim->RInput, sim->RPlain);
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 a = od_M3Load(sim->RInput + 9 * i), r = od_M3Load(sim->RPlain + 9 * i);
		sim->counters.polarFallbacks += od_PolarRotationWarm(&a, &r);
		od_Orthonormalize(&r);
		od_M3Store(rot + 9 * i, &r);
	}
	od_Status status = od_GlobalStep(sim);
	double energy = status == OD_OK ? od_Energy(sim) : *accepted;
	if (status == OD_OK && energy < *accepted)
	{
		sim->counters.accelerated++;
		*accepted = energy;
		return OD_OK;
	}
	sim->counters.rejected++;
	memcpy(rot, sim->RPlain, sizeof(double) * 9 * n);
	status = od_GlobalStep(sim);
	*accepted = od_Energy(sim);
	od_Accelerator_Restart(&sim->accelerator);
	return status;
}

static od_Status od_PlainIteration(od_Sim* sim)
{
	od_LocalStep(sim);
	od_Trace(sim);
	return od_GlobalStep(sim);
}

// Records a dynamic step's iterations and estimated error (-1: none, no tolerance) in the call's report.
static void od_Report(od_Sim* sim, int iterations, double error)
{
	od_StepReport* r = &sim->report;
	r->steps++;
	r->iterations += iterations;
	r->mostIterations = iterations > r->mostIterations ? iterations : r->mostIterations;
	r->error = fmax(r->error, error);
	r->unconverged += error > sim->solverDef.tolerance;
}

// The shared iteration, in stages so that a contact group can act between the iterations of its members
// (contact_group.c, body_contact.c): a global solve with the current rotations (od_IterateStart), then
// local/global pairs (od_IterateNext): `iterations` of them, or under a tolerance (dynamic steps only) until
// the plan's error estimate is at most the tolerance, at most maxIterations; the last one records the step
// (od_Report). The plan (tolerance.c) says whether the pairs are accelerated; the auto accelerator's plan may
// turn acceleration on during a step.
static od_Status od_IterateStart(od_Sim* sim, int iterations)
{
	od_Iteration* r = &sim->iteration;
	sim->traceCount = 0;
	od_Status status = od_GlobalStep(sim);
	od_Trace(sim);
	*r = (od_Iteration){ .limit = iterations, .error = -1.0, .plan = od_Tolerance_Plan(sim) };
	if (r->plan.accelerate && status == OD_OK)
	{
		od_Accelerator_Restart(&sim->accelerator);
		r->accepted = od_Energy(sim);
	}
	if (r->plan.tolerance > 0.0)
	{
		od_Tolerance_Start(sim);
		r->limit = sim->solverDef.maxIterations;
	}
	r->finished = status != OD_OK || r->limit <= 0;
	return status;
}

// The forces of contact are held from now on: the step's plan starts again from the current iterate.
static void od_RestartPlan(od_Sim* sim)
{
	od_Iteration* r = &sim->iteration;
	r->plan = od_Tolerance_Plan(sim);
	if (r->plan.accelerate)
	{
		od_Accelerator_Restart(&sim->accelerator);
		r->accepted = od_Energy(sim);
	}
	od_Tolerance_Start(sim);
}

static od_Status od_IterateNext(od_Sim* sim)
{
	od_Iteration* r = &sim->iteration;
	bool accelerated = r->plan.accelerate;
	od_Status status = accelerated ? od_AcceleratedIteration(sim, &r->accepted) : od_PlainIteration(sim);
	od_Trace(sim);
	status = status == OD_OK ? od_CheckInterrupt() : status;
	++r->done;
	if (r->plan.tolerance > 0.0 && (r->error = od_Tolerance_Check(sim, &r->plan)) <= r->plan.tolerance)
	{
		r->finished = true;
	}
	else if (r->plan.accelerate && !accelerated && status == OD_OK)
	{
		r->accepted = od_Energy(sim); // auto turned Chebyshev on; od_Tolerance_Check seeded its history
	}
	r->finished = r->finished || status != OD_OK || r->done >= r->limit;
	return status;
}

static void od_IterateEnd(od_Sim* sim)
{
	if (sim->mode == OD_DYNAMIC)
	{
		od_Report(sim, sim->iteration.done, sim->iteration.error);
	}
}

static od_Status od_Iterate(od_Sim* sim, int iterations)
{
	od_Status status = od_IterateStart(sim, iterations);
	while (!sim->iteration.finished && status == OD_OK)
	{
		status = od_IterateNext(sim);
	}
	od_IterateEnd(sim);
	return status;
}

// The most a step's turn counts toward a particle's angular velocity: a quarter turn. A turn near a half turn is
// aliased (its velocity, pi / h, predicts another half turn at the next step, back where it started): gob at
// 1,000 particles (docs/goals.md), whose armature folds its chest's skin at frame 40 so that four goal fits turn
// 113-178 degrees in a frame, had a particle turn 178 degrees in a step and the body fly apart (4e7 m within three
// steps, tests/test_goal_rest.py). Only what turns faster than a quarter turn a step loses speed; energy is never
// added.
#define OD_MAX_TURN 1.5707963267948966

static void od_UpdateVelocities(od_Sim* sim, const od_State* before)
{
	od_State* s = &sim->state;
	double invH = 1.0 / sim->def.dt;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_V3Store(s->v + 3 * i, od_Scale(invH, od_Sub(od_V3Load(s->x + 3 * i), od_V3Load(before->x + 3 * i))));
		od_Mat3 r = od_M3Load(s->R + 9 * i), r0 = od_M3Load(before->R + 9 * i);
		od_Orthonormalize(&r);
		od_M3Store(s->R + 9 * i, &r);
		od_Mat3 dr = od_M3MulNT(&r, &r0);
		od_Vec3 turn = od_M3LogRotation(&dr);
		double angle = od_Length(turn);
		if (angle > OD_MAX_TURN)
		{
			turn = od_Scale(OD_MAX_TURN / angle, turn);
		}
		od_Vec3 w = od_Scale(invH, turn);
		if (sim->hasFloor || sim->colliders.count)
		{
			w = od_Scale(sim->angularScale[i], w);
		}
		od_V3Store(s->omega + 3 * i, w);
	}
}

// Swaps the prediction's buffers with the kept ones: at the start of a call (a call predicts before it reads
// them) the objective before the call is kept; a failed call swaps it back (od_End).
static void od_SwapPrediction(od_Sim* sim)
{
	double* y = sim->y;
	double* rtilde = sim->Rtilde;
	double* inertia = sim->inertiaTerm;
	sim->y = sim->keptY;
	sim->Rtilde = sim->keptRtilde;
	sim->inertiaTerm = sim->keptInertiaTerm;
	sim->keptY = y;
	sim->keptRtilde = rtilde;
	sim->keptInertiaTerm = inertia;
}

static od_Status od_Begin(od_Sim* sim, od_Mode mode)
{
	if (atomic_exchange(&sim->busy, 1))
	{
		return od_Fail(OD_ERROR_BUSY, "the simulation is being used by another thread");
	}
	od_Mode previous = sim->mode;
	sim->mode = mode;
	sim->partitionDirty = sim->partitionDirty || sim->constraints.pairsDirty || sim->constraints.incidenceDirty;
	od_Status status = od_Constraints_Prepare(sim);
	if (status == OD_OK)
	{
		status = od_LocalStep_PreparePartition(sim);
	}
	if (status == OD_OK && mode == OD_STATIC)
	{
		status = od_Positions_CheckPinned(sim);
	}
	if (status != OD_OK)
	{
		sim->mode = previous;
		atomic_store(&sim->busy, 0);
		return status;
	}
	od_LocalStep_PrepareEdges(sim);
	od_CopyState(&sim->saved, &sim->state, sim->graph->n);
	od_SwapPrediction(sim);
	sim->keptPredictionValid = sim->predictionValid;
	sim->keptMode = previous;
	sim->keptSteps = sim->counters.steps;
	return OD_OK;
}

static od_Status od_End(od_Sim* sim, od_Status status)
{
	if (status == OD_OK && !od_StateIsFinite(&sim->state, sim->graph->n))
	{
		status = od_Fail(OD_ERROR_NOT_FINITE, "the solve produced a non-finite state; the previous state was kept");
	}
	if (status != OD_OK)
	{
		od_CopyState(&sim->state, &sim->saved, sim->graph->n);
		od_SwapPrediction(sim);
		sim->predictionValid = sim->keptPredictionValid;
		sim->mode = sim->keptMode;
		sim->counters.steps = sim->keptSteps;
	}
	atomic_store(&sim->busy, 0);
	return status;
}

od_Status od_Step_Begin(od_Sim* sim, int steps)
{
	od_Status status = od_Begin(sim, OD_DYNAMIC);
	if (status == OD_OK)
	{
		od_StretchBound(sim, steps * sim->def.dt);
		od_LocalStep_PrepareEdges(sim);
	}
	status = status == OD_OK ? od_SurfaceContact_Reserve(sim) : status;
	if (status == OD_ERROR_MEMORY)
	{
		return od_End(sim, status);
	}
	if (status == OD_OK)
	{
		sim->report = (od_StepReport){ .error = -1.0 };
		od_SurfaceContact_BeginCall(sim, steps);
		od_Colliders_BeginCall(sim, steps);
		od_Goals_BeginCall(sim, steps);
	}
	return status;
}

void od_Step_Start(od_Sim* sim, bool chooseStart)
{
	int n = sim->graph->n;
	memcpy(sim->previous.x, sim->state.x, sizeof(double) * 3 * n);
	memcpy(sim->previous.R, sim->state.R, sizeof(double) * 9 * n);
	od_Goals_Place(sim);
	od_Predict(sim);
	// Near the floor or a collider a step starts from the previous rotations, as a group's with forces: the
	// start chosen by global solves without the contact forces turned a 0.3 m cube sliding down a 30-degree
	// ramp 8.8 degrees about the ramp's normal in 2 s at 240 Hz, frictionless (0.75 from the previous ones).
	// Goals carrying the rest take the predicted rotations there too (od_Tolerance_ChooseStart: untested, no
	// global solve): a character's feet stand on the floor, and from the previous rotations a loose shell's
	// swing about its links (held only by its soft terms) advanced one pair's worth a step: the dog of
	// docs/goals.md, 1,000 particles, crept back onto its rig one pair a step (1.7 mm off 1 s after the motion,
	// 0.13 mm without the floor), or with fewer tail particles cycled under Chebyshev (13.7 mm).
	bool touching = od_SurfaceContact_Start(sim);
	if (chooseStart && sim->solverDef.tolerance > 0.0 && (!touching || od_Goals_CarryRest(sim)))
	{
		od_Tolerance_ChooseStart(sim);
	}
	sim->iteration = (od_Iteration){ .started = false };
}

od_Status od_Step_Advance(od_Sim* sim, bool* more)
{
	od_Status status;
	bool finished = sim->iteration.started && sim->iteration.finished; // a group's extra pair: reported already
	bool first = !sim->iteration.started;
	if (first)
	{
		status = od_IterateStart(sim, sim->def.iterations);
		sim->iteration.started = true;
	}
	else
	{
		status = od_IterateNext(sim);
	}
	*more = !sim->iteration.finished;
	// Contact with the floor and the colliders for the next solve (surface_contact.c); while it acts, plain
	// pairs (an accelerator's extrapolation and energy test would see the forces change, as a group's); once
	// they are held (under a tolerance) the plan starts again.
	od_SurfaceUpdate forces = status == OD_OK && *more ? od_SurfaceContact_Update(sim, sim->iteration.plan.tolerance > 0.0) : OD_SURFACE_NONE;
	if (forces == OD_SURFACE_MOVED && first)
	{
		od_Tolerance_PlainPlan(&sim->iteration.plan);
	}
	else if (forces == OD_SURFACE_HELD)
	{
		od_RestartPlan(sim);
	}
	if (!*more && !finished)
	{
		od_IterateEnd(sim);
	}
	return status;
}

od_Status od_Step_Solve(od_Sim* sim)
{
	od_Step_Start(sim, true);
	bool more = true;
	od_Status status = OD_OK;
	while (more && status == OD_OK)
	{
		status = od_Step_Advance(sim, &more);
	}
	return status;
}

void od_Step_Finish(od_Sim* sim, int k, int steps)
{
	od_SurfaceContact_Finish(sim);
	od_SurfaceContact_Turn(sim);
	double* lifted = od_SurfaceContact_Lifts(sim);
	if (sim->hasFloor)
	{
		od_FloorStep(sim, &sim->previous, sim->angularScale, lifted);
	}
	if (sim->colliders.count)
	{
		od_ContactStep(sim, &sim->previous, (double)k / steps, (double)(k + 1) / steps, lifted);
	}
	od_SurfaceContact_Roll(sim);
	od_SurfaceContact_GroupRoll(sim, lifted);
	od_UpdateVelocities(sim, &sim->previous);
	sim->counters.steps++;
	sim->goals.step++;
}

od_Status od_Step_End(od_Sim* sim, od_Status status)
{
	od_Goals_EndCall(sim);
	status = od_End(sim, status);
	od_Colliders_EndCall(sim, status == OD_OK);
	od_SurfaceContact_EndCall(sim, status == OD_OK);
	return status;
}

od_Status od_Sim_SolveStatic(od_Sim* sim, int iterations)
{
	if (iterations < 0)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "iterations = %d must be >= 0", iterations);
	}
	od_Status status = od_Begin(sim, OD_STATIC);
	if (status != OD_OK)
	{
		return status;
	}
	od_StretchBound_Lower(sim); // a static pose does not depend on the last call's raise
	od_LocalStep_PrepareEdges(sim);
	status = od_Iterate(sim, iterations);
	if (status == OD_OK)
	{
		for (int i = 0; i < sim->graph->n; ++i)
		{
			od_Mat3 r = od_M3Load(sim->state.R + 9 * i);
			od_Orthonormalize(&r);
			od_M3Store(sim->state.R + 9 * i, &r);
		}
		memset(sim->state.v, 0, sizeof(double) * 3 * sim->graph->n);
		memset(sim->state.omega, 0, sizeof(double) * 3 * sim->graph->n);
	}
	return od_End(sim, status);
}
