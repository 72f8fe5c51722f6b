// Internal layout of a simulation: the model (graph, parameters, constraints, factorizations), the
// state (centres, rotations, velocities) and preallocated scratch. Every stage of a step is a function
// of (sim) that reads the model and rewrites the state; nothing is allocated per step after warm-up.
#pragma once

#include "graph.h"

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
	// Incidence, rebuilt when the set changes: for particle i, entries touchStart[i]..touchStart[i+1]-1
	// of touchSlot (constraint slot) and touchLocal (index of i in that constraint's skinning list).
	int* touchStart;
	int* touchSlot;
	int* touchLocal;
	int touchCapacity;
	bool touchDirty;
} od_ConstraintSet;

typedef struct od_State
{
	double* x;     // n*3
	double* R;     // n*9
	double* v;     // n*3
	double* omega; // n*3
} od_State;

typedef enum od_Mode
{
	OD_DYNAMIC = 0,
	OD_STATIC = 1,
} od_Mode;

typedef struct od_GlobalSolver od_GlobalSolver; // global_solve.c

struct od_Sim
{
	const od_Graph* graph;
	od_SimDef def;
	od_ConstraintSet constraints;
	od_GlobalSolver* solver[2]; // per mode
	bool hasFloor;
	double floorHeight, floorFriction;

	od_State state;
	od_State saved;    // the state at the start of the current call, restored on failure
	od_State previous; // the state at the start of the current step (x⁽¹⁾, R⁽¹⁾)

	// Step scratch and the targets of the current objective.
	od_Mode mode;
	bool predictionValid; // y and Rtilde belong to the current objective
	double* y;            // n*3 predicted centres
	double* Rtilde;       // n*9 predicted rotations
	double* angularScale; // n, friction's scaling of the angular velocity of touching particles

	bool traceEnabled;
	double* trace;
	int traceCount, traceCapacity;

	od_SimCounters counters;
	_Atomic int busy;
};

// constraints.c
void od_Constraints_Destroy(od_ConstraintSet* set);
od_Status od_Constraints_UpdateIncidence(od_ConstraintSet* set, int particleCount);
void od_Constraints_CurrentPoint(const od_Constraint* c, const od_Graph* g, const od_State* s, double out[3]);
void od_Constraints_CurrentDirection(const od_Constraint* c, const od_State* s, double out[3], double* length);
void od_Constraints_AddLocal(const od_Sim* sim, int i, od_Mat3* c);
double od_Constraints_Energy(const od_Sim* sim);
od_Status od_Constraints_CheckPinned(const od_Sim* sim);

// local_step.c
void od_LocalStep(od_Sim* sim);

// global_solve.c
od_Status od_GlobalSolver_Create(od_GlobalSolver** solver);
void od_GlobalSolver_Destroy(od_GlobalSolver* solver);
void od_GlobalSolver_Invalidate(od_GlobalSolver* solver);
od_Status od_GlobalStep(od_Sim* sim);

// floor.c
void od_FloorStep(od_Sim* sim, const od_State* before, double* angularScale);

// energy.c
double od_Energy(const od_Sim* sim);
void od_Predict(od_Sim* sim);
