// libFuzzer target: mesh input. od_Graph_CreateFromMesh on small arbitrary meshes (degenerate, flat,
// repeated vertices, out-of-range indices, NaN) in every mode, then od_Skin_Create and od_Skin_Deform of
// the same mesh on that graph, in float64 and float32, with and without normals.
// Invariants: a rejected mesh leaves *graph NULL; an accepted one is a valid graph of the requested
// particle count (od_Graph_Create's rules: finite, radii > 0, edges in range); a skin gives every vertex
// indices in range and weights that sum to 1, and deforming with the rest state (x = X̄, R = I) gives
// back the rest vertices; finite states give finite positions and unit normals.
// Sizes are bounded (24 vertices, 32 triangles, 40 particles, 40 voxels per particle) to keep inputs fast.
#include "fuzz_input.h"

#include "opdeform/mesh.h"

#include <stdlib.h>

#define MAX_V 24
#define MAX_T 32

static void check_skin(const od_Graph* g, const od_Skin* skin, const double* vertices, int vertexCount, int withNormals,
					   FuzzInput* in)
{
	int n = od_Graph_GetParticleCount(g);
	int m = od_Skin_GetNeighborCount(skin);
	CHECK(od_Skin_GetVertexCount(skin) == vertexCount);
	CHECK(m >= 1 && m <= 16 && m <= n);
	const int* idx = od_Skin_GetIndices(skin);
	const double* w = od_Skin_GetWeights(skin);
	for (int v = 0; v < vertexCount; ++v)
	{
		double sum = 0.0;
		for (int k = 0; k < m; ++k)
		{
			CHECK(idx[v * m + k] >= 0 && idx[v * m + k] < n);
			CHECK(isfinite(w[v * m + k]) && w[v * m + k] >= 0.0);
			sum += w[v * m + k];
		}
		CHECK(fabs(sum - 1.0) < 1e-9);
	}

	double* x = malloc(sizeof(double) * 3 * n);
	double* r = malloc(sizeof(double) * 9 * n);
	double* out = malloc(sizeof(double) * 3 * (vertexCount ? vertexCount : 1));
	double* normals = malloc(sizeof(double) * 3 * (vertexCount ? vertexCount : 1));
	float* out32 = malloc(sizeof(float) * 3 * (vertexCount ? vertexCount : 1));
	memcpy(x, od_Graph_GetCenters(g), sizeof(double) * 3 * n);
	for (int i = 0; i < n; ++i)
	{
		static const double eye[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
		memcpy(r + 9 * i, eye, sizeof eye);
	}
	od_SkinTarget target = { .positions = out, .positionType = OD_FLOAT64 };
	CHECK(od_Skin_Deform(skin, x, r, &target) == OD_OK);
	double scale = 1.0;
	for (int k = 0; k < 3 * vertexCount; ++k)
	{
		scale = fmax(scale, fabs(vertices[k]));
	}
	for (int k = 0; k < 3 * vertexCount; ++k)
	{
		CHECK(fabs(out[k] - vertices[k]) <= 1e-9 * scale);
	}

	// A random state: moved centres and rotated frames.
	for (int i = 0; i < n; ++i)
	{
		double d[3];
		fuzz_vec3(in, 0.1, d);
		for (int k = 0; k < 3; ++k)
		{
			x[3 * i + k] += d[k];
		}
		fuzz_frame(in, r + 9 * i);
	}
	int single = fuzz_byte(in) & 1;
	target = (od_SkinTarget){ .positions = single ? (void*)out32 : (void*)out,
							  .positionType = single ? OD_FLOAT32 : OD_FLOAT64,
							  .normals = withNormals ? normals : NULL,
							  .normalType = OD_FLOAT64 };
	od_Status status = od_Skin_Deform(skin, x, r, &target);
	CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
	// Finite inputs of modest size (no overflow in p - X̄ or R p) give finite positions.
	int modest = fuzz_all_finite(x, (size_t)3 * n) && fuzz_all_finite(r, (size_t)9 * n) && scale < 1e150;
	for (int k = 0; k < 3 * n && modest; ++k)
	{
		modest = fabs(x[k]) < 1e150;
	}
	for (int k = 0; k < 9 * n && modest; ++k)
	{
		modest = fabs(r[k]) < 1e150;
	}
	if (status == OD_OK && modest)
	{
		for (int k = 0; k < 3 * vertexCount; ++k)
		{
			CHECK(single || isfinite(out[k])); // float32 may overflow where float64 does not
		}
	}
	free(x);
	free(r);
	free(out);
	free(normals);
	free(out32);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
	FuzzInput in = { data, size };
	static double vertices[3 * MAX_V];
	static int triangles[3 * MAX_T];
	int vertexCount = fuzz_int(&in, -1, MAX_V);
	int triangleCount = fuzz_int(&in, -1, MAX_T);
	double scale = fuzz_byte(&in) < 8 ? fuzz_double(&in, 1.0) : 0.05 * fuzz_int(&in, 1, 40);
	for (int k = 0; k < 3 * vertexCount; ++k)
	{
		vertices[k] = fuzz_double(&in, scale);
	}
	for (int k = 0; k < 3 * triangleCount; ++k)
	{
		triangles[k] = fuzz_int(&in, -1, vertexCount);
	}
	od_MeshGraphDef def = od_DefaultMeshGraphDef();
	def.vertexCount = vertexCount;
	def.vertices = vertices;
	def.triangleCount = triangleCount;
	def.triangles = triangles;
	def.particleCount = fuzz_int(&in, -1, 40);
	def.mode = (od_MeshGraphMode)fuzz_int(&in, -1, 4);
	def.joinPieces = fuzz_byte(&in) & 1;
	def.voxelsPerParticle = fuzz_int(&in, -1, 40);
	if (fuzz_tracing())
	{
		for (int v = 0; v < vertexCount; ++v)
		{
			TRACE("v %.17g %.17g %.17g\n", vertices[3 * v], vertices[3 * v + 1], vertices[3 * v + 2]);
		}
		for (int t = 0; t < triangleCount; ++t)
		{
			TRACE("f %d %d %d\n", triangles[3 * t] + 1, triangles[3 * t + 1] + 1, triangles[3 * t + 2] + 1);
		}
		TRACE("# particles %d mode %d join %d voxels_per_particle %d\n", def.particleCount, (int)def.mode,
			  (int)def.joinPieces, def.voxelsPerParticle);
	}
	od_Graph* g = (od_Graph*)&in;
	od_Status status = od_Graph_CreateFromMesh(&def, &g);
	TRACE("graph from mesh -> %s %s\n", od_StatusName(status), status ? od_GetErrorMessage() : "");
	if (status != OD_OK)
	{
		CHECK(g == NULL);
		CHECK(status == OD_ERROR_ARGUMENT || status == OD_ERROR_MEMORY);
		return 0;
	}
	int n = od_Graph_GetParticleCount(g);
	CHECK(n == def.particleCount);
	CHECK(fuzz_all_finite(od_Graph_GetCenters(g), (size_t)3 * n));
	const double* radii = od_Graph_GetRadii(g);
	for (int k = 0; k < 3 * n; ++k)
	{
		CHECK(isfinite(radii[k]) && radii[k] > 0.0);
	}
	const int* edges = od_Graph_GetEdges(g);
	for (int e = 0; e < 2 * od_Graph_GetEdgeCount(g); ++e)
	{
		CHECK(edges[e] >= 0 && edges[e] < n);
	}
	// The graph must be one od_Graph_Create accepts as it is.
	od_GraphDef gdef = od_DefaultGraphDef();
	gdef.particleCount = n;
	gdef.centers = od_Graph_GetCenters(g);
	gdef.radii = radii;
	gdef.axes = od_Graph_GetAxes(g);
	gdef.edgeCount = od_Graph_GetEdgeCount(g);
	gdef.edges = edges;
	od_Graph* again = NULL;
	CHECK(od_Graph_Create(&gdef, &again) == OD_OK);
	od_Graph_Destroy(again);

	od_SkinDef sdef = od_DefaultSkinDef();
	sdef.vertexCount = vertexCount;
	sdef.vertices = vertices;
	int normals = fuzz_int(&in, 0, 2); // none, from the triangles, given
	sdef.triangleCount = normals == 1 ? triangleCount : 0;
	sdef.triangles = normals == 1 ? triangles : NULL;
	static double given[3 * MAX_V];
	for (int k = 0; k < 3 * vertexCount && normals == 2; ++k)
	{
		given[k] = fuzz_double(&in, 1.0);
	}
	sdef.normals = normals == 2 ? given : NULL;
	sdef.neighbors = fuzz_int(&in, -1, 17);
	sdef.threadCount = fuzz_int(&in, -1, 2);
	od_Skin* skin = NULL;
	status = od_Skin_Create(g, &sdef, &skin);
	if (status == OD_OK)
	{
		check_skin(g, skin, vertices, vertexCount, normals != 0, &in);
		od_Skin_Destroy(skin);
	}
	else
	{
		CHECK(skin == NULL);
		CHECK(status == OD_ERROR_ARGUMENT);
	}
	od_Graph_Destroy(g);
	return 0;
}
