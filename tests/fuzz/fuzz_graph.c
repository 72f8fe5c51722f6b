// libFuzzer target: od_Graph_Create on arbitrary particles, radii, rest frames and edges (counts out of
// range, NaN, infinities, improper frames, self-loops, duplicates), then what a caller does with a graph:
// the getters, pieces, skinning weights and one simulation step on it.
// Invariants: a rejected graph leaves *graph NULL with a message; an accepted one returns what it was
// given, labels pieces consistently with the edges, gives skinning weights that are finite, in range and
// sum to 1, and a step either succeeds with a finite state or fails and keeps the rest state.
#include "fuzz_input.h"

#include "opdeform/opdeform.h"

#include <stdlib.h>

#define MAX_PARTICLES 48
#define MAX_EDGES 96

static void check_graph(const od_Graph* g, const od_GraphDef* def, FuzzInput* in)
{
	int n = def->particleCount;
	CHECK(od_Graph_GetParticleCount(g) == n);
	CHECK(od_Graph_GetEdgeCount(g) == def->edgeCount);
	CHECK(memcmp(od_Graph_GetCenters(g), def->centers, sizeof(double) * 3 * n) == 0);
	CHECK(memcmp(od_Graph_GetRadii(g), def->radii, sizeof(double) * 3 * n) == 0);
	CHECK(def->edgeCount == 0 || memcmp(od_Graph_GetEdges(g), def->edges, sizeof(int) * 2 * def->edgeCount) == 0);
	CHECK(fuzz_all_finite(od_Graph_GetAxes(g), (size_t)9 * n));

	int piece[MAX_PARTICLES];
	int pieces = od_Graph_GetPieces(g, piece);
	CHECK(pieces >= 1 && pieces <= n);
	for (int i = 0; i < n; ++i)
	{
		CHECK(piece[i] >= 0 && piece[i] < pieces);
	}
	for (int e = 0; e < def->edgeCount; ++e)
	{
		CHECK(piece[def->edges[2 * e]] == piece[def->edges[2 * e + 1]]);
	}

	for (int q = fuzz_int(in, 0, 3); q > 0; --q)
	{
		double p[3];
		fuzz_vec3(in, 1.0, p);
		int m = fuzz_int(in, -1, 20);
		int idx[20];
		double w[20];
		int count = od_Graph_SkinWeights(g, p, m, idx, w);
		CHECK(count >= 0 && count <= (m < 0 ? 0 : m < 16 ? m : 16) && count <= n);
		CHECK(m < 1 || count >= 1);
		double sum = 0.0;
		for (int k = 0; k < count; ++k)
		{
			CHECK(idx[k] >= 0 && idx[k] < n);
			CHECK(k == 0 || piece[idx[k]] == piece[idx[0]]);
			sum += w[k];
		}
		// Distances of points within 1e150 of every centre cannot overflow.
		int modest = fuzz_all_finite(p, 3) && fabs(p[0]) < 1e150 && fabs(p[1]) < 1e150 && fabs(p[2]) < 1e150;
		for (int i = 0; i < n && modest; ++i)
		{
			const double* c = od_Graph_GetCenters(g) + 3 * i;
			modest = fabs(c[0]) < 1e150 && fabs(c[1]) < 1e150 && fabs(c[2]) < 1e150;
		}
		if (modest && count > 0)
		{
			CHECK(fuzz_all_finite(w, (size_t)count));
			CHECK(fabs(sum - 1.0) < 1e-9);
		}
	}

	od_SimDef sdef = od_DefaultSimDef();
	sdef.iterations = 2;
	od_Sim* sim = NULL;
	if (od_Sim_Create(g, &sdef, &sim) == OD_OK)
	{
		od_Status status = od_Sim_Step(sim, 1);
		if (status == OD_OK)
		{
			CHECK(fuzz_all_finite(od_Sim_GetPositions(sim), (size_t)3 * n));
			CHECK(fuzz_all_finite(od_Sim_GetRotations(sim), (size_t)9 * n));
		}
		else
		{
			CHECK(od_GetErrorMessage()[0] != '\0');
			CHECK(memcmp(od_Sim_GetPositions(sim), def->centers, sizeof(double) * 3 * n) == 0);
		}
		od_Sim_Destroy(sim);
	}
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
	FuzzInput in = { data, size };
	int n = fuzz_int(&in, -1, MAX_PARTICLES);
	int m = fuzz_int(&in, -1, MAX_EDGES);
	int withAxes = fuzz_byte(&in) & 1;
	int nn = n > 0 ? n : 1, mm = m > 0 ? m : 1;
	double* centers = calloc((size_t)3 * nn, sizeof(double));
	double* radii = calloc((size_t)3 * nn, sizeof(double));
	double* axes = calloc((size_t)9 * nn, sizeof(double));
	int* edges = calloc((size_t)2 * mm, sizeof(int));
	for (int i = 0; i < n; ++i)
	{
		fuzz_vec3(&in, 1.0, centers + 3 * i);
		for (int k = 0; k < 3; ++k)
		{
			radii[3 * i + k] = fuzz_positive(&in, 0.1);
		}
		if (withAxes)
		{
			fuzz_frame(&in, axes + 9 * i);
		}
	}
	for (int e = 0; e < 2 * m; ++e)
	{
		edges[e] = fuzz_int(&in, -1, n);
	}

	od_GraphDef def = od_DefaultGraphDef();
	def.particleCount = n;
	def.centers = fuzz_byte(&in) == 255 ? NULL : centers;
	def.radii = radii;
	def.axes = withAxes ? axes : NULL;
	def.edgeCount = m;
	def.edges = edges;
	od_Graph* g = (od_Graph*)&in; // must be overwritten
	od_Status status = od_Graph_Create(&def, &g);
	TRACE("graph n %d m %d axes %d -> %s %s\n", n, m, withAxes, od_StatusName(status), status ? od_GetErrorMessage() : "");
	if (status == OD_OK)
	{
		CHECK(g != NULL);
		check_graph(g, &def, &in);
		od_Graph_Destroy(g);
	}
	else
	{
		CHECK(g == NULL);
		CHECK(status == OD_ERROR_ARGUMENT);
		CHECK(od_GetErrorMessage()[0] != '\0');
	}
	free(centers);
	free(radii);
	free(axes);
	free(edges);
	return 0;
}
