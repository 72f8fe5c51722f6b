// The mesh skin: rest and rigid poses are exact, weights equal the constraints' ones, normals turn with
// the particles, and the threaded path gives the same bits as one thread; a shown offset whose reference is
// skinned in its own pass equals the skin deformed first, to the bit.
#include "opdeform/mesh.h"
#include "test_macros.h"
#include "test_mesh_util.h"

#include <string.h>

static od_Skin* make_skin(const od_Graph* g, const test_Mesh* m, int threads)
{
	od_SkinDef def = od_DefaultSkinDef();
	def.vertexCount = m->vertexCount;
	def.vertices = m->vertices;
	def.triangleCount = m->triangleCount;
	def.triangles = m->triangles;
	def.threadCount = threads;
	od_Skin* skin = NULL;
	return od_Skin_Create(g, &def, &skin) == OD_OK ? skin : NULL;
}

// Positions and rotations of every particle moved by the rotation r about the z axis by angle and t.
static void rigid_state(const od_Graph* g, double angle, const double t[3], double* x, double* r)
{
	double cs = cos(angle), sn = sin(angle);
	double rot[9] = { cs, -sn, 0, sn, cs, 0, 0, 0, 1 };
	for (int i = 0; i < od_Graph_GetParticleCount(g); ++i)
	{
		const double* c = od_Graph_GetCenters(g) + 3 * i;
		for (int a = 0; a < 3; ++a)
		{
			x[3 * i + a] = rot[3 * a] * c[0] + rot[3 * a + 1] * c[1] + rot[3 * a + 2] * c[2] + t[a];
		}
		memcpy(r + 9 * i, rot, sizeof rot);
	}
}

static int check_rigid(const od_Graph* g, const test_Mesh* m, const od_Skin* skin)
{
	int np = od_Graph_GetParticleCount(g), nv = m->vertexCount;
	double* x = malloc(sizeof(double) * 3 * np);
	double* r = malloc(sizeof(double) * 9 * np);
	double* out = malloc(sizeof(double) * 3 * nv);
	float* normals = malloc(sizeof(float) * 3 * nv);
	double t[3] = { 0.5, -1.0, 2.0 }, angle = 0.7;
	rigid_state(g, angle, t, x, r);
	od_SkinTarget target = { out, OD_FLOAT64, normals, OD_FLOAT32, NULL, OD_FLOAT64 };
	ENSURE(od_Skin_Deform(skin, x, r, &target) == OD_OK);
	const double* n0 = od_Skin_GetRestNormals(skin);
	for (int v = 0; v < nv; ++v)
	{
		const double* p = m->vertices + 3 * v;
		ENSURE_SMALL(out[3 * v] - (cos(angle) * p[0] - sin(angle) * p[1] + t[0]), 1e-13);
		ENSURE_SMALL(out[3 * v + 1] - (sin(angle) * p[0] + cos(angle) * p[1] + t[1]), 1e-13);
		ENSURE_SMALL(out[3 * v + 2] - (p[2] + t[2]), 1e-13);
		ENSURE_SMALL(normals[3 * v] - (cos(angle) * n0[3 * v] - sin(angle) * n0[3 * v + 1]), 1e-6);
		ENSURE_SMALL(normals[3 * v + 2] - n0[3 * v + 2], 1e-6);
	}
	free(x);
	free(r);
	free(out);
	free(normals);
	return 0;
}

int test_skinning(void)
{
	int n[3] = { 20, 2, 2 };
	double size[3] = { 2.0, 0.2, 0.2 }, origin[3] = { 0.0, -0.1, -0.1 };
	test_Mesh bar = test_box(n, size, origin);
	od_MeshGraphDef gdef = od_DefaultMeshGraphDef();
	gdef.vertexCount = bar.vertexCount;
	gdef.vertices = bar.vertices;
	gdef.triangleCount = bar.triangleCount;
	gdef.triangles = bar.triangles;
	gdef.particleCount = 20;
	od_Graph* g = NULL;
	ENSURE(od_Graph_CreateFromMesh(&gdef, &g) == OD_OK);
	od_Skin* skin = make_skin(g, &bar, 0);
	ENSURE(skin && od_Skin_GetNeighborCount(skin) == 4 && od_Skin_GetVertexCount(skin) == bar.vertexCount);

	// The constraints' weights, bit for bit; non-negative, summing to 1.
	for (int v = 0; v < bar.vertexCount; ++v)
	{
		int idx[4];
		double w[4], sum = 0.0;
		ENSURE(od_Graph_SkinWeights(g, bar.vertices + 3 * v, 4, idx, w) == 4);
		ENSURE(memcmp(idx, od_Skin_GetIndices(skin) + 4 * v, sizeof idx) == 0);
		ENSURE(memcmp(w, od_Skin_GetWeights(skin) + 4 * v, sizeof w) == 0);
		for (int k = 0; k < 4; ++k)
		{
			ENSURE(w[k] >= 0.0);
			sum += w[k];
		}
		ENSURE_SMALL(sum - 1.0, 1e-15);
	}
	ENSURE(check_rigid(g, &bar, skin) == 0);

	// No rest normals, no normals: asking for them is an error, positions alone are fine.
	od_SkinDef plain = od_DefaultSkinDef();
	plain.vertexCount = bar.vertexCount;
	plain.vertices = bar.vertices;
	od_Skin* noNormals = NULL;
	ENSURE(od_Skin_Create(g, &plain, &noNormals) == OD_OK && od_Skin_GetRestNormals(noNormals) == NULL);
	double* x = malloc(sizeof(double) * 3 * 20);
	double* r = malloc(sizeof(double) * 9 * 20);
	float* out = malloc(sizeof(float) * 3 * bar.vertexCount);
	double zero[3] = { 0, 0, 0 };
	rigid_state(g, 0.0, zero, x, r);
	od_SkinTarget target = { out, OD_FLOAT32, out, OD_FLOAT32, NULL, OD_FLOAT64 };
	ENSURE(od_Skin_Deform(noNormals, x, r, &target) == OD_ERROR_ARGUMENT);
	target.normals = NULL;
	ENSURE(od_Skin_Deform(noNormals, x, r, &target) == OD_OK);
	for (int k = 0; k < 3 * bar.vertexCount; ++k)
	{
		ENSURE(out[k] == (float)bar.vertices[k]); // the rest mesh
	}
	plain.neighbors = 0;
	od_Skin* bad = NULL;
	ENSURE(od_Skin_Create(g, &plain, &bad) == OD_ERROR_ARGUMENT && bad == NULL);
	free(x);
	free(r);
	free(out);
	od_Skin_Destroy(noNormals);
	od_Skin_Destroy(skin);

	// A mesh large enough for the thread pool: the same bits with one thread and with every core.
	int fine[3] = { 200, 40, 40 };
	test_Mesh big = test_box(fine, size, origin);
	od_Skin* one = make_skin(g, &big, 1);
	od_Skin* every = make_skin(g, &big, 0);
	ENSURE(one && every && big.vertexCount > 32768);
	size_t rows = (size_t)big.vertexCount * 4;
	ENSURE(memcmp(od_Skin_GetIndices(one), od_Skin_GetIndices(every), sizeof(int) * rows) == 0);
	ENSURE(memcmp(od_Skin_GetWeights(one), od_Skin_GetWeights(every), sizeof(double) * rows) == 0);
	double* x1 = malloc(sizeof(double) * 3 * 20);
	double* r1 = malloc(sizeof(double) * 9 * 20);
	double* a = malloc(sizeof(double) * 6 * big.vertexCount);
	double* b = malloc(sizeof(double) * 6 * big.vertexCount);
	double shift[3] = { 0.1, 0.2, 0.3 };
	rigid_state(g, 0.3, shift, x1, r1);
	x1[5] += 0.05; // not rigid
	od_SkinTarget ta = { a, OD_FLOAT64, a + 3 * big.vertexCount, OD_FLOAT64, NULL, OD_FLOAT64 };
	od_SkinTarget tb = { b, OD_FLOAT64, b + 3 * big.vertexCount, OD_FLOAT64, NULL, OD_FLOAT64 };
	ENSURE(od_Skin_Deform(one, x1, r1, &ta) == OD_OK && od_Skin_Deform(every, x1, r1, &tb) == OD_OK);
	ENSURE(memcmp(a, b, sizeof(double) * 6 * big.vertexCount) == 0);
	ENSURE(check_rigid(g, &big, every) == 0);
	size_t values = 3 * (size_t)big.vertexCount;
	double* skinned = malloc(sizeof(double) * values);
	float* input = malloc(sizeof(float) * 4 * values); // input, then the offset and output twice
	for (size_t k = 0; k < values; ++k)
	{
		skinned[k] = a[k] + 1e-3 * (double)(k % 7);
		input[k] = (float)(0.1 * (double)(k % 5));
	}
	od_ShownOffset(big.vertexCount, skinned, a, NULL, input, input + values, input + 2 * values);
	for (od_Skin* s = one; s; s = s == one ? every : NULL) // one thread, then the pool
	{
		float* offset = input + 3 * values;
		float* out = malloc(sizeof(float) * values);
		ENSURE(od_Skin_DeformShown(s, x1, r1, skinned, NULL, input, offset, out) == OD_OK);
		ENSURE(memcmp(offset, input + values, sizeof(float) * values) == 0);
		ENSURE(memcmp(out, input + 2 * values, sizeof(float) * values) == 0);
		ENSURE(od_Skin_DeformShown(s, x1, r1, NULL, NULL, input, offset, out) == OD_ERROR_ARGUMENT);
		free(out);
	}
	free(skinned);
	free(input);
	free(x1);
	free(r1);
	free(a);
	free(b);
	od_Skin_Destroy(one);
	od_Skin_Destroy(every);
	od_Graph_Destroy(g);
	test_free_mesh(&bar);
	test_free_mesh(&big);
	return 0;
}
