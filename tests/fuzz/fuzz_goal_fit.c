// libFuzzer target: GoalFit, whose pickle is its constructor's arguments (a graph, rest vertices, neighbours:
// unpickling builds it again, issue 28), then one fit: od_GoalFit_Create on the 8-particle chain of
// tests/fuzz/make_state_corpus.py with raw rest vertices, then od_GoalFit_Compute with raw animated vertices and
// od_GoalFit_ComputeShifted with them as float32, shifted by the first vertex.
// Input: an int32 neighbour count, an int32 vertex count V (cut to what the bytes hold), V rest vertices and
// V animated ones (doubles). Invariants: a refused fit leaves *fit NULL; an accepted one has indices in range
// and weights >= 0 summing to 1 per particle; a fit returns finite positions and proper rotations or
// OD_ERROR_ARGUMENT.
#include "fuzz_chain.h"

#include "opdeform/mesh.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>

#define N CHAIN_N

static void check_fit(const od_GoalFit* fit, int vertices)
{
	int k = od_GoalFit_GetNeighborCount(fit);
	CHECK(k >= 1 && k <= vertices && k <= OD_MAX_GOAL_NEIGHBORS);
	const int* idx = od_GoalFit_GetIndices(fit);
	const double* w = od_GoalFit_GetWeights(fit);
	for (int j = 0; j < N; ++j)
	{
		double sum = 0.0;
		for (int a = 0; a < k; ++a)
		{
			CHECK(idx[k * j + a] >= 0 && idx[k * j + a] < vertices);
			CHECK(isfinite(w[k * j + a]) && w[k * j + a] >= 0.0);
			sum += w[k * j + a];
		}
		CHECK(fabs(sum - 1.0) < 1e-9);
	}
}

static void check_frames(const double* positions, const double* rotations)
{
	CHECK(fuzz_all_finite(positions, N * 3) && fuzz_all_finite(rotations, N * 9));
	for (int j = 0; j < N; ++j)
	{
		const double* r = rotations + 9 * j;
		for (int a = 0; a < 3; ++a)
		{
			for (int b = 0; b < 3; ++b)
			{
				double dot = r[a] * r[b] + r[3 + a] * r[3 + b] + r[6 + a] * r[6 + b];
				CHECK(fabs(dot - (a == b)) < 1e-6);
			}
		}
	}
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
	int32_t head[2] = { 0, 0 };
	memcpy(head, data, size < sizeof head ? size : sizeof head);
	size_t rest = size < sizeof head ? 0 : size - sizeof head, fit = rest / 48;
	int vertices = head[1] < 0 ? head[1] : (int)((size_t)head[1] < fit ? (size_t)head[1] : fit);
	double* rest_vertices = malloc(sizeof(double) * 3 * (fit + 1));
	double* animated = malloc(sizeof(double) * 3 * (fit + 1));
	CHECK(rest_vertices && animated);
	memcpy(rest_vertices, data + sizeof head, 24 * fit);
	memcpy(animated, data + sizeof head + 24 * fit, 24 * fit);
	od_GoalFitDef def = od_DefaultGoalFitDef();
	def.vertexCount = vertices;
	def.vertices = rest_vertices;
	def.neighbors = head[0];
	od_GoalFit* goals = (od_GoalFit*)&def;
	od_Status status = od_GoalFit_Create(chain(), &def, &goals);
	TRACE("create %d vertices, %d neighbours -> %s %s\n", vertices, head[0], od_StatusName(status),
		  status == OD_OK ? "" : od_GetErrorMessage());
	if (status != OD_OK)
	{
		CHECK(goals == NULL && (status == OD_ERROR_ARGUMENT || status == OD_ERROR_MEMORY));
	}
	else
	{
		check_fit(goals, vertices);
		double positions[N * 3], rotations[N * 9];
		status = od_GoalFit_Compute(goals, animated, positions, rotations);
		TRACE("fit -> %s %s\n", od_StatusName(status), status == OD_OK ? "" : od_GetErrorMessage());
		CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
		if (status == OD_OK)
		{
			check_frames(positions, rotations);
		}
		float* single = malloc(sizeof(float) * 3 * (size_t)vertices);
		CHECK(single != NULL);
		for (int i = 0; i < 3 * vertices; ++i)
		{
			double a = animated[i]; // out of float's range: infinite (a cast would be undefined behaviour)
			single[i] = isnan(a) ? NAN : a > FLT_MAX ? INFINITY : a < -FLT_MAX ? -INFINITY : (float)a;
		}
		status = od_GoalFit_ComputeShifted(goals, single, animated, positions, rotations);
		TRACE("shifted fit -> %s\n", od_StatusName(status));
		CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
		if (status == OD_OK)
		{
			check_frames(positions, rotations);
		}
		free(single);
		od_GoalFit_Destroy(goals);
	}
	free(rest_vertices);
	free(animated);
	return 0;
}
