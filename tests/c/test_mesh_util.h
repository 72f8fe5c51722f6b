// Meshes for the C tests of the mesh parts: a closed box of quads split into triangles.
#pragma once

#include "opdeform/mesh.h"

#include <stdlib.h>
#include <string.h>

typedef struct test_Mesh
{
	int vertexCount, triangleCount;
	double* vertices;
	int* triangles;
} test_Mesh;

// The closed box [0, size[0]] x [0, size[1]] x [0, size[2]] + offset, n[a] divisions along axis a, triangles
// facing outwards. Free with test_free_mesh.
static inline test_Mesh test_box(const int n[3], const double size[3], const double offset[3])
{
	test_Mesh m = { 0, 0, NULL, NULL };
	int nx = n[0] + 1, ny = n[1] + 1, nz = n[2] + 1;
	int* id = malloc(sizeof(int) * (size_t)(nx * ny * nz));
	m.vertices = malloc(sizeof(double) * 3 * (size_t)(nx * ny * nz));
	m.triangles = malloc(sizeof(int) * 12 * (size_t)(n[0] * n[1] + n[1] * n[2] + n[2] * n[0]));
	for (int k = 0; k < nz; ++k)
	{
		for (int j = 0; j < ny; ++j)
		{
			for (int i = 0; i < nx; ++i)
			{
				int onSurface = i == 0 || j == 0 || k == 0 || i == n[0] || j == n[1] || k == n[2];
				int c[3] = { i, j, k };
				id[(k * ny + j) * nx + i] = onSurface ? m.vertexCount : -1;
				for (int a = 0; a < 3 && onSurface; ++a)
				{
					m.vertices[3 * m.vertexCount + a] = offset[a] + size[a] * c[a] / n[a];
				}
				m.vertexCount += onSurface;
			}
		}
	}
	for (int a = 0; a < 3; ++a)
	{
		int u = (a + 1) % 3, v = (a + 2) % 3;
		for (int side = 0; side < 2; ++side)
		{
			for (int i = 0; i < n[u]; ++i)
			{
				for (int j = 0; j < n[v]; ++j)
				{
					int corner[4][2] = { { i, j }, { i + 1, j }, { i + 1, j + 1 }, { i, j + 1 } };
					int q[4];
					for (int c = 0; c < 4; ++c)
					{
						int p[3];
						p[a] = side * n[a];
						p[u] = corner[c][0];
						p[v] = corner[c][1];
						q[side ? c : 3 - c] = id[(p[2] * ny + p[1]) * nx + p[0]];
					}
					int* t = m.triangles + 3 * m.triangleCount;
					t[0] = q[0], t[1] = q[1], t[2] = q[2], t[3] = q[0], t[4] = q[2], t[5] = q[3];
					m.triangleCount += 2;
				}
			}
		}
	}
	free(id);
	return m;
}

static inline void test_free_mesh(test_Mesh* m)
{
	free(m->vertices);
	free(m->triangles);
}

// The two meshes as one (a's vertices and triangles first). Free with test_free_mesh.
static inline test_Mesh test_concat(const test_Mesh* a, const test_Mesh* b)
{
	test_Mesh m = { a->vertexCount + b->vertexCount, a->triangleCount + b->triangleCount, NULL, NULL };
	m.vertices = malloc(sizeof(double) * 3 * (size_t)m.vertexCount);
	m.triangles = malloc(sizeof(int) * 3 * (size_t)m.triangleCount);
	memcpy(m.vertices, a->vertices, sizeof(double) * 3 * (size_t)a->vertexCount);
	memcpy(m.vertices + 3 * a->vertexCount, b->vertices, sizeof(double) * 3 * (size_t)b->vertexCount);
	memcpy(m.triangles, a->triangles, sizeof(int) * 3 * (size_t)a->triangleCount);
	for (int k = 0; k < 3 * b->triangleCount; ++k)
	{
		m.triangles[3 * a->triangleCount + k] = b->triangles[k] + a->vertexCount;
	}
	return m;
}

// A graph definition of `particles` particles over the mesh, the other fields at their defaults.
static inline od_MeshGraphDef test_graph_def(const test_Mesh* m, int particles)
{
	od_MeshGraphDef def = od_DefaultMeshGraphDef();
	def.vertexCount = m->vertexCount;
	def.vertices = m->vertices;
	def.triangleCount = m->triangleCount;
	def.triangles = m->triangles;
	def.particleCount = particles;
	return def;
}
