// libFuzzer target: the core calls that load a Simulation's pickle (Simulation.__setstate__, issue 28), fed
// arrays read as raw bytes, in the order the pickle sets them: goal frames (od_Sim_SetGoals), the goals' motion
// (od_Sim_RestoreGoalMotion), damping per particle (od_Sim_SetParticleDamping), a constraint's target as
// stored (od_Sim_RestoreConstraintTarget), the state (od_Sim_RestoreState), then one step.
// The simulation: the 8-particle chain tests/fuzz/make_state_corpus.py saves its corpus from, goals at 1 Hz
// carrying the rest, a position and a direction constraint. Input: the arrays below back to back (missing
// bytes read as zero). Invariants: a refused call changes nothing (state, goal motion, damping, target); an
// accepted one reads back bit for bit; the step ends finite or fails keeping the state.
#include "fuzz_chain.h"

#include "opdeform/opdeform.h"

#define N CHAIN_N

typedef struct Saved
{
	double goalPositions[N * 3], goalRotations[N * 9];
	double goalVelocities[N * 3], goalSpins[N * 3];
	int32_t goalSteps;
	int32_t pad;
	double damping[N];
	double target[3];
	double positions[N * 3], rotations[N * 9], velocities[N * 3], spins[N * 3];
} Saved;

typedef struct Snapshot
{
	double state[4][N * 9];
	double goalVelocities[N * 3], goalSpins[N * 3], damping[N], target[3];
	int goalSteps, hasDamping;
} Snapshot;

static void take(const od_Sim* sim, Snapshot* s)
{
	memset(s, 0, sizeof *s);
	memcpy(s->state[0], od_Sim_GetPositions(sim), sizeof(double) * N * 3);
	memcpy(s->state[1], od_Sim_GetRotations(sim), sizeof(double) * N * 9);
	memcpy(s->state[2], od_Sim_GetVelocities(sim), sizeof(double) * N * 3);
	memcpy(s->state[3], od_Sim_GetAngularVelocities(sim), sizeof(double) * N * 3);
	CHECK(od_Sim_GetGoalMotion(sim, s->goalVelocities, s->goalSpins, &s->goalSteps) == OD_OK);
	const double* d = od_Sim_GetParticleDamping(sim);
	s->hasDamping = d != NULL;
	if (d)
	{
		memcpy(s->damping, d, sizeof s->damping);
	}
	CHECK(od_Sim_GetConstraintTarget(sim, 0, s->target) == OD_OK);
}

static od_Sim* make_sim(void)
{
	double hz[N], point[3] = { 0, 0, 0 }, end[3] = { 0.2 * (N - 1), 0, 0 }, direction[3] = { 1, 0, 0 };
	for (int i = 0; i < N; ++i)
	{
		hz[i] = 1.0;
	}
	od_SimDef def = od_DefaultSimDef();
	od_Sim* sim = NULL;
	CHECK(od_Sim_Create(chain(), &def, &sim) == OD_OK);
	CHECK(od_Sim_SetGoalFrequencies(sim, hz) == OD_OK);
	CHECK(od_Sim_SetGoalRest(sim, true) == OD_OK);
	int id;
	CHECK(od_Sim_AddPositionConstraint(sim, point, NULL, 1e3, &id) == OD_OK && id == 0);
	CHECK(od_Sim_AddDirectionConstraint(sim, end, direction, NULL, 10.0, &id) == OD_OK);
	return sim;
}

static void check_unchanged(const od_Sim* sim, const Snapshot* before)
{
	Snapshot now;
	take(sim, &now);
	CHECK(memcmp(&now, before, sizeof now) == 0);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
	Saved s;
	memset(&s, 0, sizeof s);
	memcpy(&s, data, size < sizeof s ? size : sizeof s);
	od_Sim* sim = make_sim();
	Snapshot before, after;
	take(sim, &before);
	od_Status status = od_Sim_SetGoals(sim, s.goalPositions, s.goalRotations);
	TRACE("goals -> %s\n", od_StatusName(status));
	take(sim, &after);
	CHECK(status == OD_OK || memcmp(&after, &before, sizeof after) == 0);

	take(sim, &before);
	status = od_Sim_RestoreGoalMotion(sim, s.goalVelocities, s.goalSpins, s.goalSteps);
	TRACE("goal motion -> %s\n", od_StatusName(status));
	take(sim, &after);
	if (status == OD_OK)
	{
		CHECK(memcmp(after.goalVelocities, s.goalVelocities, sizeof s.goalVelocities) == 0);
		CHECK(memcmp(after.goalSpins, s.goalSpins, sizeof s.goalSpins) == 0);
	}
	else
	{
		check_unchanged(sim, &before);
	}

	take(sim, &before);
	status = od_Sim_SetParticleDamping(sim, s.damping);
	TRACE("damping -> %s\n", od_StatusName(status));
	take(sim, &after);
	CHECK(status == OD_OK ? memcmp(after.damping, s.damping, sizeof s.damping) == 0
						  : memcmp(&after, &before, sizeof after) == 0);

	take(sim, &before);
	status = od_Sim_RestoreConstraintTarget(sim, 0, s.target);
	TRACE("target -> %s\n", od_StatusName(status));
	take(sim, &after);
	CHECK(status == OD_OK ? memcmp(after.target, s.target, sizeof s.target) == 0
						  : memcmp(&after, &before, sizeof after) == 0);

	take(sim, &before);
	status = od_Sim_RestoreState(sim, s.positions, s.rotations, s.velocities, s.spins);
	TRACE("state -> %s\n", od_StatusName(status));
	take(sim, &after);
	if (status == OD_OK)
	{
		CHECK(memcmp(after.state[0], s.positions, sizeof s.positions) == 0);
		CHECK(memcmp(after.state[1], s.rotations, sizeof s.rotations) == 0);
	}
	else
	{
		check_unchanged(sim, &before);
	}

	take(sim, &before);
	status = od_Sim_Step(sim, 1);
	TRACE("step -> %s\n", od_StatusName(status));
	if (status == OD_OK)
	{
		CHECK(fuzz_all_finite(od_Sim_GetPositions(sim), N * 3) && fuzz_all_finite(od_Sim_GetRotations(sim), N * 9));
	}
	else
	{
		take(sim, &after);
		CHECK(memcmp(after.state, before.state, sizeof after.state) == 0);
	}
	od_Sim_Destroy(sim);
	return 0;
}
