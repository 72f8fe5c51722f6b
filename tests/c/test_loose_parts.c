// Loose parts of a mesh (issue 12): a bead beside a bar is attached to the bar (no particles, every vertex
// skinned by the same bar particles) or has particles of its own joined to the bar; no vertex is ever
// skinned by particles of another piece; bad input is named.
#include "opdeform/mesh.h"
#include "test_macros.h"
#include "test_mesh_util.h"

#include <string.h>

#define TEST_MOST_PARTICLES 30

// A 2 m bar and a 0.1 m cube (a bead, 1/400 of its volume) just beside its middle: pieces 0 and 1.
static test_Mesh bar_and_bead(void)
{
	int nBar[3] = { 20, 2, 2 }, nBead[3] = { 2, 2, 2 };
	double barSize[3] = { 2.0, 0.2, 0.2 }, barAt[3] = { 0.0, -0.1, -0.1 };
	double beadSize[3] = { 0.1, 0.1, 0.1 }, beadAt[3] = { 0.95, 0.12, -0.05 };
	test_Mesh bar = test_box(nBar, barSize, barAt), bead = test_box(nBead, beadSize, beadAt);
	test_Mesh both = test_concat(&bar, &bead);
	test_free_mesh(&bar);
	test_free_mesh(&bead);
	return both;
}

static od_Status build(const test_Mesh* m, od_SmallPieces small, od_Graph** g)
{
	od_MeshGraphDef def = test_graph_def(m, 30);
	def.smallPieces = small;
	return od_Graph_CreateFromMesh(&def, g);
}

// The particles skinning each vertex of the bead (from vertex `first` on) belong to piece `want`, and
// (attached) every bead vertex has the same particles and weights.
static int check_skin(const od_Graph* g, const test_Mesh* m, int first, int want, bool shared)
{
	int label[TEST_MOST_PARTICLES];
	ENSURE(od_Graph_GetParticleCount(g) <= TEST_MOST_PARTICLES && od_Graph_GetMeshPieces(g, label) == 2);
	od_SkinDef def = od_DefaultSkinDef();
	def.vertexCount = m->vertexCount;
	def.vertices = m->vertices;
	od_Skin* skin = NULL;
	ENSURE(od_Skin_Create(g, &def, &skin) == OD_OK);
	const int* idx = od_Skin_GetIndices(skin);
	const double* w = od_Skin_GetWeights(skin);
	int fails = 0;
	for (int v = 0; v < m->vertexCount; ++v)
	{
		for (int k = 0; k < 4; ++k)
		{
			fails += label[idx[4 * v + k]] != (v < first ? 0 : want);
		}
		fails += shared && v > first && (memcmp(idx + 4 * v, idx + 4 * first, sizeof(int) * 4) != 0 ||
										  memcmp(w + 4 * v, w + 4 * first, sizeof(double) * 4) != 0);
	}
	od_Skin_Destroy(skin);
	ENSURE(fails == 0);
	return 0;
}

int test_loose_parts(void)
{
	test_Mesh m = bar_and_bead();
	int first = m.vertexCount - 26; // the bead's 26 vertices come last
	int label[TEST_MOST_PARTICLES];
	od_Graph* g = NULL;

	// Attached: no particle of its own, one graph piece, skinned by the bar alone and rigidly.
	ENSURE(build(&m, OD_SMALL_ATTACH, &g) == OD_OK);
	ENSURE(od_Graph_GetMeshPieces(g, label) == 2 && od_Graph_GetPieces(g, NULL) == 1);
	for (int i = 0; i < 30; ++i)
	{
		ENSURE(label[i] == 0);
	}
	ENSURE(check_skin(g, &m, first, 0, true) == 0);
	od_Graph_Destroy(g);

	// Its own: the bead is compact, so OD_SMALL_PIECE_PARTICLES from the budget (a long or flat piece gets
	// OD_SHELL_PARTICLES beyond it: tests/test_loose_parts.py); joined to the bar; each piece skinned by its own
	// particles only.
	ENSURE(build(&m, OD_SMALL_OWN, &g) == OD_OK);
	int own = 0, n = od_Graph_GetParticleCount(g);
	ENSURE(n <= TEST_MOST_PARTICLES && od_Graph_GetMeshPieces(g, label) == 2);
	for (int i = 0; i < n; ++i)
	{
		own += label[i] == 1;
	}
	ENSURE(own == OD_SMALL_PIECE_PARTICLES && n == 30 && od_Graph_GetPieces(g, NULL) == 1);
	ENSURE(check_skin(g, &m, first, 1, false) == 0);
	od_Graph_Destroy(g);

	// A graph not built from a mesh has no mesh pieces; a bad option is named.
	double c[3] = { 0, 0, 0 }, r[3] = { 1, 1, 1 };
	od_GraphDef def = od_DefaultGraphDef();
	def.particleCount = 1;
	def.centers = c;
	def.radii = r;
	ENSURE(od_Graph_Create(&def, &g) == OD_OK && od_Graph_GetMeshPieces(g, NULL) == 0);
	od_Graph_Destroy(g);
	ENSURE(build(&m, (od_SmallPieces)5, &g) == OD_ERROR_ARGUMENT && g == NULL);
	ENSURE(strstr(od_GetErrorMessage(), "small_pieces") != NULL);
	test_free_mesh(&m);
	return 0;
}
