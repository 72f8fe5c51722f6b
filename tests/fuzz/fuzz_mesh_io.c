// libFuzzer target: the OBJ and PLY readers (od_Mesh_ParseObj, od_Mesh_ParsePly) on arbitrary bytes (the
// first byte picks the reader, the rest is the file), and the writers on what was read.
// Invariants: a failed parse leaves an empty mesh and a message; a successful one gives triangles whose
// indices are in range; writing it as OBJ and as PLY and reading that back gives the same mesh (vertices
// bit for bit, NaN for NaN); od_Mesh_Free leaves an empty mesh. ASan checks every read stays in the data.
#include "fuzz_input.h"

#include "opdeform/mesh.h"

#include <stdlib.h>

static int same_double(double a, double b)
{
	return (isnan(a) && isnan(b)) || memcmp(&a, &b, sizeof a) == 0 || (a == 0.0 && b == 0.0 && signbit(a) == signbit(b));
}

static void check_same(const od_Mesh* a, const od_Mesh* b)
{
	CHECK(a->vertexCount == b->vertexCount);
	CHECK(a->triangleCount == b->triangleCount);
	for (int k = 0; k < 3 * a->vertexCount; ++k)
	{
		CHECK(same_double(a->vertices[k], b->vertices[k]));
	}
	CHECK(a->triangleCount == 0 || memcmp(a->triangles, b->triangles, sizeof(int) * 3 * a->triangleCount) == 0);
}

static void round_trip(const od_Mesh* mesh, int ply)
{
	char* text = NULL;
	size_t size = 0;
	od_Status status = ply ? od_Mesh_FormatPly(mesh->vertexCount, mesh->vertices, mesh->triangleCount, mesh->triangles,
											   &text, &size)
						   : od_Mesh_FormatObj(mesh->vertexCount, mesh->vertices, mesh->triangleCount, mesh->triangles,
											   &text, &size);
	CHECK(status == OD_OK);
	od_Mesh back;
	status = ply ? od_Mesh_ParsePly(text, size, &back) : od_Mesh_ParseObj(text, size, &back);
	CHECK(status == OD_OK);
	check_same(mesh, &back);
	od_Mesh_Free(&back);
	od_Mesh_FreeData(text);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
	if (size < 1)
	{
		return 0;
	}
	int ply = data[0] & 1;
	// An exact-size heap copy, so that ASan sees any read past the end of the data.
	char* copy = malloc(size - 1 ? size - 1 : 1);
	memcpy(copy, data + 1, size - 1);
	od_Mesh mesh;
	memset(&mesh, 0xab, sizeof mesh);
	od_Status status = ply ? od_Mesh_ParsePly(copy, size - 1, &mesh) : od_Mesh_ParseObj(copy, size - 1, &mesh);
	if (status != OD_OK)
	{
		CHECK(status == OD_ERROR_ARGUMENT);
		CHECK(mesh.vertexCount == 0 && mesh.triangleCount == 0 && mesh.vertices == NULL && mesh.triangles == NULL);
	}
	else
	{
		CHECK(mesh.vertexCount >= 0 && mesh.triangleCount >= 0);
		CHECK(mesh.vertexCount == 0 || mesh.vertices != NULL);
		CHECK(mesh.triangleCount == 0 || mesh.triangles != NULL);
		for (int k = 0; k < 3 * mesh.triangleCount; ++k)
		{
			CHECK(mesh.triangles[k] >= 0 && mesh.triangles[k] < mesh.vertexCount);
		}
		round_trip(&mesh, 0);
		round_trip(&mesh, 1);
	}
	od_Mesh_Free(&mesh);
	CHECK(mesh.vertexCount == 0 && mesh.vertices == NULL && mesh.triangles == NULL);
	free(copy);
	return 0;
}
