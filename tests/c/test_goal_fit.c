// Goal frames fitted to an animated mesh: a rigid motion of the mesh gives every particle that motion,
// exactly, turned a little or nearly half a turn (beyond Newton's reach from the identity: the SVD's fallback),
// and the same bits whatever was fitted before; float32 vertices plus a shift fit as their float64 copy plus the
// shift, to the bit; a non-finite vertex that a fit reads fails it and nothing is written.
#include "opdeform/mesh.h"
#include "test_macros.h"
#include "test_mesh_util.h"

#include <string.h>

// p turned by angle about z, then moved by t.
static void turn_point(double angle, const double t[3], const double* p, double* out)
{
	out[0] = cos(angle) * p[0] - sin(angle) * p[1] + t[0];
	out[1] = sin(angle) * p[0] + cos(angle) * p[1] + t[1];
	out[2] = p[2] + t[2];
}

int test_goal_fit(void)
{
	int n[3] = { 12, 3, 3 };
	double size[3] = { 1.2, 0.3, 0.3 }, origin[3] = { 0.0, -0.15, -0.15 }, t[3] = { 0.3, -2.0, 1.0 };
	double angles[3] = { 1.1, 3.1, 1.1 };
	test_Mesh box = test_box(n, size, origin);
	od_MeshGraphDef gdef = test_graph_def(&box, 12);
	od_Graph* g = NULL;
	ENSURE(od_Graph_CreateFromMesh(&gdef, &g) == OD_OK);
	od_GoalFitDef def = od_DefaultGoalFitDef();
	def.vertexCount = box.vertexCount;
	def.vertices = box.vertices;
	od_GoalFit* fit = NULL;
	ENSURE(od_GoalFit_Create(g, &def, &fit) == OD_OK && od_GoalFit_GetVertexCount(fit) == box.vertexCount);
	double* moved = malloc(sizeof(double) * 3 * box.vertexCount);
	int np = od_Graph_GetParticleCount(g);
	double* x = malloc(sizeof(double) * 3 * np);
	double* r = malloc(sizeof(double) * 9 * np);
	double* first = malloc(sizeof(double) * 9 * np);
	for (int k = 0; k < 3; ++k)
	{
		double angle = angles[k];
		for (int v = 0; v < box.vertexCount; ++v)
		{
			turn_point(angle, t, box.vertices + 3 * v, moved + 3 * v);
		}
		ENSURE(od_GoalFit_Compute(fit, moved, x, r) == OD_OK);
		for (int j = 0; j < np; ++j)
		{
			double want[3];
			turn_point(angle, t, od_Graph_GetCenters(g) + 3 * j, want);
			for (int a = 0; a < 3; ++a)
			{
				ENSURE_SMALL(x[3 * j + a] - want[a], 1e-12);
			}
			ENSURE_SMALL(r[9 * j] - cos(angle), 1e-12);
			ENSURE_SMALL(r[9 * j + 3] - sin(angle), 1e-12);
			ENSURE_SMALL(r[9 * j + 8] - 1.0, 1e-12);
		}
		if (k == 0)
		{
			memcpy(first, r, sizeof(double) * 9 * np);
		}
	}
	ENSURE(memcmp(first, r, sizeof(double) * 9 * np) == 0);
	float* single = malloc(sizeof(float) * 3 * box.vertexCount);
	double* shiftedX = malloc(sizeof(double) * 3 * np);
	double* shiftedR = malloc(sizeof(double) * 9 * np);
	double shifts[2][3] = { { 0.0, 0.0, 0.0 }, { 0.25, 0.0, -1.5 } };
	for (int k = 0; k < 2; ++k)
	{
		for (int i = 0; i < 3 * box.vertexCount; ++i)
		{
			single[i] = (float)moved[i];
			moved[i] = (double)single[i] + (k ? shifts[k][i % 3] : 0.0);
		}
		ENSURE(od_GoalFit_ComputeShifted(fit, single, shifts[k], shiftedX, shiftedR) == OD_OK);
		ENSURE(od_GoalFit_Compute(fit, moved, x, r) == OD_OK);
		ENSURE(memcmp(x, shiftedX, sizeof(double) * 3 * np) == 0 && memcmp(r, shiftedR, sizeof(double) * 9 * np) == 0);
	}
	for (int v = 0; v < box.vertexCount; ++v)
	{
		single[3 * v + 1] = NAN;
	}
	shiftedX[0] = 42.0;
	ENSURE(od_GoalFit_ComputeShifted(fit, single, shifts[1], shiftedX, shiftedR) == OD_ERROR_ARGUMENT &&
		   shiftedX[0] == 42.0);
	free(single);
	free(shiftedX);
	free(shiftedR);
	for (int v = 0; v < box.vertexCount; ++v)
	{
		moved[3 * v + 1] = NAN;
	}
	x[0] = 42.0;
	ENSURE(od_GoalFit_Compute(fit, moved, x, r) == OD_ERROR_ARGUMENT && x[0] == 42.0);
	def.neighbors = 0;
	od_GoalFit* bad = NULL;
	ENSURE(od_GoalFit_Create(g, &def, &bad) == OD_ERROR_ARGUMENT && !bad);
	free(moved);
	free(x);
	free(r);
	free(first);
	od_GoalFit_Destroy(fit);
	od_Graph_Destroy(g);
	test_free_mesh(&box);
	return 0;
}
