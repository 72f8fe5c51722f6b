// Graphs built from meshes: the chain of the paper's bar, connected pieces, determinism, bad input.
#include "opdeform/mesh.h"
#include "test_macros.h"
#include "test_mesh_util.h"

#include <string.h>

static od_Status build(const test_Mesh* m, int particles, od_MeshGraphMode mode, bool join, od_Graph** g)
{
	od_MeshGraphDef def = test_graph_def(m, particles);
	def.mode = mode;
	def.joinPieces = join;
	return od_Graph_CreateFromMesh(&def, g);
}

static int same_graph(const od_Graph* a, const od_Graph* b)
{
	int n = od_Graph_GetParticleCount(a), m = od_Graph_GetEdgeCount(a);
	return n == od_Graph_GetParticleCount(b) && m == od_Graph_GetEdgeCount(b) &&
		   memcmp(od_Graph_GetCenters(a), od_Graph_GetCenters(b), sizeof(double) * 3 * n) == 0 &&
		   memcmp(od_Graph_GetRadii(a), od_Graph_GetRadii(b), sizeof(double) * 3 * n) == 0 &&
		   memcmp(od_Graph_GetAxes(a), od_Graph_GetAxes(b), sizeof(double) * 9 * n) == 0 &&
		   memcmp(od_Graph_GetEdges(a), od_Graph_GetEdges(b), sizeof(int) * 2 * m) == 0;
}

int test_mesh_graph(void)
{
	// The bar of Figs. 1-2: a chain of 20 particles and 19 edges along x, one after the other.
	int n[3] = { 20, 2, 2 };
	double size[3] = { 2.0, 0.2, 0.2 }, origin[3] = { 0.0, -0.1, -0.1 };
	test_Mesh bar = test_box(n, size, origin);
	od_Graph *g = NULL, *h = NULL;
	ENSURE(build(&bar, 20, OD_MESH_CHAIN, false, &g) == OD_OK);
	ENSURE(od_Graph_GetParticleCount(g) == 20 && od_Graph_GetEdgeCount(g) == 19);
	const int* e = od_Graph_GetEdges(g);
	const double* c = od_Graph_GetCenters(g);
	for (int k = 0; k < 19; ++k)
	{
		ENSURE(e[2 * k] == k && e[2 * k + 1] == k + 1);
		ENSURE(fabs(c[3 * (k + 1)] - c[3 * k]) > 0.05);
	}
	ENSURE(od_Graph_GetPieces(g, NULL) == 1);
	od_Graph_Destroy(g);

	// Auto mode: connected, positive radii; the same input gives the same graph bit for bit.
	ENSURE(build(&bar, 30, OD_MESH_AUTO, false, &g) == OD_OK);
	ENSURE(build(&bar, 30, OD_MESH_AUTO, false, &h) == OD_OK);
	ENSURE(same_graph(g, h));
	ENSURE(od_Graph_GetPieces(g, NULL) == 1);
	for (int k = 0; k < 3 * 30; ++k)
	{
		ENSURE(od_Graph_GetRadii(g)[k] > 0.0);
	}
	od_Graph_Destroy(g);
	od_Graph_Destroy(h);

	// Two boxes: two pieces, or one when joined.
	double far[3] = { 0.0, 1.0, 0.0 };
	test_Mesh other = test_box(n, size, far);
	test_Mesh both = test_concat(&bar, &other);
	ENSURE(build(&both, 24, OD_MESH_AUTO, false, &g) == OD_OK);
	ENSURE(od_Graph_GetPieces(g, NULL) == 2);
	od_Graph_Destroy(g);
	ENSURE(build(&both, 24, OD_MESH_SURFACE, true, &g) == OD_OK);
	ENSURE(od_Graph_GetPieces(g, NULL) == 1);
	od_Graph_Destroy(g);

	// Bad input fails with OD_ERROR_ARGUMENT and a message naming the problem, and no graph.
	test_Mesh empty = bar;
	empty.triangleCount = 0;
	ENSURE(build(&empty, 5, OD_MESH_AUTO, false, &g) == OD_ERROR_ARGUMENT && g == NULL);
	ENSURE(strstr(od_GetErrorMessage(), "empty") != NULL);
	ENSURE(build(&bar, bar.vertexCount + 1, OD_MESH_AUTO, false, &g) == OD_ERROR_ARGUMENT);
	ENSURE(strstr(od_GetErrorMessage(), "distinct vertices") != NULL);
	ENSURE(build(&bar, 5, (od_MeshGraphMode)7, false, &g) == OD_ERROR_ARGUMENT);
	ENSURE(strstr(od_GetErrorMessage(), "mode") != NULL);
	bar.triangles[4] = bar.vertexCount;
	ENSURE(build(&bar, 5, OD_MESH_AUTO, false, &g) == OD_ERROR_ARGUMENT);
	ENSURE(strstr(od_GetErrorMessage(), "triangles[1] refers to vertex") != NULL);
	bar.triangles[4] = 0;
	bar.vertices[7] = NAN;
	ENSURE(build(&bar, 5, OD_MESH_AUTO, false, &g) == OD_ERROR_ARGUMENT && g == NULL);
	ENSURE(strstr(od_GetErrorMessage(), "vertices[2] is not finite") != NULL);

	test_free_mesh(&bar);
	test_free_mesh(&other);
	test_free_mesh(&both);
	return 0;
}
