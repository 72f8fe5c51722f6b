// libFuzzer target: od_MpmWorld_LoadState on arbitrary bytes (the core of an mpm.World pickle: a damaged or
// crafted file, issue 28). The world is the one tests/fuzz/make_state_corpus.py saves its corpus from (the
// unit box, dx = 1/16, one thread, a floor at z = 0.1 and a sphere), holding 8 particles of its own first.
// Invariants: a refused state leaves the world's saved bytes as they were; an accepted one has the size the
// header says, saves again to bytes that load again to the same bytes, reads every field without touching
// memory it does not own, and steps either to finite particles inside the domain or to a clean error.
#include "fuzz_input.h"

#include "opdeform/mpm.h"

#include <stdlib.h>

static od_MpmWorld* make_world(void)
{
	od_MpmWorldDef def = od_DefaultMpmWorldDef();
	def.dx = 1.0 / 16;
	def.threads = 1;
	od_MpmWorld* w = NULL;
	CHECK(od_MpmWorld_Create(&def, &w) == OD_OK);
	od_MpmColliderDef c = od_DefaultMpmColliderDef();
	c.translation[2] = 0.1;
	int id = 0;
	CHECK(od_MpmWorld_AddCollider(w, &c, &id) == OD_OK);
	c = od_DefaultMpmColliderDef();
	c.shape = OD_MPM_SPHERE;
	c.halfExtents[0] = 0.1;
	c.translation[0] = c.translation[1] = 0.5;
	c.translation[2] = 0.8;
	CHECK(od_MpmWorld_AddCollider(w, &c, &id) == OD_OK);
	double positions[8 * 3];
	for (int i = 0; i < 8; ++i)
	{
		positions[3 * i] = 0.4 + 0.1 * (i & 1);
		positions[3 * i + 1] = 0.4 + 0.1 * (i >> 1 & 1);
		positions[3 * i + 2] = 0.4 + 0.1 * (i >> 2 & 1);
	}
	od_MpmParticlesDef batch = od_DefaultMpmParticlesDef();
	batch.count = 8;
	batch.positions = positions;
	batch.particleVolume = 1e-4;
	CHECK(od_MpmWorld_AddParticles(w, &batch) == OD_OK);
	return w;
}

static unsigned char* save(const od_MpmWorld* w, size_t* size)
{
	*size = od_MpmWorld_StateSize(w);
	unsigned char* out = malloc(*size);
	CHECK(out != NULL);
	od_MpmWorld_SaveState(w, out);
	return out;
}

// Every field read into a buffer of exactly its size (ids index the output: ASan sees a stray write).
static void read_fields(const od_MpmWorld* w)
{
	int n = od_MpmWorld_GetParticleCount(w);
	for (int f = OD_MPM_POSITIONS; f <= OD_MPM_PLASTIC_J; ++f)
	{
		size_t count = (size_t)n * (size_t)od_MpmFieldWidth((od_MpmField)f);
		double* out = malloc(count * sizeof(double) + 1);
		CHECK(out != NULL);
		od_MpmWorld_Read(w, (od_MpmField)f, out);
		CHECK(f != OD_MPM_POSITIONS || fuzz_all_finite(out, count));
		free(out);
	}
}

static void step_and_check(od_MpmWorld* w)
{
	od_Status status = od_MpmWorld_Step(w, 1.0 / 240);
	TRACE("step -> %s\n", od_StatusName(status));
	CHECK(status == OD_OK || status == OD_ERROR_NOT_FINITE || status == OD_ERROR_ARGUMENT);
	if (status != OD_OK)
	{
		return;
	}
	int n = od_MpmWorld_GetParticleCount(w);
	double* x = malloc((size_t)n * 3 * sizeof(double) + 1);
	CHECK(x != NULL);
	od_MpmWorld_Read(w, OD_MPM_POSITIONS, x);
	for (int i = 0; i < 3 * n; ++i)
	{
		CHECK(isfinite(x[i]) && x[i] >= 0.0 && x[i] <= 1.0);
	}
	free(x);
	read_fields(w);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
	od_MpmWorld* w = make_world();
	size_t beforeSize, afterSize;
	unsigned char* before = save(w, &beforeSize);
	od_Status status = od_MpmWorld_LoadState(w, data, size);
	TRACE("load %zu bytes -> %s %s\n", size, od_StatusName(status), status == OD_OK ? "" : od_GetErrorMessage());
	if (status != OD_OK)
	{
		CHECK(status == OD_ERROR_ARGUMENT || status == OD_ERROR_MEMORY);
		unsigned char* after = save(w, &afterSize);
		CHECK(afterSize == beforeSize && memcmp(before, after, beforeSize) == 0);
		free(after);
	}
	else
	{
		CHECK(od_MpmWorld_StateSize(w) == size);
		unsigned char* again = save(w, &afterSize);
		od_MpmWorld* other = make_world();
		CHECK(od_MpmWorld_LoadState(other, again, afterSize) == OD_OK);
		size_t thirdSize;
		unsigned char* third = save(other, &thirdSize);
		CHECK(thirdSize == afterSize && memcmp(again, third, afterSize) == 0);
		free(third);
		free(again);
		od_MpmWorld_Destroy(other);
		read_fields(w);
		od_MpmWorld_UpdateOrientations(w);
		step_and_check(w);
	}
	free(before);
	od_MpmWorld_Destroy(w);
	return 0;
}
