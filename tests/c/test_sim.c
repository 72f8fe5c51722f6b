// The solver from C alone: monotone energy, one factorization for many steps and target moves, no
// allocation per step after warm-up (alone and in a group), bit-for-bit determinism, and a failed step that keeps
// the state.
#include "opdeform/colliders.h"
#include "opdeform/opdeform.h"
#include "test_macros.h"

#include <string.h>

#define N 20

static od_Graph* make_bar(void)
{
	double c[3 * N], r[3 * N];
	int e[2 * (N - 1)];
	for (int i = 0; i < N; ++i)
	{
		c[3 * i] = (i + 0.5) * 0.1;
		c[3 * i + 1] = c[3 * i + 2] = 0.0;
		r[3 * i] = 0.05;
		r[3 * i + 1] = r[3 * i + 2] = 0.1;
		if (i + 1 < N)
		{
			e[2 * i] = i;
			e[2 * i + 1] = i + 1;
		}
	}
	od_GraphDef def = od_DefaultGraphDef();
	def.particleCount = N;
	def.centers = c;
	def.radii = r;
	def.edgeCount = N - 1;
	def.edges = e;
	od_Graph* g = NULL;
	return od_Graph_Create(&def, &g) == OD_OK ? g : NULL;
}

static od_Sim* make_pinned(const od_Graph* g, int* tipId)
{
	od_SimDef def = od_DefaultSimDef();
	def.stiffness = 1e6;
	od_Sim* sim = NULL;
	if (od_Sim_Create(g, &def, &sim) != OD_OK)
	{
		return NULL;
	}
	for (int a = 0; a < 5; ++a)
	{
		for (int b = 0; b < 5; ++b)
		{
			double p[3] = { 0.0, -0.1 + 0.05 * a, -0.1 + 0.05 * b };
			int id;
			if (od_Sim_AddPositionConstraint(sim, p, NULL, 1e3 * 1e6 * 0.002, &id) != OD_OK)
			{
				return NULL;
			}
		}
	}
	double tip[3] = { 2.0, 0, 0 };
	od_Sim_AddPositionConstraint(sim, tip, NULL, 10.0, tipId);
	return sim;
}

static int check_monotone(od_Sim* sim)
{
	int count = 0;
	const double* e = od_Sim_GetEnergyTrace(sim, &count);
	ENSURE(count > 2);
	for (int k = 1; k < count; ++k)
	{
		ENSURE(e[k] <= e[k - 1] + 1e-12 * fabs(e[k - 1]));
	}
	return 0;
}

// A link softness from C: values outside (0, 1] are refused with OD_ERROR_ARGUMENT and change nothing; set, it
// refactors once and steps without allocating, a stretch limit never reached too (od_Sim_SetStretchLimit, bad
// limits refused); NULL clears it.
static int check_link_softness(const od_Graph* g)
{
	int tip;
	od_Sim* sim = make_pinned(g, &tip);
	ENSURE(sim != NULL && od_Sim_Step(sim, 1) == OD_OK);
	double r[N];
	for (int i = 0; i < N; ++i)
	{
		r[i] = 1.0;
	}
	const double bad[4] = { 0.0, -0.5, 1.5, NAN };
	for (int k = 0; k < 4; ++k)
	{
		r[7] = bad[k];
		ENSURE(od_Sim_SetLinkSoftness(sim, r) == OD_ERROR_ARGUMENT && od_Sim_GetLinkSoftness(sim) == NULL);
	}
	r[7] = 0.01;
	ENSURE(od_Sim_SetLinkSoftness(sim, r) == OD_OK && od_Sim_GetLinkSoftness(sim)[7] == 0.01);
	ENSURE(od_Sim_SetStretchLimit(sim, 1.0, NULL) == OD_ERROR_ARGUMENT && od_Sim_GetStretchLimit(sim) == 0.0);
	ENSURE(od_Sim_SetStretchLimit(sim, NAN, NULL) == OD_ERROR_ARGUMENT && od_Sim_GetStretchLimit(sim) == 0.0);
	ENSURE(od_Sim_SetStretchLimit(sim, 50.0, NULL) == OD_OK && od_Sim_GetStretchLimit(sim) == 50.0);
	ENSURE(od_Sim_Step(sim, 1) == OD_OK);
	od_SimCounters before = od_Sim_GetCounters(sim);
	long long allocations = od_GetAllocationCount();
	ENSURE(od_Sim_Step(sim, 20) == OD_OK);
	ENSURE(od_GetAllocationCount() == allocations);
	ENSURE(od_Sim_GetCounters(sim).factorizations == before.factorizations && before.factorizations == 2);
	ENSURE(od_Sim_SetStretchLimit(sim, 0.0, NULL) == OD_OK && od_Sim_GetStretchLimit(sim) == 0.0);
	ENSURE(od_Sim_SetLinkSoftness(sim, NULL) == OD_OK && od_Sim_GetLinkSoftness(sim) == NULL);
	od_Sim_Destroy(sim);
	return 0;
}

int test_sim(void)
{
	od_Graph* g = make_bar();
	ENSURE(g != NULL);
	int tip;
	od_Sim* sim = make_pinned(g, &tip);
	ENSURE(sim != NULL);

	od_Sim_SetEnergyTrace(sim, 1);
	ENSURE(od_Sim_SolveStatic(sim, 50) == OD_OK);
	ENSURE(check_monotone(sim) == 0);
	ENSURE(od_Sim_Step(sim, 1) == OD_OK);
	ENSURE(check_monotone(sim) == 0);
	od_Sim_SetEnergyTrace(sim, 0);

	// Many steps and target moves: no new factorization, no allocation after warm-up.
	ENSURE(od_Sim_Step(sim, 2) == OD_OK);
	od_SimCounters before = od_Sim_GetCounters(sim);
	long long allocations = od_GetAllocationCount();
	for (int k = 0; k < 100; ++k)
	{
		double t[3] = { 2.0, 0.0, 0.01 * k };
		ENSURE(od_Sim_SetConstraintTarget(sim, tip, t) == OD_OK);
		ENSURE(od_Sim_Step(sim, 1) == OD_OK);
	}
	od_SimCounters after = od_Sim_GetCounters(sim);
	ENSURE(after.factorizations == before.factorizations);
	ENSURE(after.solves == before.solves + 100 * 11);
	ENSURE(od_GetAllocationCount() == allocations);

	// Determinism: a second simulation driven the same way ends bit for bit equal.
	int tip2;
	od_Sim* twin = make_pinned(g, &tip2);
	ENSURE(twin != NULL);
	ENSURE(od_Sim_SolveStatic(twin, 50) == OD_OK);
	ENSURE(od_Sim_Step(twin, 1) == OD_OK);
	ENSURE(od_Sim_Step(twin, 2) == OD_OK);
	for (int k = 0; k < 100; ++k)
	{
		double t[3] = { 2.0, 0.0, 0.01 * k };
		od_Sim_SetConstraintTarget(twin, tip2, t);
		od_Sim_Step(twin, 1);
	}
	ENSURE(memcmp(od_Sim_GetPositions(sim), od_Sim_GetPositions(twin), sizeof(double) * 3 * N) == 0);
	ENSURE(memcmp(od_Sim_GetRotations(sim), od_Sim_GetRotations(twin), sizeof(double) * 9 * N) == 0);
	od_Sim_Destroy(twin);

	// A step that overflows fails with OD_ERROR_NOT_FINITE and keeps the state.
	double kept[3 * N];
	memcpy(kept, od_Sim_GetPositions(sim), sizeof kept);
	od_SimDef def = od_Sim_GetDef(sim);
	def.gravity[2] = -1e308;
	ENSURE(od_Sim_SetDef(sim, &def) == OD_OK);
	ENSURE(od_Sim_Step(sim, 3) == OD_ERROR_NOT_FINITE);
	ENSURE(memcmp(kept, od_Sim_GetPositions(sim), sizeof kept) == 0);

	// Unknown ids and a static solve without constraints are errors, not crashes.
	ENSURE(od_Sim_RemoveConstraint(sim, 12345) == OD_ERROR_NOT_FOUND);
	od_Sim_Destroy(sim);
	od_SimDef plain = od_DefaultSimDef();
	ENSURE(od_Sim_Create(g, &plain, &sim) == OD_OK);
	ENSURE(od_Sim_SolveStatic(sim, 5) == OD_ERROR_ARGUMENT);
	od_Sim_Destroy(sim);
	ENSURE(check_link_softness(g) == 0);
	od_Graph_Destroy(g);
	return 0;
}

// Steps of the pinned bar with its tip target moved, under `solver`; the positions after `steps` steps.
static int run_moved(const od_Graph* g, const od_SolverDef* solver, int steps, double* positions)
{
	int tip;
	od_Sim* sim = make_pinned(g, &tip);
	ENSURE(sim != NULL && od_Sim_SetSolver(sim, solver) == OD_OK);
	for (int k = 0; k < steps; ++k)
	{
		double t[3] = { 2.0, 0.0, 0.02 * k };
		ENSURE(od_Sim_SetConstraintTarget(sim, tip, t) == OD_OK && od_Sim_Step(sim, 1) == OD_OK);
	}
	memcpy(positions, od_Sim_GetPositions(sim), sizeof(double) * 3 * N);
	od_Sim_Destroy(sim);
	return 0;
}

// The auto accelerator: under a tolerance every step reaches it (plain or Chebyshev, tolerance.c) with no
// allocation per step; without one it is Chebyshev bit for bit; an unknown accelerator is refused.
int test_auto(void)
{
	od_Graph* g = make_bar();
	ENSURE(g != NULL);
	int tip;
	od_Sim* sim = make_pinned(g, &tip);
	ENSURE(sim != NULL);
	od_SolverDef solver = od_DefaultSolverDef();
	solver.accelerator = OD_ACCELERATE_AUTO;
	solver.tolerance = 2e-5;
	ENSURE(od_Sim_SetSolver(sim, &solver) == OD_OK);
	ENSURE(od_Sim_Step(sim, 2) == OD_OK);
	long long allocations = od_GetAllocationCount();
	for (int k = 0; k < 60; ++k)
	{
		double t[3] = { 2.0, 0.0, 0.02 * k };
		ENSURE(od_Sim_SetConstraintTarget(sim, tip, t) == OD_OK && od_Sim_Step(sim, 1) == OD_OK);
		od_StepReport r = od_Sim_GetStepReport(sim);
		ENSURE(r.unconverged == 0 && r.iterations >= 1 && r.error >= 0.0 && r.error <= solver.tolerance);
	}
	ENSURE(od_GetAllocationCount() == allocations);
	ENSURE(od_Sim_GetSolver(sim).accelerator == OD_ACCELERATE_AUTO);
	solver.accelerator = (od_AcceleratorKind)4;
	ENSURE(od_Sim_SetSolver(sim, &solver) == OD_ERROR_ARGUMENT && strstr(od_GetErrorMessage(), "auto"));
	od_Sim_Destroy(sim);

	double autoX[3 * N], chebyshevX[3 * N];
	od_SolverDef fixed = od_DefaultSolverDef();
	fixed.accelerator = OD_ACCELERATE_AUTO;
	ENSURE(run_moved(g, &fixed, 10, autoX) == 0);
	fixed.accelerator = OD_ACCELERATE_CHEBYSHEV;
	ENSURE(run_moved(g, &fixed, 10, chebyshevX) == 0);
	ENSURE(memcmp(autoX, chebyshevX, sizeof autoX) == 0);
	od_Graph_Destroy(g);
	return 0;
}

// Goals: a static pose on goals moved rigidly is the moved bar; a moving goal per step never refactors
// and the energy of every step still decreases; a change of frequencies refactors once; bad goals fail
// and change nothing.
static int check_goal_static(const od_Graph* g)
{
	od_SimDef def = od_DefaultSimDef();
	def.stiffness = 1e6;
	def.gravity[2] = 0.0;
	od_Sim* sim = NULL;
	ENSURE(od_Sim_Create(g, &def, &sim) == OD_OK);
	double f[N], x[3 * N], r[9 * N];
	const double turn[9] = { 0, -1, 0, 1, 0, 0, 0, 0, 1 }; // 90 degrees about z
	const double* c = od_Graph_GetCenters(g);
	for (int i = 0; i < N; ++i)
	{
		f[i] = 2.0;
		for (int a = 0; a < 3; ++a)
		{
			x[3 * i + a] = turn[3 * a] * c[3 * i] + turn[3 * a + 1] * c[3 * i + 1] + turn[3 * a + 2] * c[3 * i + 2] + 1.0;
		}
		memcpy(r + 9 * i, turn, sizeof turn);
	}
	ENSURE(od_Sim_SetGoalFrequencies(sim, f) == OD_OK);
	ENSURE(od_Sim_SetGoals(sim, x, r) == OD_OK);
	ENSURE(od_Sim_SolveStatic(sim, 200) == OD_OK);
	const double* p = od_Sim_GetPositions(sim);
	for (int k = 0; k < 3 * N; ++k)
	{
		ENSURE_SMALL(p[k] - x[k], 1e-9);
	}
	od_Sim_Destroy(sim);
	return 0;
}

static int check_goal_moving(const od_Graph* g)
{
	int tip;
	od_Sim* sim = make_pinned(g, &tip);
	ENSURE(sim);
	double f[N], x[3 * N];
	for (int i = 0; i < N; ++i)
	{
		f[i] = 1.0;
	}
	ENSURE(od_Sim_SetGoalFrequencies(sim, f) == OD_OK);
	od_Sim_SetEnergyTrace(sim, 1);
	memcpy(x, od_Graph_GetCenters(g), sizeof x);
	for (int step = 0; step < 30; ++step)
	{
		for (int i = 0; i < N; ++i)
		{
			x[3 * i + 2] = 0.01 * step * x[3 * i]; // the goal bends up
		}
		ENSURE(od_Sim_SetGoals(sim, x, NULL) == OD_OK);
		ENSURE(od_Sim_Step(sim, 1) == OD_OK);
		ENSURE(check_monotone(sim) == 0);
	}
	ENSURE(od_Sim_GetCounters(sim).factorizations == 1);
	ENSURE(od_Sim_GetPositions(sim)[3 * (N - 1) + 2] > 0.0); // pulled up against gravity
	f[3] = -1.0;
	x[7] = NAN;
	double before[3 * N];
	memcpy(before, od_Sim_GetPositions(sim), sizeof before);
	ENSURE(od_Sim_SetGoalFrequencies(sim, f) == OD_ERROR_ARGUMENT);
	ENSURE(od_Sim_SetGoals(sim, x, NULL) == OD_ERROR_ARGUMENT);
	ENSURE(memcmp(before, od_Sim_GetPositions(sim), sizeof before) == 0);
	f[3] = 3.0;
	ENSURE(od_Sim_SetGoalFrequencies(sim, f) == OD_OK);
	ENSURE(od_Sim_Step(sim, 2) == OD_OK);
	ENSURE(od_Sim_GetCounters(sim).factorizations == 2);
	ENSURE(od_Sim_SetGoalFrequencies(sim, NULL) == OD_OK);
	ENSURE(od_Sim_Step(sim, 1) == OD_OK);
	ENSURE(od_Sim_GetCounters(sim).factorizations == 3);
	od_Sim_Destroy(sim);
	return 0;
}

// Goals carrying the rest (docs/goals.md): the static pose on goals that bend the bar 90 degrees at its middle,
// strength 0 on the far half, is the bent bar; new frames never refactor; bad damping and motion fail.
static int check_goal_rest(const od_Graph* g)
{
	od_SimDef def = od_DefaultSimDef();
	def.stiffness = 1e6;
	def.gravity[2] = 0.0;
	od_Sim* sim = NULL;
	ENSURE(od_Sim_Create(g, &def, &sim) == OD_OK);
	double f[N], x[3 * N], r[9 * N], velocity[3 * N], spin[3 * N];
	const double turn[9] = { 0, -1, 0, 1, 0, 0, 0, 0, 1 }, eye[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
	const double* c = od_Graph_GetCenters(g);
	for (int i = 0; i < N; ++i)
	{
		bool far = i >= N / 2;
		f[i] = far ? 0.0 : 5.0;
		x[3 * i] = far ? 1.0 : c[3 * i];
		x[3 * i + 1] = far ? c[3 * i] - 1.0 : 0.0;
		x[3 * i + 2] = 0.0;
		memcpy(r + 9 * i, far ? turn : eye, sizeof turn);
	}
	int steps = 0;
	ENSURE(od_Sim_GetGoalMotion(sim, velocity, spin, &steps) == OD_ERROR_ARGUMENT); // no goals yet
	ENSURE(od_Sim_SetGoalFrequencies(sim, f) == OD_OK);
	ENSURE(od_Sim_SetGoalRest(sim, true) == OD_OK && od_Sim_GetGoalRest(sim));
	ENSURE(od_Sim_SetGoals(sim, x, r) == OD_OK);
	ENSURE(od_Sim_SolveStatic(sim, 4000) == OD_OK); // the free half turns 90 degrees: slow from rest (0.03 m at 500)
	const double* p = od_Sim_GetPositions(sim);
	for (int k = 0; k < 3 * N; ++k)
	{
		ENSURE_SMALL(p[k] - x[k], 1e-9);
	}
	for (int step = 0; step < 5; ++step)
	{
		x[0] += 0.01;
		ENSURE(od_Sim_SetGoals(sim, x, r) == OD_OK);
		ENSURE(od_Sim_Step(sim, 2) == OD_OK);
	}
	ENSURE(od_Sim_GetGoalMotion(sim, velocity, spin, &steps) == OD_OK && steps == 2);
	ENSURE_SMALL(velocity[0] - 0.01 / (2 * def.dt), 1e-9); // moved 0.01 over the two steps since the last frame
	ENSURE_SMALL(velocity[3] + spin[0] + spin[29], 0.0);
	ENSURE(od_Sim_GetCounters(sim).factorizations == 2); // the static pose's matrix and the dynamic one
	double damping[N] = { 0 };
	damping[4] = 1.5;
	ENSURE(od_Sim_SetParticleDamping(sim, damping) == OD_ERROR_ARGUMENT);
	damping[4] = NAN;
	ENSURE(od_Sim_SetParticleDamping(sim, damping) == OD_ERROR_ARGUMENT);
	ENSURE(od_Sim_GetParticleDamping(sim) == NULL);
	damping[4] = 0.2;
	ENSURE(od_Sim_SetParticleDamping(sim, damping) == OD_OK && od_Sim_GetParticleDamping(sim)[4] == 0.2);
	ENSURE(od_Sim_RestoreGoalMotion(sim, velocity, spin, -2) == OD_ERROR_ARGUMENT);
	ENSURE(od_Sim_SetGoalRest(sim, false) == OD_OK);
	ENSURE(od_Sim_RestoreGoalMotion(sim, velocity, spin, 0) == OD_ERROR_ARGUMENT);
	od_Sim_Destroy(sim);
	return 0;
}

int test_goal(void)
{
	od_Graph* g = make_bar();
	ENSURE(g);
	int failed = check_goal_static(g) || check_goal_moving(g) || check_goal_rest(g);
	od_Graph_Destroy(g);
	return failed;
}

// The interrupt handler (base.h): polled at most every 50 ms, a nonzero answer stops a long step with
// OD_ERROR_INTERRUPTED and the state from before the call; no handler, no effect.
static int stop_now(void* context)
{
	++*(int*)context;
	return 1;
}

int test_interrupt(void)
{
	od_Graph* g = make_bar();
	int tip = -1, polls = 0;
	od_Sim* sim = g ? make_pinned(g, &tip) : NULL;
	ENSURE(sim && od_Sim_Step(sim, 2) == OD_OK);
	double before[3 * N];
	memcpy(before, od_Sim_GetPositions(sim), sizeof before);
	od_SetInterruptHandler(stop_now, &polls);
	ENSURE(od_Sim_Step(sim, 100000000) == OD_ERROR_INTERRUPTED);
	ENSURE(polls == 1 && memcmp(before, od_Sim_GetPositions(sim), sizeof before) == 0);
	od_SetInterruptHandler(NULL, NULL);
	ENSURE(od_Sim_Step(sim, 1) == OD_OK);
	od_Sim_Destroy(sim);
	od_Graph_Destroy(g);
	return 0;
}

// Two bars stacked in a group, meeting their floor with their skins (a point above and below each particle) and
// each other with their ellipsoids (the add-on's default, which takes the members' inelastic impacts,
// od_BodyContact_Impacts): once landed, a group step allocates nothing, the upper resting on the lower.
static od_Sim* make_skin_bar(const od_Graph* g, double lift)
{
	od_SimDef def = od_DefaultSimDef();
	def.stiffness = 1e6;
	def.dt = 1.0 / 240.0;
	def.gravity[2] = -9.81;
	od_Sim* sim = NULL;
	if (od_Sim_Create(g, &def, &sim) != OD_OK)
	{
		return NULL;
	}
	const double* c = od_Graph_GetCenters(g);
	double x[3 * N], rotations[9 * N], points[6 * N];
	int particles[2 * N];
	for (int i = 0; i < N; ++i)
	{
		for (int k = 0; k < 9; ++k)
		{
			rotations[9 * i + k] = k % 4 == 0 ? 1.0 : 0.0;
		}
		for (int k = 0; k < 3; ++k)
		{
			x[3 * i + k] = c[3 * i + k] + (k == 2 ? lift : 0.0);
			points[6 * i + k] = points[6 * i + 3 + k] = c[3 * i + k];
		}
		points[6 * i + 2] -= 0.1;
		points[6 * i + 5] += 0.1;
		particles[2 * i] = particles[2 * i + 1] = i;
	}
	bool ok = od_Sim_SetState(sim, x, rotations, NULL, NULL) == OD_OK && od_Sim_SetFloor(sim, 0.0, 0.5) == OD_OK &&
			  od_Sim_SetContactSkin(sim, points, particles, 2 * N, 0) == OD_OK;
	if (!ok)
	{
		od_Sim_Destroy(sim);
	}
	return ok ? sim : NULL;
}

static int check_group_at_rest(od_Sim* const* sims)
{
	od_BodyContactDef def = od_DefaultBodyContactDef();
	od_ContactGroup* group = NULL;
	ENSURE(od_ContactGroup_Create(sims, 2, &def, &group) == OD_OK);
	ENSURE(od_ContactGroup_Step(group, 240) == OD_OK);
	long long allocations = od_GetAllocationCount();
	ENSURE(od_ContactGroup_Step(group, 120) == OD_OK);
	ENSURE(od_GetAllocationCount() == allocations);
	int count = od_ContactGroup_GetPairCount(group), pairs[2 * 4 * N * N];
	double forces[4 * N * N];
	ENSURE(count > 0 && count <= 4 * N * N);
	od_ContactGroup_GetPairs(group, pairs, forces);
	double most = 0.0;
	for (int k = 0; k < count; ++k)
	{
		most = forces[k] > most ? forces[k] : most;
	}
	ENSURE(most > 0.0); // the pairs carry the upper: interfaces were gathered at every step
	const double *lower = od_Sim_GetPositions(sims[0]), *upper = od_Sim_GetPositions(sims[1]);
	ENSURE(upper[3 * (N / 2) + 2] > lower[3 * (N / 2) + 2] + 0.15);
	od_ContactGroup_Destroy(group);
	return 0;
}

int test_group(void)
{
	od_Graph* g = make_bar();
	ENSURE(g);
	od_Sim* sims[2] = { make_skin_bar(g, 0.1), make_skin_bar(g, 0.32) };
	int failed = !sims[0] || !sims[1] || check_group_at_rest(sims);
	od_Sim_Destroy(sims[0]);
	od_Sim_Destroy(sims[1]);
	od_Graph_Destroy(g);
	return failed;
}
