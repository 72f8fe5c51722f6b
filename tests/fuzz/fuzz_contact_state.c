// libFuzzer target: od_ContactGroup_SetPairs, the core of ContactGroup.restore_state (a saved group state is
// untrusted input, issue 28), on two 8-particle chains 0.15 m apart (their ellipsoids overlap), the group
// tests/fuzz/make_state_corpus.py saves its corpus from. Input: an int32 pair count m, then m pairs (int32 a,
// b) and m rows of OD_PAIR_VALUES doubles (normal force, friction force, normal, friction's anchor); the count is
// passed as given when negative, else cut to the pairs the bytes hold. Invariants: a refused state leaves the
// group's pairs as they were; an accepted one reads back bit for bit; a step after it ends finite or fails keeping
// both states.
#include "fuzz_chain.h"

#include "opdeform/colliders.h"
#include "opdeform/opdeform.h"

#include <stdlib.h>

#define N CHAIN_N

typedef struct Pairs
{
	int count;
	int* pairs;
	double* forces;
} Pairs;

static Pairs read_pairs(const od_ContactGroup* group)
{
	Pairs p = { od_ContactGroup_GetPairCount(group), NULL, NULL };
	p.pairs = malloc(sizeof(int) * 2 * (size_t)p.count + 1);
	p.forces = malloc(sizeof(double) * OD_PAIR_VALUES * (size_t)p.count + 1);
	CHECK(p.pairs && p.forces);
	od_ContactGroup_GetPairs(group, p.pairs, p.forces);
	return p;
}

static int same_pairs(const Pairs* a, int count, const int* pairs, const double* forces)
{
	return a->count == count && memcmp(a->pairs, pairs, sizeof(int) * 2 * (size_t)count) == 0 &&
		   memcmp(a->forces, forces, sizeof(double) * OD_PAIR_VALUES * (size_t)count) == 0;
}

static void release(Pairs* p)
{
	free(p->pairs);
	free(p->forces);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
	int32_t count = 0;
	memcpy(&count, data, size < 4 ? size : 4);
	size_t rest = size < 4 ? 0 : size - 4, fit = rest / (8 + OD_PAIR_VALUES * 8);
	int m = count < 0 ? count : (int)((size_t)count < fit ? (size_t)count : fit);
	int* pairs = malloc(sizeof(int) * 2 * (fit + 1));
	double* forces = malloc(sizeof(double) * OD_PAIR_VALUES * (fit + 1));
	CHECK(pairs && forces);
	memcpy(pairs, data + 4, 8 * fit);
	memcpy(forces, data + 4 + 8 * fit, OD_PAIR_VALUES * 8 * fit);

	od_SimDef def = od_DefaultSimDef();
	od_Sim* sims[2] = { NULL, NULL };
	CHECK(od_Sim_Create(chain(), &def, &sims[0]) == OD_OK && od_Sim_Create(chain(), &def, &sims[1]) == OD_OK);
	double x[N * 3], r[N * 9];
	memcpy(x, od_Sim_GetPositions(sims[1]), sizeof x);
	memcpy(r, od_Sim_GetRotations(sims[1]), sizeof r);
	for (int i = 0; i < N; ++i)
	{
		x[3 * i + 2] += 0.15;
	}
	CHECK(od_Sim_SetState(sims[1], x, r, NULL, NULL) == OD_OK);
	od_BodyContactDef contact = od_DefaultBodyContactDef();
	od_ContactGroup* group = NULL;
	CHECK(od_ContactGroup_Create(sims, 2, &contact, &group) == OD_OK);
	CHECK(od_ContactGroup_Step(group, 1) == OD_OK);

	Pairs before = read_pairs(group);
	od_Status status = od_ContactGroup_SetPairs(group, m, pairs, forces);
	TRACE("set %d pairs -> %s %s\n", m, od_StatusName(status), status == OD_OK ? "" : od_GetErrorMessage());
	Pairs after = read_pairs(group);
	if (status == OD_OK)
	{
		CHECK(same_pairs(&after, m, pairs, forces));
		double x0[2][N * 3];
		memcpy(x0[0], od_Sim_GetPositions(sims[0]), sizeof x0[0]);
		memcpy(x0[1], od_Sim_GetPositions(sims[1]), sizeof x0[1]);
		status = od_ContactGroup_Step(group, 1);
		TRACE("step -> %s\n", od_StatusName(status));
		for (int b = 0; b < 2; ++b)
		{
			CHECK(status == OD_OK ? fuzz_all_finite(od_Sim_GetPositions(sims[b]), N * 3)
								  : memcmp(x0[b], od_Sim_GetPositions(sims[b]), sizeof x0[b]) == 0);
		}
	}
	else
	{
		CHECK(status == OD_ERROR_ARGUMENT || status == OD_ERROR_MEMORY);
		CHECK(same_pairs(&after, before.count, before.pairs, before.forces));
	}
	release(&before);
	release(&after);
	od_ContactGroup_Destroy(group);
	od_Sim_Destroy(sims[0]);
	od_Sim_Destroy(sims[1]);
	free(pairs);
	free(forces);
	return 0;
}
