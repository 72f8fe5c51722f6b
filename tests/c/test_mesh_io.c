// OBJ and PLY from memory: polygons, relative indices, binary PLY, exact round trips, errors.
#include "opdeform/mesh.h"
#include "test_macros.h"
#include "test_mesh_util.h"

#include <string.h>

static int round_trip(const test_Mesh* m, int ply)
{
	char* data = NULL;
	size_t size = 0;
	od_Status (*format)(int, const double*, int, const int*, char**, size_t*) =
		ply ? od_Mesh_FormatPly : od_Mesh_FormatObj;
	od_Status status = format(m->vertexCount, m->vertices, m->triangleCount, m->triangles, &data, &size);
	ENSURE(status == OD_OK);
	od_Mesh back;
	ENSURE((ply ? od_Mesh_ParsePly(data, size, &back) : od_Mesh_ParseObj(data, size, &back)) == OD_OK);
	ENSURE(back.vertexCount == m->vertexCount && back.triangleCount == m->triangleCount);
	ENSURE(memcmp(back.vertices, m->vertices, sizeof(double) * 3 * m->vertexCount) == 0);
	ENSURE(memcmp(back.triangles, m->triangles, sizeof(int) * 3 * m->triangleCount) == 0);
	od_Mesh_Free(&back);
	od_Mesh_FreeData(data);
	return 0;
}

int test_mesh_io(void)
{
	const char* obj = "# quad and triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\n"
					  "f 1/1 2/1 3/1 4/1\nf -4//1 -3//1 -1//1\n";
	od_Mesh m;
	ENSURE(od_Mesh_ParseObj(obj, strlen(obj), &m) == OD_OK);
	ENSURE(m.vertexCount == 4 && m.triangleCount == 3);
	int expected[9] = { 0, 1, 2, 0, 2, 3, 0, 1, 3 };
	ENSURE(memcmp(m.triangles, expected, sizeof expected) == 0);
	ENSURE(m.vertices[6] == 1.0 && m.vertices[7] == 1.0);
	od_Mesh_Free(&m);

	const char* ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
					  "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
					  "0 0 0\n1 0 0\n0 1 0.5\n3 2 1 0\n";
	ENSURE(od_Mesh_ParsePly(ply, strlen(ply), &m) == OD_OK);
	ENSURE(m.vertexCount == 3 && m.triangleCount == 1 && m.triangles[0] == 2 && m.vertices[8] == 0.5);
	od_Mesh_Free(&m);

	int n[3] = { 3, 2, 1 };
	double size[3] = { 1.0 / 3.0, 0.7, 1e-3 }, origin[3] = { -1.1, 2.0 / 7.0, 3.0 };
	test_Mesh box = test_box(n, size, origin);
	ENSURE(round_trip(&box, 0) == 0 && round_trip(&box, 1) == 0);

	// Errors name the problem and leave nothing allocated.
	const char* range = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 5\n";
	ENSURE(od_Mesh_ParseObj(range, strlen(range), &m) == OD_ERROR_ARGUMENT && m.vertices == NULL);
	ENSURE(strstr(od_GetErrorMessage(), "refers to vertex 4") != NULL);
	char* data = NULL;
	size_t bytes = 0;
	ENSURE(od_Mesh_FormatPly(box.vertexCount, box.vertices, box.triangleCount, box.triangles, &data, &bytes) == OD_OK);
	ENSURE(od_Mesh_ParsePly(data, bytes - 3, &m) == OD_ERROR_ARGUMENT);
	ENSURE(strstr(od_GetErrorMessage(), "ends before") != NULL);
	od_Mesh_FreeData(data);
	box.triangles[2] = -1;
	ENSURE(od_Mesh_FormatObj(box.vertexCount, box.vertices, box.triangleCount, box.triangles, &data, &bytes) ==
		   OD_ERROR_ARGUMENT);
	ENSURE(data == NULL);
	test_free_mesh(&box);
	return 0;
}
