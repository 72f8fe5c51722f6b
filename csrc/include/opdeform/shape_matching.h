// opdeform: Gauss-Seidel shape matching with oriented particles (Müller and Chentanez 2011), the baseline
// that the ARAP solver of opdeform.h is compared against, on the same rest graphs (od_Graph).
//
// Every particle i and its graph neighbours form a shape-matching group. A step predicts positions and
// orientations (gravity, velocities), then, for `iterations` sweeps, matches every group in turn
// (Gauss-Seidel), moving its particles a fraction `stiffness` of the way to their goals and setting the
// orientation of particle i to its group's rotation, and projects every position constraint; velocities
// come from the position and orientation changes of the step (position-based dynamics). The stiffness of
// the result therefore depends on the iteration count and the step size, unlike the ARAP solver's.
//
// The model (groups, constraints, floor) is separate from the state (centres, rotations, velocities);
// arrays are row-major doubles, positions n*3 and rotations n*9 (R[3*r + c]) as in opdeform.h. An object
// borrows its graph: keep the graph alive until the object is destroyed.
#pragma once

#if defined(OD_LAYER_CHECK) && !defined(OD_USES_BASELINE)
#error "opdeform/shape_matching.h is the baseline layer's header, which this layer of csrc/ may not use (docs/architecture.md)"
#endif

#include "opdeform/graph.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct od_ShapeMatching od_ShapeMatching;

typedef struct od_ShapeMatchingDef
{
	double stiffness;  // fraction of the way to the goals per group and sweep, in (0, 1]
	double density;    // rho; the result does not depend on it (only mass ratios enter), kept for symmetry
	double dt;         // h
	int iterations;    // Gauss-Seidel sweeps over the groups and constraints per step
	double gravity[3];
	double damping;    // per-step velocity damping in [0, 1]
	int skinNeighbors; // m of the Sumner weights that place the constraints
} od_ShapeMatchingDef;

typedef struct od_ShapeMatchingCounters
{
	long long steps;
	long long groupSolves;    // shape-matching group projections
	long long polarFallbacks; // group rotations that needed the full SVD
} od_ShapeMatchingCounters;

od_ShapeMatchingDef od_DefaultShapeMatchingDef(void);
od_Status od_ShapeMatching_Create(const od_Graph* graph, const od_ShapeMatchingDef* def, od_ShapeMatching** sm);
void od_ShapeMatching_Destroy(od_ShapeMatching* sm);
od_ShapeMatchingDef od_ShapeMatching_GetDef(const od_ShapeMatching* sm);
// Changes parameters; the state is kept.
od_Status od_ShapeMatching_SetDef(od_ShapeMatching* sm, const od_ShapeMatchingDef* def);

// A rest-space point held at target (NULL: where the point is now). Ids count up from 0. The constraint is
// hard: every sweep projects the skinned point onto its target through the translations and rotations of
// its skinning particles, weighted by their inverse masses and inverse inertias.
od_Status od_ShapeMatching_AddPositionConstraint(od_ShapeMatching* sm, const double point[3], const double* target,
												 int* id);
od_Status od_ShapeMatching_SetConstraintTarget(od_ShapeMatching* sm, int id, const double target[3]);
int od_ShapeMatching_GetConstraintCount(const od_ShapeMatching* sm);

// The floor z = height with a Coulomb-like friction coefficient (as od_Sim_SetFloor).
od_Status od_ShapeMatching_SetFloor(od_ShapeMatching* sm, double height, double friction);
void od_ShapeMatching_ClearFloor(od_ShapeMatching* sm);

// On a non-finite result the state of the call's start is restored and OD_ERROR_NOT_FINITE returned.
od_Status od_ShapeMatching_Step(od_ShapeMatching* sm, int steps);

// velocities and angularVelocities may be NULL (zero).
od_Status od_ShapeMatching_SetState(od_ShapeMatching* sm, const double* positions, const double* rotations,
									const double* velocities, const double* angularVelocities);
const double* od_ShapeMatching_GetPositions(const od_ShapeMatching* sm);
const double* od_ShapeMatching_GetRotations(const od_ShapeMatching* sm);
const double* od_ShapeMatching_GetVelocities(const od_ShapeMatching* sm);
const double* od_ShapeMatching_GetAngularVelocities(const od_ShapeMatching* sm);
od_ShapeMatchingCounters od_ShapeMatching_GetCounters(const od_ShapeMatching* sm);

#ifdef __cplusplus
}
#endif
