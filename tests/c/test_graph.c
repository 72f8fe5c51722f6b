// Graph validation, pieces and skinning weights.
#include "opdeform/opdeform.h"
#include "test_macros.h"

#include <string.h>

static od_Status make(int n, const double* centers, const double* radii, const double* axes, int m, const int* edges,
					  od_Graph** g)
{
	od_GraphDef def = od_DefaultGraphDef();
	def.particleCount = n;
	def.centers = centers;
	def.radii = radii;
	def.axes = axes;
	def.edgeCount = m;
	def.edges = edges;
	return od_Graph_Create(&def, g);
}

int test_graph(void)
{
	double c[12] = { 0, 0, 0, 1, 0, 0, 2, 0, 0, 5, 0, 0 };
	double r[12] = { .5, .5, .5, .5, .5, .5, .5, .5, .5, .5, .5, .5 };
	int e[4] = { 0, 1, 1, 2 };
	od_Graph* g = NULL;
	ENSURE(make(4, c, r, NULL, 2, e, &g) == OD_OK);
	int piece[4];
	ENSURE(od_Graph_GetPieces(g, piece) == 2);
	ENSURE(piece[0] == piece[2] && piece[3] != piece[0]);

	int idx[4];
	double w[4];
	double p[3] = { 0.9, 0.1, 0 };
	int count = od_Graph_SkinWeights(g, p, 2, idx, w);
	ENSURE(count == 2 && idx[0] == 1 && idx[1] == 0);
	ENSURE_SMALL(w[0] + w[1] - 1.0, 1e-15);
	ENSURE(w[0] > w[1] && w[1] >= 0.0);
	count = od_Graph_SkinWeights(g, p, 8, idx, w); // more neighbours than the piece has: all of the piece
	ENSURE(count == 3 && idx[0] != 3 && idx[1] != 3 && idx[2] != 3);
	od_Graph_Destroy(g);

	// Bad input: each fails with OD_ERROR_ARGUMENT, a message naming the argument, and no graph.
	double bad_r[12];
	memcpy(bad_r, r, sizeof r);
	bad_r[4] = -1.0;
	ENSURE(make(4, c, bad_r, NULL, 2, e, &g) == OD_ERROR_ARGUMENT && g == NULL);
	ENSURE(strstr(od_GetErrorMessage(), "radii[1][1]") != NULL);
	double bad_c[12];
	memcpy(bad_c, c, sizeof c);
	bad_c[7] = NAN;
	ENSURE(make(4, bad_c, r, NULL, 2, e, &g) == OD_ERROR_ARGUMENT);
	ENSURE(strstr(od_GetErrorMessage(), "centers[2]") != NULL);
	int loop[2] = { 1, 1 }, out_of_range[2] = { 0, 4 }, dup[4] = { 0, 1, 1, 0 };
	ENSURE(make(4, c, r, NULL, 1, loop, &g) == OD_ERROR_ARGUMENT);
	ENSURE(strstr(od_GetErrorMessage(), "self-loop") != NULL);
	ENSURE(make(4, c, r, NULL, 1, out_of_range, &g) == OD_ERROR_ARGUMENT);
	ENSURE(strstr(od_GetErrorMessage(), "out of range") != NULL);
	ENSURE(make(4, c, r, NULL, 2, dup, &g) == OD_ERROR_ARGUMENT);
	ENSURE(strstr(od_GetErrorMessage(), "more than once") != NULL);
	double mirror[36];
	for (int i = 0; i < 4; ++i)
	{
		double f[9] = { 1, 0, 0, 0, 1, 0, 0, 0, -1 };
		memcpy(mirror + 9 * i, f, sizeof f);
	}
	ENSURE(make(4, c, r, mirror, 2, e, &g) == OD_ERROR_ARGUMENT);
	ENSURE(strstr(od_GetErrorMessage(), "axes[0]") != NULL);
	ENSURE(make(0, c, r, NULL, 0, e, &g) == OD_ERROR_ARGUMENT);
	return 0;
}
