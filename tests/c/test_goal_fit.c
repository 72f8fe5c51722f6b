// Goal frames fitted to an animated mesh: a rigid motion of the mesh gives every particle that motion,
// exactly, turned a little or nearly half a turn (beyond Newton's reach from the identity: the SVD's fallback),
// and the same bits whatever was fitted before; float32 vertices plus a shift fit as their float64 copy plus the
// shift, to the bit; a non-finite vertex that a fit reads fails it and nothing is written; od_GoalFit_Follow fits
// a new input only (test_follow).
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

// od_GoalFit_Follow: a new input fitted as od_GoalFit_ComputeShifted fits it and kept; the same input again (a zero
// as -0.0 too) not fitted, nothing written; another shift fitted; a vertex not finite refused with kept unchanged.
static int test_follow(const od_GoalFit* fit, float* single, const double shift[3], int vc, int np)
{
	size_t nx = sizeof(double) * 3 * (size_t)np, nr = sizeof(double) * 9 * (size_t)np;
	double *x = malloc(nx), *r = malloc(nr), *wantX = malloc(nx), *wantR = malloc(nr), keptShift[3];
	float* keptVertices = malloc(sizeof(float) * 3 * (size_t)vc);
	od_KeptInput kept = { keptVertices, keptShift, false };
	bool fitted = false;
	float first = single[0];
	single[0] = 0.0f; // kept as -0.0 below: equal
	ENSURE(od_GoalFit_ComputeShifted(fit, single, shift, wantX, wantR) == OD_OK);
	ENSURE(od_GoalFit_Follow(fit, single, shift, &kept, &fitted, x, r) == OD_OK && fitted && kept.valid);
	ENSURE(memcmp(x, wantX, nx) == 0 && memcmp(r, wantR, nr) == 0);
	ENSURE(memcmp(keptVertices, single, sizeof(float) * 3 * (size_t)vc) == 0 && memcmp(keptShift, shift, 24) == 0);
	keptVertices[0] = -0.0f;
	x[0] = 42.0;
	ENSURE(od_GoalFit_Follow(fit, single, shift, &kept, &fitted, x, r) == OD_OK && !fitted && x[0] == 42.0);
	double other[3] = { shift[0], shift[1] + 0.5, shift[2] };
	ENSURE(od_GoalFit_Follow(fit, single, other, &kept, &fitted, x, r) == OD_OK && fitted && keptShift[1] == other[1]);
	float saved = single[3 * (vc - 1) + 2];
	single[3 * (vc - 1) + 2] = INFINITY;
	x[0] = 42.0;
	ENSURE(od_GoalFit_Follow(fit, single, shift, &kept, &fitted, x, r) == OD_ERROR_ARGUMENT && !fitted &&
		   x[0] == 42.0 && keptShift[1] == other[1] && keptVertices[3 * (vc - 1) + 2] == saved);
	single[3 * (vc - 1) + 2] = saved;
	single[0] = first;
	free(x);
	free(r);
	free(wantX);
	free(wantR);
	free(keptVertices);
	return 0;
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
	ENSURE(test_follow(fit, single, shifts[1], box.vertexCount, np) == 0);
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
