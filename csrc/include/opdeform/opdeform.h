// opdeform: ARAP dynamic deformation with oriented particles (Choi 2016), the public C API.
//
// The rest graph (od_Graph, opdeform/graph.h) is immutable once made and may be shared by many simulations.
// A simulation (od_Sim) holds the model that depends on its parameters and constraints (weights,
// the prefactored global matrix) and the state (centres, rotations, velocities). Arrays are row
// major doubles: positions are n*3, rotations n*9 (R[3*r + c]), the layout of numpy (n,3) and (n,3,3).
// A simulation borrows its graph: keep the graph alive until the simulation is destroyed.
// One thread at a time per simulation: od_Sim_Step and od_Sim_SolveStatic refuse a concurrent call with
// OD_ERROR_BUSY, but the other calls do not check (the Python binding refuses them all).
#pragma once

#if defined(OD_LAYER_CHECK) && !defined(OD_USES_ARAP)
#error "opdeform/opdeform.h is the arap layer's header, which this layer of csrc/ may not use (docs/architecture.md)"
#endif

#include "opdeform/fields.h"
#include "opdeform/graph.h"

#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct od_Sim od_Sim;

typedef struct od_SimDef
{
	double stiffness;   // k
	double density;     // rho
	double dt;          // h
	int iterations;     // local/global pairs after the first global solve of a step
	double gravity[3];
	double damping;     // c, per-step velocity damping in [0, 1]
	int skinNeighbors;  // m of the Sumner weights that place the constraints
} od_SimDef;

od_SimDef od_DefaultSimDef(void);
od_Status od_Sim_Create(const od_Graph* graph, const od_SimDef* def, od_Sim** sim);
void od_Sim_Destroy(od_Sim* sim);
od_SimDef od_Sim_GetDef(const od_Sim* sim);
// Changes parameters; the state is kept. The factorization is redone lazily if needed.
od_Status od_Sim_SetDef(od_Sim* sim, const od_SimDef* def);
// A stiffness per particle: particle i's ellipsoid stores s_i k instead of k (every elastic term integrated
// over it, its volume's and its moment's, METHOD.md eq. 3), n values > 0; NULL = all 1 (the same bits as
// never set). The global matrix is refactored once, on the next solve. Get: NULL when all 1.
od_Status od_Sim_SetStiffnessScale(od_Sim* sim, const double* scale);
const double* od_Sim_GetStiffnessScale(const od_Sim* sim);
// A softness per link: each link (i, j) is weighted min(r_i, r_j) on both of its halves (the term over ellipsoid
// j then weighs s_j min(r_i, r_j)), so a soft particle among stiff ones has soft links; n values in (0, 1];
// NULL = all 1 (the same bits as never set). Refactored once, on the next solve. Get: NULL when all 1.
od_Status od_Sim_SetLinkSoftness(od_Sim* sim, const double* softness);
const double* od_Sim_GetLinkSoftness(const od_Sim* sim);
// A stretch bound on the softened links (flesh stiffens as it stretches): at each dynamic call's start, a link
// that would stretch the skin past `limit` at the call's end (its ends' velocities carrying them there) by t
// (reaching 1 at 0.2 further) raises its ends' link softness r to r^(1 - t); the raise is a function of the call's
// start and its duration (a static solve uses the softness as set). A link's stretch of the skin: the gap at its middle between the skin its ends carry, times its
// `gradient` (one value >= 0 per link of the graph's edges: the most half the difference of its ends' skin
// weights changes per metre along a mesh edge), or over the link's length (gradient NULL). The link's length and
// its ends' frames: the goals' when they carry the rest, else the rest's. limit 0: off (the default); else > 1.
// With no link past the limit: the same bits as off. The limit and gradient already set again: nothing changes
// (the raise kept, nothing refactored).
od_Status od_Sim_SetStretchLimit(od_Sim* sim, double limit, const double* gradient);
double od_Sim_GetStretchLimit(const od_Sim* sim);

// Constraints on rest-space points. target == NULL means the point's current position (direction).
od_Status od_Sim_AddPositionConstraint(od_Sim* sim, const double point[3], const double* target, double weight,
									   int* id);
od_Status od_Sim_AddDirectionConstraint(od_Sim* sim, const double point[3], const double direction[3],
										const double* target, double weight, int* id);
od_Status od_Sim_SetConstraintTarget(od_Sim* sim, int id, const double target[3]);
od_Status od_Sim_SetConstraintWeight(od_Sim* sim, int id, double weight);
// The target as stored (a direction constraint's normalised), and setting it back unchanged (no
// normalisation): what a saved simulation needs to continue to the same bits.
od_Status od_Sim_GetConstraintTarget(const od_Sim* sim, int id, double target[3]);
od_Status od_Sim_RestoreConstraintTarget(od_Sim* sim, int id, const double target[3]);
od_Status od_Sim_RemoveConstraint(od_Sim* sim, int id);
int od_Sim_GetConstraintCount(const od_Sim* sim);

// Goals (Soft Body's Goal, nCloth's Input Mesh Attract): each particle is pulled toward a goal frame, its
// goal centre and rotation (an animated shape, see od_Skin_FitGoals), by a spring given as a frequency in
// Hz, so that it means the same at any size, mass and frame rate (0: free; ~1000 Hz follows the goal to
// about 1e-6 of the motion per step at 24 fps). Frequencies enter the global matrix (one refactor per
// change); new goal frames each frame change only the right side. NULL frequencies remove the goals.
od_Status od_Sim_SetGoalFrequencies(od_Sim* sim, const double* frequencies); // n values >= 0
// positions n*3; rotations n*9 proper rotations, NULL = the rest frames. Frames start at the rest frames.
od_Status od_Sim_SetGoals(od_Sim* sim, const double* positions, const double* rotations);
// Goals carrying the rest (docs/goals.md): when enabled, the elastic energy is measured against the goal shape
// (each particle's neighbours as the goal frames place them) instead of the rest shape, so that the animated
// shape is the equilibrium and only the animation's acceleration (through the inertia) moves the body off it;
// gravity still pulls. Each od_Sim_SetGoals then remakes the edges' terms (O(edges), no refactor), and the
// prediction damps only the motion relative to the goals: c_i applies to v - u and ω - Ω, u and Ω the goal
// frame's velocity and angular velocity between the last two od_Sim_SetGoals calls over the steps taken
// between them (0 until the second frame after enabling or after the goals were made). Off by default: the
// same bits as never set. It acts while goals exist (od_Sim_SetGoalFrequencies) and stays set without them.
od_Status od_Sim_SetGoalRest(od_Sim* sim, bool enabled);
bool od_Sim_GetGoalRest(const od_Sim* sim);
// The goals' motion while they carry the rest: velocities and angular velocities (n*3 each) and the steps taken
// since the last od_Sim_SetGoals (-1: none set since the motion started at 0). A saved simulation sets them back
// (after its goal frames) to continue to the same bits. OD_ERROR_ARGUMENT while the goals do not carry the rest.
od_Status od_Sim_GetGoalMotion(const od_Sim* sim, double* velocities, double* angularVelocities, int* steps);
od_Status od_Sim_RestoreGoalMotion(od_Sim* sim, const double* velocities, const double* angularVelocities, int steps);
// The floor's and colliders' normal forces a step starts from (warm start, docs/contact.md): per particle the
// force (n*3) it pressed its surface with at the last step's end and that surface (n: -1 the floor, k >= 0 the
// collider of index k in the order they were added, -2 none). Part of the state: a saved state continues to the
// same bits only with them. od_Sim_SetState and RestoreState, od_Sim_SetFloor and ClearFloor drop them,
// od_Sim_RemoveCollider those of the removed collider (the later ones renumbered); Restore sets them after those.
// Recorded under fixed iteration counts only (docs/contact.md, "Warm start and turn").
void od_Sim_GetSurfaceForces(const od_Sim* sim, double* forces, int* surfaces);
od_Status od_Sim_RestoreSurfaceForces(od_Sim* sim, const double* forces, const int* surfaces);
// A damping per particle: c_i in [0, 1] per step replaces def.damping for particle i (relative to the goals when
// they carry the rest); NULL = def.damping for all (the same bits as never set). Get: NULL when none.
od_Status od_Sim_SetParticleDamping(od_Sim* sim, const double* damping);
const double* od_Sim_GetParticleDamping(const od_Sim* sim);

od_Status od_Sim_SetFloor(od_Sim* sim, double height, double friction);
void od_Sim_ClearFloor(od_Sim* sim);
// The simulation's force fields (opdeform/fields.h): they enter each step's prediction, per particle at its
// centre. Add, move and remove them between steps.
od_FieldSet* od_Sim_GetForceFields(od_Sim* sim);

od_Status od_Sim_Step(od_Sim* sim, int steps);
od_Status od_Sim_SolveStatic(od_Sim* sim, int iterations);

// velocities and angularVelocities may be NULL (zero).
od_Status od_Sim_SetState(od_Sim* sim, const double* positions, const double* rotations, const double* velocities,
						  const double* angularVelocities);
// SetState without orthonormalising the rotations: a saved state back to the same bits.
od_Status od_Sim_RestoreState(od_Sim* sim, const double* positions, const double* rotations, const double* velocities,
							  const double* angularVelocities);
const double* od_Sim_GetPositions(const od_Sim* sim);
const double* od_Sim_GetRotations(const od_Sim* sim);
const double* od_Sim_GetVelocities(const od_Sim* sim);
const double* od_Sim_GetAngularVelocities(const od_Sim* sim);

// The objective of the current (or last) step at the current iterate; static poses use the static objective.
double od_Sim_GetEnergy(od_Sim* sim);

// When enabled, the objective is recorded after the first global solve and after every local and every
// global step of each step or static solve; the record of the last one is kept.
void od_Sim_SetEnergyTrace(od_Sim* sim, int enabled);
const double* od_Sim_GetEnergyTrace(const od_Sim* sim, int* count);

typedef enum od_AcceleratorKind
{
	OD_ACCELERATE_NONE = 0,     // plain alternation of local and global steps
	OD_ACCELERATE_ANDERSON = 1, // Anderson acceleration of the centres, energy safeguarded
	OD_ACCELERATE_CHEBYSHEV = 2, // Chebyshev semi-iterative acceleration, energy safeguarded
	OD_ACCELERATE_AUTO = 3       // under a tolerance, chosen per step (tolerance.c): two plain pairs, then plain
	                             // pairs (their residual doubled is the estimate) if they contracted fast,
	                             // else Chebyshev; without a tolerance (and in static solves), Chebyshev
} od_AcceleratorKind;

typedef struct od_SolverDef
{
	od_AcceleratorKind accelerator;
	int window;     // Anderson history (1..16)
	double rho;     // Chebyshev spectral radius estimate in (0, 1)
	int threads;    // 0..64; 0: the CPUs this process may use (affinity, at most OMP_NUM_THREADS). > 1: the local step sweeps a block of particles per thread, then the
	                // border; the right side and the substitution split too (same bits run to run)
	int factorization; // CHOLMOD's path: 0 auto (supernodal from 400 flops per factor entry), 1 simplicial,
	                   // 2 supernodal; the substitution is the same for all (cholesky.c)
	double tolerance;  // 0: od_SimDef.iterations pairs per step. > 0: iterate each step until the residual
	                   // (tolerance.c: the largest displacement of a particle's material in the last pair, as a
	                   // fraction of the body's size; doubled for auto's plain pairs) is at most this, or
	                   // maxIterations pairs were made
	int maxIterations; // the cap of a step under a tolerance (>= 1)
} od_SolverDef;

od_SolverDef od_DefaultSolverDef(void);
od_Status od_Sim_SetSolver(od_Sim* sim, const od_SolverDef* def);
od_SolverDef od_Sim_GetSolver(const od_Sim* sim);

typedef struct od_SimCounters
{
	long long factorizations; // numeric factorizations of the global matrix
	long long analyses;       // symbolic analyses
	long long solves;         // back-substitutions (3 right sides each)
	long long steps;
	long long polarFallbacks; // local updates that needed the full SVD
	long long accelerated;    // iterations whose accelerated iterate was kept
	long long rejected;       // iterations whose accelerated iterate raised the energy and was dropped
	double localSeconds;      // wall time in local steps
	double globalSeconds;     // wall time in global steps (right side, back-substitution, factorizations)
	double analyzeSeconds;    // of which the symbolic analyses (ordering) took
	double factorSeconds;     // of which the numeric factorizations took (with copying the factor for the
	                          // substitutions)
} od_SimCounters;

od_SimCounters od_Sim_GetCounters(const od_Sim* sim);

// What the last od_Sim_Step call did (all of its steps).
typedef struct od_StepReport
{
	int steps;
	int iterations;     // local/global pairs, all steps
	int mostIterations; // the most in one step
	double error;       // the largest error estimate at the end of a step (the residual, a fraction of the
	                    // body's size; doubled for auto's plain pairs); measured only under a tolerance, else -1
	int unconverged;    // steps that stopped at maxIterations above the tolerance
} od_StepReport;

od_StepReport od_Sim_GetStepReport(const od_Sim* sim);

// What the threads' plan allows at most (docs/speed.md, "Threads"): per stage of an iteration, its work on one
// thread over its longest chain of tasks at the solver's thread count, each job on the threads the pool gives
// it with every CPU free (an Amdahl bound from the plan alone: the local sweep's phases, the right side's chunks
// and the substitution's levels and top, costed by the pool's per-item times). 1 where a stage runs on one
// thread; 0 until a step made the partition of the current constraints (local) or the factor of the current
// mode (global).
typedef struct od_ThreadBound
{
	int threads;
	double local, global;
} od_ThreadBound;

od_ThreadBound od_Sim_GetThreadBound(const od_Sim* sim);

#ifdef __cplusplus
}
#endif
