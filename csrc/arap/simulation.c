// The simulation driver: creation, parameters, state, and the order of the stages of a step.
//
// A dynamic step (METHOD.md):
//   predict y, R̃ from (x, v, R, ω) -> global solve with the previous rotations -> `iterations` pairs of
//   (local Gauss-Seidel rotations, global solve) -> particle pairs (body_contact.c: self-contact, a
//   group's bodies) -> floor -> colliders (contact.c) -> v = (x - x⁽¹⁾)/h,
//   ω = log(R R⁽¹⁾ᵀ)/h.
// The stages are step.c's (step.h), so that a contact group can put the forces of its pairs on the right side
// between the solves (body_contact.c) and drive them without reaching back here: this file calls
// body_contact.c and step.c, body_contact.c calls step.c, and step.c calls neither.
#include "body_contact.h"
#include "check.h"
#include "constraints.h"
#include "core.h"
#include "energy.h"
#include "field.h"
#include "global_solve.h"
#include "goal.h"
#include "local_step.h"
#include "math3.h"
#include "polar.h"
#include "scene_colliders.h"
#include "skin_shape.h"
#include "sim.h"
#include "step.h"
#include "stretch_bound.h"
#include "surface_contact.h"
#include "tolerance.h"

#include <math.h>
#include <string.h>

#define OD_MAX_STIFFNESS 1e20 // Pa: 1e8 times diamond's Young's modulus
#define OD_MAX_DENSITY 1e8    // kg/m³: 4,000 times osmium's
#define OD_MIN_DT 1e-9        // s

od_SimDef od_DefaultSimDef(void)
{
	od_SimDef def;
	memset(&def, 0, sizeof def);
	def.stiffness = 1e6;
	def.density = 1000.0;
	def.dt = 1.0 / 60.0;
	def.iterations = 10;
	def.gravity[2] = -9.81;
	def.damping = 0.0;
	def.skinNeighbors = 4;
	return def;
}

od_SolverDef od_DefaultSolverDef(void)
{
	od_SolverDef def;
	memset(&def, 0, sizeof def);
	def.accelerator = OD_ACCELERATE_NONE;
	def.window = 5;
	def.rho = 0.999;
	def.threads = 1;
	def.maxIterations = 100;
	return def;
}

static od_Status od_CheckSolverDef(const od_SolverDef* def)
{
	if (def->accelerator < OD_ACCELERATE_NONE || def->accelerator > OD_ACCELERATE_AUTO)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "accelerator = %d is not one of none, anderson, chebyshev, auto",
					   (int)def->accelerator);
	}
	if (def->window < 1 || def->window > 16)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "window = %d must be in [1, 16]", def->window);
	}
	if (!(def->rho > 0.0 && def->rho < 1.0))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "rho = %g must be in (0, 1)", def->rho);
	}
	if (def->factorization < 0 || def->factorization > 2)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "factorization = %d must be 0 (auto), 1 (simplicial) or 2 (supernodal)",
					   def->factorization);
	}
	od_Status status = od_Pool_CheckThreads(def->threads);
	if (status != OD_OK)
	{
		return status;
	}
	if (!(def->tolerance >= 0.0) || !isfinite(def->tolerance))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "tolerance = %g must be finite and >= 0", def->tolerance);
	}
	if (def->maxIterations < 1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "max_iterations = %d must be >= 1", def->maxIterations);
	}
	return OD_OK;
}

od_Status od_Sim_SetSolver(od_Sim* sim, const od_SolverDef* def)
{
	od_Status status = od_CheckSolverDef(def);
	if (status != OD_OK)
	{
		return status;
	}
	int n3 = 3 * sim->graph->n;
	if (def->accelerator != OD_ACCELERATE_NONE && !sim->RInput)
	{
		sim->RInput = od_Alloc(sizeof(double) * 3 * n3);
		sim->RPlain = od_Alloc(sizeof(double) * 3 * n3);
		if (!sim->RInput || !sim->RPlain)
		{
			return od_Fail(OD_ERROR_MEMORY, "out of memory for the accelerator");
		}
	}
	od_AcceleratorKind kind = def->accelerator == OD_ACCELERATE_AUTO ? OD_ACCELERATE_CHEBYSHEV : def->accelerator;
	status = od_Accelerator_Reset(&sim->accelerator, kind, 3 * n3, def->window, def->rho);
	if (status == OD_OK && def->tolerance > 0.0)
	{
		status = od_Tolerance_Prepare(sim);
	}
	if (status != OD_OK)
	{
		return status;
	}
	od_Pool* pool = NULL;
	if (def->threads != 1)
	{
		status = od_Pool_Create(def->threads, &pool);
		if (status != OD_OK)
		{
			return status;
		}
		if (od_Pool_Threads(pool) == 1)
		{
			od_Pool_Destroy(pool);
			pool = NULL;
		}
	}
	od_Pool_Destroy(sim->pool);
	sim->pool = pool;
	sim->partitionDirty = true;
	sim->solverDef = *def;
	return OD_OK;
}

od_SolverDef od_Sim_GetSolver(const od_Sim* sim)
{
	return sim->solverDef;
}

static od_Status od_CheckDef(const od_SimDef* def)
{
	// Bounds of what a step represents (issue 28): beyond them every step failed (stiffness 1e300, density 1e308:
	// the matrix or the energy overflows; dt 1e-300: the mass term m/h² does). The Fig. 1 bar steps at each
	// bound with the others anywhere in stiffness [1e15, 1e22], density [1e-3, 1e8], dt [1e-9, 1] s.
	if (!(def->stiffness > 0.0 && def->stiffness <= OD_MAX_STIFFNESS))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "stiffness = %g must be in (0, %g]", def->stiffness, OD_MAX_STIFFNESS);
	}
	if (!(def->density > 0.0 && def->density <= OD_MAX_DENSITY))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "density = %g must be in (0, %g]", def->density, OD_MAX_DENSITY);
	}
	if (!(def->dt >= OD_MIN_DT) || !isfinite(def->dt))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "dt = %g must be finite and >= %g", def->dt, OD_MIN_DT);
	}
	if (def->iterations < 1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "iterations = %d must be >= 1", def->iterations);
	}
	if (!od_IsFinite3(def->gravity))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "gravity must be three finite numbers");
	}
	if (!(def->damping >= 0.0 && def->damping <= 1.0))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "damping = %g must be in [0, 1]", def->damping);
	}
	if (def->skinNeighbors < 1 || def->skinNeighbors > OD_MAX_SKIN)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "skin_neighbors = %d must be in [1, %d]", def->skinNeighbors, OD_MAX_SKIN);
	}
	return OD_OK;
}

static od_Status od_AllocState(od_State* s, int n)
{
	s->x = od_Alloc(sizeof(double) * 3 * n);
	s->R = od_Alloc(sizeof(double) * 9 * n);
	s->v = od_AllocZero((size_t)3 * n, sizeof(double));
	s->omega = od_AllocZero((size_t)3 * n, sizeof(double));
	if (!s->x || !s->R || !s->v || !s->omega)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the state of %d particles", n);
	}
	return OD_OK;
}

static void od_FreeState(od_State* s)
{
	od_Free(s->x);
	od_Free(s->R);
	od_Free(s->v);
	od_Free(s->omega);
}

od_Status od_Sim_Create(const od_Graph* graph, const od_SimDef* def, od_Sim** out)
{
	*out = NULL;
	if (!graph)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "graph is required");
	}
	od_Status status = od_CheckDef(def);
	if (status != OD_OK)
	{
		return status;
	}
	int n = graph->n;
	od_Sim* sim = od_AllocZero(1, sizeof *sim);
	if (!sim)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory creating a simulation");
	}
	sim->graph = graph;
	sim->def = *def;
	sim->constraints.pairsDirty = sim->constraints.incidenceDirty = sim->constraints.targetsDirty = true;
	sim->solverDef = od_DefaultSolverDef();
	sim->partitionDirty = true;
	status = od_AllocState(&sim->state, n);
	if (status == OD_OK)
	{
		status = od_AllocState(&sim->saved, n);
	}
	if (status == OD_OK)
	{
		status = od_AllocState(&sim->previous, n);
	}
	if (status == OD_OK)
	{
		sim->y = od_Alloc(sizeof(double) * 3 * n);
		sim->Rtilde = od_Alloc(sizeof(double) * 9 * n);
		sim->inertiaTerm = od_Alloc(sizeof(double) * 9 * n);
		sim->keptY = od_Alloc(sizeof(double) * 3 * n);
		sim->keptRtilde = od_Alloc(sizeof(double) * 9 * n);
		sim->keptInertiaTerm = od_Alloc(sizeof(double) * 9 * n);
		sim->angularScale = od_Alloc(sizeof(double) * n);
		sim->edgeMoment = od_Alloc(sizeof(double) * 18 * graph->edgeCount);
		sim->edgeArm = od_Alloc(sizeof(double) * 6 * graph->edgeCount);
		sim->rowArm = od_Alloc(sizeof(double) * 3 * n);
		status = sim->y && sim->Rtilde && sim->inertiaTerm && sim->keptY && sim->keptRtilde && sim->keptInertiaTerm &&
						 sim->angularScale && sim->edgeMoment && sim->edgeArm &&
						 sim->rowArm
					 ? OD_OK
					 : od_Fail(OD_ERROR_MEMORY, "out of memory for a simulation of %d particles", n);
	}
	for (int m = 0; m < 2 && status == OD_OK; ++m)
	{
		status = od_GlobalSolver_Create(&sim->solver[m]);
	}
	if (status != OD_OK)
	{
		od_Sim_Destroy(sim);
		return status;
	}
	memcpy(sim->state.x, graph->centers, sizeof(double) * 3 * n);
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 eye = od_M3Identity();
		od_M3Store(sim->state.R + 9 * i, &eye);
	}
	*out = sim;
	return OD_OK;
}

void od_Sim_Destroy(od_Sim* sim)
{
	if (!sim)
	{
		return;
	}
	od_FreeState(&sim->state);
	od_FreeState(&sim->saved);
	od_FreeState(&sim->previous);
	od_Free(sim->y);
	od_Free(sim->Rtilde);
	od_Free(sim->inertiaTerm);
	od_Free(sim->keptY);
	od_Free(sim->keptRtilde);
	od_Free(sim->keptInertiaTerm);
	od_Free(sim->angularScale);
	od_Free(sim->damping);
	od_Free(sim->contactForce);
	od_SurfaceContact_Destroy(&sim->surface);
	od_Free(sim->edgeMoment);
	od_Free(sim->edgeArm);
	od_Free(sim->rowArm);
	od_Free(sim->stiffnessScale);
	od_Free(sim->elasticVolumes);
	od_Free(sim->linkSoftness);
	od_Free(sim->linkWeight);
	od_Free(sim->linkRaised);
	od_Free(sim->skinGradient);
	od_Free(sim->trace);
	od_Constraints_Destroy(&sim->constraints);
	od_Colliders_Destroy(&sim->colliders);
	od_SkinShape_Destroy(&sim->skinShape);
	od_FieldSet_Destroy(&sim->fields);
	od_PairScratch_Destroy(&sim->selfPairs);
	od_Goals_Destroy(&sim->goals);
	od_Accelerator_Destroy(&sim->accelerator);
	od_Tolerance_Destroy(&sim->tolerance);
	od_Pool_Destroy(sim->pool);
	od_Free(sim->RInput);
	od_Free(sim->RPlain);
	od_Free(sim->sweepStart);
	od_Free(sim->sweepOrder);
	od_Free(sim->sweepBatch);
	od_GlobalSolver_Destroy(sim->solver[0]);
	od_GlobalSolver_Destroy(sim->solver[1]);
	od_Free(sim);
}

od_SimDef od_Sim_GetDef(const od_Sim* sim)
{
	return sim->def;
}

od_Status od_Sim_SetDef(od_Sim* sim, const od_SimDef* def)
{
	od_Status status = od_CheckDef(def);
	if (status != OD_OK)
	{
		return status;
	}
	bool reskin = def->skinNeighbors != sim->def.skinNeighbors;
	sim->def = *def; // the global solver notices a change of k, ρ or h itself (global_solve.c)
	if (reskin)
	{
		od_Constraints_Reskin(sim);
	}
	sim->predictionValid = false;
	return OD_OK;
}

// s_i v_i of every particle, the right side's weights (od_ElasticVolumes).
static void od_FillElasticVolumes(od_Sim* sim)
{
	for (int i = 0; i < sim->graph->n; ++i)
	{
		sim->elasticVolumes[i] = sim->stiffnessScale[i] * sim->graph->volumes[i];
	}
}

// w_ij = min(r_i, r_j) of every directed edge (od_LinkWeight), and the stretch bound's raised softness as set.
static void od_FillLinkWeights(od_Sim* sim)
{
	if (sim->linkRaised)
	{
		memcpy(sim->linkRaised, sim->linkSoftness, sizeof(double) * (size_t)sim->graph->n);
	}
	od_MakeLinkWeights(sim, sim->linkSoftness);
}

// Keeps n checked values per particle (the scale or the link softness) in *kept and the `count` weights fill
// makes of them in *made; NULL frees both. Both enter the global matrix and the edges' terms: a change refactors
// once, the same values keep the factor.
static od_Status od_SetElasticWeights(od_Sim* sim, const double* values, double** kept, double** made, size_t count,
									  void (*fill)(od_Sim*), const char* what)
{
	size_t n = (size_t)sim->graph->n;
	if (values ? *kept && !memcmp(values, *kept, sizeof(double) * n) : !*kept)
	{
		return OD_OK; // unchanged: keep the factor
	}
	if (values && !*kept)
	{
		*kept = od_Alloc(sizeof(double) * n);
		*made = od_Alloc(sizeof(double) * count);
	}
	if (values && *kept && *made)
	{
		memcpy(*kept, values, sizeof(double) * n);
		fill(sim);
	}
	else
	{
		od_Free(*kept);
		od_Free(*made);
		*kept = *made = NULL;
	}
	sim->stiffnessVersion++;
	sim->edgeStiffness = 0.0; // the edges' terms are made again (local_step.c)
	return values && !*kept ? od_Fail(OD_ERROR_MEMORY, "out of memory for the %s of %zu particles", what, n) : OD_OK;
}

od_Status od_Sim_SetStiffnessScale(od_Sim* sim, const double* scale)
{
	int n = sim->graph->n;
	for (int i = 0; scale && i < n; ++i)
	{
		if (!(scale[i] > 0.0) || !isfinite(scale[i]))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "stiffness scale[%d] = %g must be finite and > 0", i, scale[i]);
		}
	}
	return od_SetElasticWeights(sim, scale, &sim->stiffnessScale, &sim->elasticVolumes, (size_t)n,
								od_FillElasticVolumes, "stiffness scale");
}

const double* od_Sim_GetStiffnessScale(const od_Sim* sim)
{
	return sim->stiffnessScale;
}

od_Status od_Sim_SetLinkSoftness(od_Sim* sim, const double* softness)
{
	for (int i = 0; softness && i < sim->graph->n; ++i)
	{
		if (!(softness[i] > 0.0 && softness[i] <= 1.0))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "link softness[%d] = %g must be in (0, 1]", i, softness[i]);
		}
	}
	return od_SetElasticWeights(sim, softness, &sim->linkSoftness, &sim->linkWeight,
								2 * (size_t)sim->graph->edgeCount, od_FillLinkWeights, "link softness");
}

const double* od_Sim_GetLinkSoftness(const od_Sim* sim)
{
	return sim->linkSoftness;
}

// The raised softness back to the softness as set, and the bound's arrays freed.
static void od_StretchBoundOff(od_Sim* sim)
{
	od_StretchBound_Lower(sim);
	od_Free(sim->linkRaised);
	od_Free(sim->skinGradient);
	sim->linkRaised = sim->skinGradient = NULL;
	sim->stretchLimit = 0.0;
}

// Whether limit and gradient are the bound's as set (the same bits).
static bool od_SameStretchBound(const od_Sim* sim, double limit, const double* gradient)
{
	if (limit != sim->stretchLimit || !gradient != !sim->skinGradient)
	{
		return false;
	}
	return !gradient || !memcmp(gradient, sim->skinGradient, sizeof(double) * (size_t)sim->graph->edgeCount);
}

od_Status od_Sim_SetStretchLimit(od_Sim* sim, double limit, const double* gradient)
{
	int n = sim->graph->n;
	if (!(limit == 0.0 || (limit > 1.0 && isfinite(limit))))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "stretch limit = %g must be 0 (off) or finite and > 1", limit);
	}
	for (int e = 0; gradient && e < sim->graph->edgeCount; ++e)
	{
		if (!(gradient[e] >= 0.0) || !isfinite(gradient[e]))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "skin gradient[%d] = %g must be finite and >= 0", e, gradient[e]);
		}
	}
	if (od_SameStretchBound(sim, limit, gradient)) // the raise kept: setting it again refactors nothing
	{
		return OD_OK;
	}
	od_StretchBoundOff(sim);
	if (limit == 0.0)
	{
		return OD_OK;
	}
	size_t bytes = sizeof(double) * (size_t)n, links = sizeof(double) * (size_t)sim->graph->edgeCount;
	sim->linkRaised = od_Alloc(OD_STRETCH_SCRATCH * bytes); // and the bound's scratch (stretch_bound.c)
	sim->skinGradient = gradient ? od_Alloc(links) : NULL;
	if (!sim->linkRaised || (gradient && !sim->skinGradient))
	{
		od_StretchBoundOff(sim);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the stretch bound of %d particles", n);
	}
	if (sim->linkSoftness)
	{
		memcpy(sim->linkRaised, sim->linkSoftness, bytes);
	}
	if (gradient)
	{
		memcpy(sim->skinGradient, gradient, links);
	}
	sim->stretchLimit = limit;
	return OD_OK;
}

double od_Sim_GetStretchLimit(const od_Sim* sim)
{
	return sim->stretchLimit;
}

od_Status od_Sim_SetFloor(od_Sim* sim, double height, double friction)
{
	if (!isfinite(height))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "height = %g must be finite", height);
	}
	if (!(friction >= 0.0) || !isfinite(friction))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "friction = %g must be finite and >= 0", friction);
	}
	sim->hasFloor = true;
	sim->floorHeight = height;
	sim->floorFriction = friction;
	od_SurfaceContact_Forget(sim);
	return OD_OK;
}

void od_Sim_ClearFloor(od_Sim* sim)
{
	sim->hasFloor = false;
	od_SurfaceContact_Forget(sim);
}

od_FieldSet* od_Sim_GetForceFields(od_Sim* sim)
{
	return &sim->fields;
}

// SetState (rotations orthonormalised) or RestoreState (copied as they are).
static od_Status od_PutState(od_Sim* sim, const double* positions, const double* rotations, const double* velocities,
							 const double* angularVelocities, bool exact)
{
	int n = sim->graph->n;
	if (!positions || !rotations)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "positions and rotations are required");
	}
	od_Status status = od_CheckFinite("positions", positions, 3 * n);
	if (status == OD_OK)
	{
		status = od_CheckRotations("rotations", rotations, n);
	}
	if (status == OD_OK && velocities)
	{
		status = od_CheckFinite("velocities", velocities, 3 * n);
	}
	if (status == OD_OK && angularVelocities)
	{
		status = od_CheckFinite("angular_velocities", angularVelocities, 3 * n);
	}
	if (status != OD_OK)
	{
		return status;
	}
	od_State* s = &sim->state;
	memcpy(s->x, positions, sizeof(double) * 3 * n);
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 r = od_M3Load(rotations + 9 * i);
		if (!exact)
		{
			od_Orthonormalize(&r);
		}
		od_M3Store(s->R + 9 * i, &r);
	}
	if (velocities)
	{
		memcpy(s->v, velocities, sizeof(double) * 3 * n);
	}
	else
	{
		memset(s->v, 0, sizeof(double) * 3 * n);
	}
	if (angularVelocities)
	{
		memcpy(s->omega, angularVelocities, sizeof(double) * 3 * n);
	}
	else
	{
		memset(s->omega, 0, sizeof(double) * 3 * n);
	}
	sim->predictionValid = false;
	od_SurfaceContact_Forget(sim);
	return OD_OK;
}

od_Status od_Sim_SetState(od_Sim* sim, const double* positions, const double* rotations, const double* velocities,
						  const double* angularVelocities)
{
	return od_PutState(sim, positions, rotations, velocities, angularVelocities, false);
}

od_Status od_Sim_RestoreState(od_Sim* sim, const double* positions, const double* rotations, const double* velocities,
							  const double* angularVelocities)
{
	return od_PutState(sim, positions, rotations, velocities, angularVelocities, true);
}

const double* od_Sim_GetPositions(const od_Sim* sim)
{
	return sim->state.x;
}

const double* od_Sim_GetRotations(const od_Sim* sim)
{
	return sim->state.R;
}

const double* od_Sim_GetVelocities(const od_Sim* sim)
{
	return sim->state.v;
}

const double* od_Sim_GetAngularVelocities(const od_Sim* sim)
{
	return sim->state.omega;
}

od_SimCounters od_Sim_GetCounters(const od_Sim* sim)
{
	return sim->counters;
}

od_StepReport od_Sim_GetStepReport(const od_Sim* sim)
{
	return sim->report;
}

void od_Sim_SetEnergyTrace(od_Sim* sim, int enabled)
{
	sim->traceEnabled = enabled != 0;
	sim->traceCount = 0;
}

const double* od_Sim_GetEnergyTrace(const od_Sim* sim, int* count)
{
	*count = sim->traceCount;
	return sim->trace;
}

od_Status od_Sim_Step(od_Sim* sim, int steps)
{
	if (steps < 1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "steps = %d must be >= 1", steps);
	}
	od_Status status = od_Step_Begin(sim, steps);
	if (status != OD_OK)
	{
		return status;
	}
	for (int k = 0; k < steps && status == OD_OK; ++k)
	{
		status = sim->selfContact ? od_BodyContact_Step(&sim->selfPairs, &sim, 1, &sim->selfDef) : od_Step_Solve(sim);
		od_Step_Finish(sim, k, steps);
	}
	return od_Step_End(sim, status);
}

double od_Sim_GetEnergy(od_Sim* sim)
{
	od_LocalStep_PrepareEdges(sim); // goals set since the last step: the objective reads the edges' terms
	if (sim->mode == OD_DYNAMIC && !sim->predictionValid)
	{
		od_Predict(sim);
	}
	return od_Energy(sim);
}
